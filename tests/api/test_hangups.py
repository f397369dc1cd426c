"""Trace uploads cut short, against ``srg serve`` itself and the log it writes.

The finding: ``POST /api/traces`` read the body before the token and the rate limits, and a
client that sent part of a body and hung up left two tracebacks (~7.9 KB) in the log, so
2,000 hang-ups added 15.4 MB. Now the token and the limits come first, and a hang-up costs
one access line at most.
"""

from __future__ import annotations

import json
import os
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from http.client import HTTPConnection
from pathlib import Path
from urllib.parse import urlsplit

import httpx
import pytest

SRG = Path(sys.executable).with_name("srg")

#: hang-ups sent: each would have logged two tracebacks
HANGUPS = 20
#: a declared body well within max_trace_bytes that never comes
UNSENT_BYTES = 900_000
#: seconds srg serve may take to answer its first request on a busy machine
START_S = 60


@pytest.fixture(scope="module")
def served(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[str, Path]]:
    """``srg serve`` on a free port of loopback (the embedded SQLite database), and its log."""
    tmp_path = tmp_path_factory.mktemp("served")
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    environment = {
        **{k: v for k, v in os.environ.items() if not k.startswith("SRG_")},
        "SRG_VAR_DIR": str(tmp_path / "var"),
        "SRG_RATE_LIMIT_STORAGE": "memory://",
    }
    log = tmp_path / "serve.log"
    with log.open("w") as out:
        server = subprocess.Popen(
            [str(SRG), "serve", "--port", str(port)], stdout=out, stderr=out, env=environment
        )
    base_url = f"http://127.0.0.1:{port}"
    try:
        deadline = time.monotonic() + START_S
        while not _answers(base_url):
            assert server.poll() is None, log.read_text()
            assert time.monotonic() < deadline, log.read_text()
            time.sleep(0.2)
        yield base_url, log
    finally:
        server.terminate()
        server.wait(timeout=30)


def _answers(base_url: str) -> bool:
    try:
        return httpx.get(f"{base_url}/api/health", timeout=1).status_code == 200
    except httpx.TransportError:
        return False


def test_a_client_that_hangs_up_mid_body_leaves_no_traceback(
    served: tuple[str, Path],
) -> None:
    base_url, log = served
    token = httpx.post(f"{base_url}/api/players", timeout=10).json()["token"]
    logged_before = len(log.read_text())
    body = json.dumps({"publication_id": 1, "idempotency_key": "k" * 16, "steps": []}).encode()
    address = urlsplit(base_url)
    head = (
        "POST /api/traces HTTP/1.1\r\n"
        f"Host: {address.netloc}\r\n"
        "Content-Type: application/json\r\n"
        f"Content-Length: {2 * len(body)}\r\n"
        f"Authorization: Bearer {token}\r\n\r\n"
    ).encode()
    for _ in range(HANGUPS):
        with socket.create_connection((address.hostname, address.port), timeout=5) as raw:
            raw.sendall(head + body)  # half of what it declared, then the hang-up
    time.sleep(1)  # the server notices each hang-up
    assert _answers(base_url)
    written = log.read_text()[logged_before:]
    assert "Traceback" not in written and "ERROR" not in written, written
    uploads = [line for line in written.splitlines() if "/api/traces" in line]
    assert len(uploads) <= HANGUPS, written


@pytest.mark.parametrize(("token", "status"), [(None, 401), ("not-a-player-token", 403)])
def test_an_upload_without_a_valid_token_is_refused_before_its_body_is_read(
    served: tuple[str, Path], token: str | None, status: int
) -> None:
    """The declared body is never sent: a refusal that waited for it would time out."""
    base_url, _ = served
    address = urlsplit(base_url)
    connection = HTTPConnection(address.hostname or "", address.port, timeout=5)
    connection.putrequest("POST", "/api/traces")
    connection.putheader("Content-Type", "application/json")
    connection.putheader("Content-Length", str(UNSENT_BYTES))
    if token is not None:
        connection.putheader("Authorization", f"Bearer {token}")
    connection.endheaders()
    reply = connection.getresponse()
    assert reply.status == status
    assert set(json.loads(reply.read())) == {"error", "details"}
    connection.close()
