"""The database's failures are never a 500: writes survive SQLite's locks, and a database
that cannot serve is a 503 in the usual ``{error, details}`` body on every route."""

from __future__ import annotations

import time
from collections.abc import Iterator
from pathlib import Path

import httpx
import pytest
from api_helpers import ADMIN_TOKEN, toy_graph_database
from fastapi.testclient import TestClient

from app.api.app import create_app
from app.api.local_server import serve_in_thread
from app.config import Settings

ADMIN = {"Authorization": f"Bearer {ADMIN_TOKEN}"}
#: growth long enough (seconds) for several publishes to run inside it even when a
#: publish is slow: with 24 a loaded machine fitted one publish into the whole growth
EXPANSIONS = 120


@pytest.fixture
def growing(tmp_path: Path) -> Iterator[Settings]:
    """A SQLite file holding the toy graph ``g``, grown in epochs of 3 (a commit a step)."""
    settings = Settings().replace(
        database_url=f"sqlite:///{tmp_path / 'growing.sqlite3'}",
        artifact_dir=tmp_path / "data",
        admin_token=ADMIN_TOKEN,
        growth_renders=False,
        batch_size=3,
    )
    yield toy_graph_database(settings)


def test_publish_succeeds_while_the_server_grows_the_graph(growing: Settings) -> None:
    """The finding: publish read, the growth committed, publish wrote: "database is locked"
    at once (a deferred transaction cannot upgrade a stale snapshot), a 500 three of three."""
    with serve_in_thread(create_app(growing)) as base_url, httpx.Client(base_url=base_url) as http:
        queued = http.post("/api/graphs/g/grow", json={"expansions": EXPANSIONS}, headers=ADMIN)
        assert queued.status_code == 202, queued.text
        published, deadline = [], time.monotonic() + 120
        while http.get(queued.json()["poll"], headers=ADMIN).json()["running"]:
            assert time.monotonic() < deadline
            reply = http.post("/api/graphs/g/publish", headers=ADMIN, timeout=60)
            assert reply.status_code == 200, reply.text
            published.append(reply.json()["result"]["number"])
        epochs = http.get(queued.json()["poll"], headers=ADMIN).json()["epochs"]
    assert len(published) >= 2, "no publish ran alongside the growth: grow more"
    assert published == list(range(1, len(published) + 1))
    assert [(e["status"], e["expansions"]) for e in epochs] == [("finished", 3)] * (EXPANSIONS // 3)


UNREACHABLE = "postgresql+psycopg://postgres@127.0.0.1:1/none"


def garbage_sqlite(path: Path) -> str:
    """The URL of a file that is not a database, though it starts like one."""
    path.write_bytes(b"SQLite format 3\x00" + bytes(range(256)) * 20)
    return f"sqlite:///{path}"


@pytest.mark.parametrize(
    ("database", "problem"), [("postgresql", "unreachable"), ("sqlite", "not a database")]
)
def test_every_route_answers_503_when_the_database_cannot_serve(
    tmp_path: Path, database: str, problem: str
) -> None:
    """The finding: every data route answered 500 "internal error" (only health said 503)."""
    url = UNREACHABLE if database == "postgresql" else garbage_sqlite(tmp_path / "x.sqlite3")
    settings = Settings().replace(
        database_url=url,
        artifact_dir=tmp_path / "data",
        admin_token=ADMIN_TOKEN,
        rate_limit_storage="memory://",
    )
    app = create_app(settings)
    expected = {
        "error": f"the database is unavailable: {problem}",
        "details": {"database": database, "reason": problem},
    }
    answered = {}
    with TestClient(app, raise_server_exceptions=False) as client:
        for path, operations in app.openapi()["paths"].items():
            if path == "/api/health":  # its own 503: test_protocol
                continue
            for method in operations:
                url = path.format(name="g", digest="0" * 64, publication_id=1)
                reply = client.request(method, url, params={"frames": 1}, headers=ADMIN)
                answered[f"{method} {path}"] = reply.status_code
                if method != "head":
                    assert reply.json() == expected, (method, path)
    assert set(answered.values()) == {503}, answered
    assert "post /api/traces" in answered and "post /api/graphs/{name}/publish" in answered
