"""Checks that only a served app shows, over a real socket: a request framed two ways is
refused and its connection closed, and ``/api/health`` notices a SQLite file overwritten
under the running server."""

from __future__ import annotations

import json
import socket
from collections.abc import Iterator
from pathlib import Path
from urllib.parse import urlsplit

import httpx
import pytest
from sqlalchemy import func, select

from app.api.app import create_app
from app.api.bodylimit import TWO_FRAMINGS
from app.api.local_server import serve_in_thread
from app.api.routes.health import QUICK_CHECK_INTERVAL_S, SqliteIntegrity
from app.config import Settings
from app.db.engines import dispose_engines, make_engine, sqlite_file
from app.models import Base, Player

SOCKET_TIMEOUT_S = 10.0


@pytest.fixture
def settings(tmp_path: Path) -> Iterator[Settings]:
    """A SQLite file with srg's tables, its writes checkpointed into the file."""
    settings = Settings(
        database_url=f"sqlite:///{tmp_path / 'served.sqlite3'}", artifact_dir=tmp_path / "data"
    )
    engine = make_engine(settings.resolved_database_url)
    Base.metadata.create_all(engine)
    engine.dispose()
    yield settings
    dispose_engines()


def players(settings: Settings) -> int:
    engine = make_engine(settings.resolved_database_url)
    try:
        with engine.connect() as connection:
            return int(connection.scalar(select(func.count()).select_from(Player)) or 0)
    finally:
        engine.dispose()


def exchange(base_url: str, request: bytes) -> bytes:
    """Send ``request`` raw and read until the server closes the connection."""
    address = urlsplit(base_url)
    with socket.create_connection(
        (address.hostname, address.port), timeout=SOCKET_TIMEOUT_S
    ) as sock:
        sock.sendall(request)
        received = b""
        while chunk := sock.recv(65536):
            received += chunk
    return received


def chunked(body: bytes) -> bytes:
    return f"{len(body):x}\r\n".encode() + body + b"\r\n0\r\n\r\n"


def test_content_length_with_transfer_encoding_is_a_400_that_closes_the_connection(
    settings: Settings,
) -> None:
    """A proxy that frames by Content-Length would pass the chunked body's tail on as the
    next request: here nothing after the headers is read, and the connection closes."""
    smuggled = b"POST /api/players HTTP/1.1\r\nHost: x\r\nContent-Length: 2\r\n\r\n{}"
    body = chunked(b'{"kind": "bot"}') + smuggled
    head = (
        b"POST /api/players HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n"
        b"Content-Length: 15\r\nTransfer-Encoding: chunked\r\n\r\n"
    )
    with serve_in_thread(create_app(settings)) as base_url:
        reply = exchange(base_url, head + body)
        status_line, _, rest = reply.partition(b"\r\n")
        headers, _, content = rest.partition(b"\r\n\r\n")
        assert status_line == b"HTTP/1.1 400 Bad Request"
        assert b"connection: close" in headers.lower()
        assert json.loads(content) == {"error": TWO_FRAMINGS, "details": None}
        assert reply.count(b"HTTP/1.1 ") == 1  # the smuggled request was never answered
        assert players(settings) == 0
        # either framing alone is served
        alone = head.replace(b"Content-Length: 15\r\n", b"Connection: close\r\n")
        assert exchange(base_url, alone + chunked(b'{"kind": "bot"}')).startswith(b"HTTP/1.1 201 ")
        assert httpx.post(f"{base_url}/api/players", json={"kind": "bot"}).status_code == 201
    assert players(settings) == 2


def test_health_runs_quick_check_at_most_once_an_interval_and_is_503_when_it_fails(
    settings: Settings,
) -> None:
    now = [0.0]
    app = create_app(settings)
    app.state.sqlite_integrity = SqliteIntegrity(settings, clock=lambda: now[0])
    file = sqlite_file(settings.resolved_database_url)
    assert file is not None
    with serve_in_thread(app) as base_url:
        assert httpx.get(f"{base_url}/api/health").status_code == 200
        with file.open("r+b") as damaged:  # a page of the tables overwritten, header kept
            damaged.seek(2 * 4096)
            damaged.write(bytes(range(256)) * 16)
        now[0] += QUICK_CHECK_INTERVAL_S / 2
        assert httpx.get(f"{base_url}/api/health").status_code == 200  # not checked again
        now[0] += QUICK_CHECK_INTERVAL_S / 2
        reply = httpx.get(f"{base_url}/api/health")
        assert (reply.status_code, reply.json()) == (
            503,
            {
                "error": "the sqlite database fails its integrity check",
                "details": {"database": "sqlite", "reason": "corrupt"},
            },
        )
        assert str(file.parent) not in reply.text
        file.write_bytes(b"SQLite format 3\x00" + bytes(range(256)) * 64)  # all of it
        now[0] += QUICK_CHECK_INTERVAL_S
        reply = httpx.get(f"{base_url}/api/health")
        assert (reply.status_code, reply.json()["details"]["reason"]) == (503, "not a database")
