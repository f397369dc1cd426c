"""``/docs`` and ``/redoc`` work without internet: every script, style sheet and icon
their pages load comes from this server, none from a CDN."""

from __future__ import annotations

import re

import pytest
from fastapi.testclient import TestClient

ASSET = re.compile(r"""(?:src|href)\s*=\s*["']([^"']+)["']""")
BUNDLES = {"/docs": "swagger-ui-bundle.js", "/redoc": "redoc.standalone.js"}


@pytest.mark.parametrize("page", ["/docs", "/redoc"])
def test_the_docs_pages_load_only_this_server_s_files(client: TestClient, page: str) -> None:
    reply = client.get(page)
    assert reply.status_code == 200
    html = reply.text
    assert "http://" not in html and "https://" not in html
    assets = ASSET.findall(html)
    assert any(url.endswith(BUNDLES[page]) for url in assets), assets
    for url in assets:
        asset = client.get(url)
        assert asset.status_code == 200, url
        assert len(asset.content) > 1000, url  # the file itself, not a placeholder
    assert "/openapi.json" in html
    assert client.get("/openapi.json").status_code == 200
