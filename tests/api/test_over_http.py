"""Bots over real HTTP on loopback, what uvicorn answers itself, and the ingest bench at a
small size."""

from __future__ import annotations

import json
from collections.abc import Iterator
from http.client import HTTPConnection
from pathlib import Path
from urllib.parse import urlsplit

import pytest
from sqlalchemy import func, select

from app.api.app import create_app
from app.api.client import ServerError, play_over_http
from app.api.local_server import serve_in_thread
from app.api.serving import UNREADABLE
from app.bench.ingest import bench_ingest, build_toy_graph
from app.config import Settings
from app.db.engines import make_engine
from app.db.sessions import session_factory
from app.models import Base, Trace, TraceStep
from app.store.artifacts import ArtifactStore
from app.store.publications import publish


@pytest.fixture
def settings(tmp_path: Path) -> Iterator[Settings]:
    settings = Settings(
        database_url=f"sqlite:///{tmp_path / 'http.sqlite3'}", artifact_dir=tmp_path / "data"
    )
    engine = make_engine(settings.resolved_database_url)
    Base.metadata.create_all(engine)
    with session_factory(engine)() as session:
        toy = build_toy_graph(
            session, ArtifactStore(settings.resolved_artifact_dir), name="http-toy"
        )
        publish(session, toy.graph_id, toy.graph)
        session.commit()
    engine.dispose()
    yield settings


def test_bots_play_over_http_and_every_trace_is_stored(settings: Settings) -> None:
    with serve_in_thread(create_app(settings)) as base_url:
        result = play_over_http(base_url, "http-toy", "goal-directed", 5, 12, seed=3)
    assert (result["sessions"], result["created"], result["replayed"]) == (5, 5, 0)
    engine = make_engine(settings.resolved_database_url)
    with session_factory(engine)() as session:
        assert session.scalar(select(func.count()).select_from(Trace)) == 5
        assert session.scalar(select(func.count()).select_from(TraceStep)) == result["steps"]
    engine.dispose()


def test_an_unknown_graph_over_http_names_the_server_error(settings: Settings) -> None:
    with (
        serve_in_thread(create_app(settings)) as base_url,
        pytest.raises(ServerError, match="404 no graph 'nope'"),
    ):
        play_over_http(base_url, "nope", "random", 1, 5, seed=0)


def _connection(base_url: str) -> HTTPConnection:
    address = urlsplit(base_url)
    return HTTPConnection(address.hostname or "", address.port, timeout=10)


@pytest.mark.parametrize("lengths", [["abc"], ["-1"], ["5", "7"]])
def test_a_request_uvicorn_cannot_frame_is_a_400_in_the_error_shape(
    settings: Settings, lengths: list[str]
) -> None:
    """h11 refuses a malformed Content-Length before the app sees it: it was plain text."""
    with serve_in_thread(create_app(settings)) as base_url:
        connection = _connection(base_url)
        connection.putrequest("POST", "/api/players")
        for length in lengths:
            connection.putheader("Content-Length", length)
        connection.endheaders(b"{}")
        reply = connection.getresponse()
        assert (reply.status, reply.getheader("Content-Type")) == (400, "application/json")
        assert json.loads(reply.read()) == {"error": UNREADABLE, "details": None}


def test_head_over_http_answers_get_s_headers_without_the_body(settings: Settings) -> None:
    with serve_in_thread(create_app(settings)) as base_url:
        connection = _connection(base_url)
        connection.request("GET", "/api/graphs")
        got = connection.getresponse()
        body = got.read()
        connection.request("HEAD", "/api/graphs")
        head = connection.getresponse()
        assert (head.status, head.read()) == (200, b"")
        assert head.getheader("Content-Length") == got.getheader("Content-Length") == str(len(body))
        connection.request("GET", "/api/health")  # the connection still frames requests
        assert connection.getresponse().status == 200


def test_the_ingest_bench_accounts_for_every_upload() -> None:
    result = bench_ingest(clients=12, uploads=2, mean_steps=20)
    assert result["ok"] is True
    assert result["created_201"] == result["replays_200_same_id"] == result["stored_traces"] == 24
    assert result["stored_steps"] == result["expected_steps"]
    assert result["latency_ms"]["p99"] >= result["latency_ms"]["p50"] > 0
