"""Admin routes: off until a token is set; growth queued (202), never run in the request."""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx
import pytest
import redis
from api_helpers import ADMIN_TOKEN, Published, make_client, toy_graph_database
from fastapi.testclient import TestClient
from kombu import Connection
from sqlalchemy import func, select
from sqlalchemy.orm import Session

import app.services.growing
from app.api.app import create_app
from app.api.local_server import serve_in_thread
from app.config import ApiSettings, Settings
from app.models import Clip
from app.models import Publication as PublicationRow
from app.store.artifacts import ArtifactStore
from app.store.epochs import start_epoch
from app.store.growth_requests import add_request, failure_reason, start_request

ADMIN = {"Authorization": f"Bearer {ADMIN_TOKEN}"}
OFF = {"error": "admin routes are off: set SRG_ADMIN_TOKEN", "details": None}
#: a broker no worker of the tests consumes from (tests/cli/test_cli_options.py sends there too)
IDLE_BROKER = "redis://127.0.0.1:6379/15"
#: nothing listens there: a broker that is down
DOWN_BROKER = "redis://127.0.0.1:1/0"


def admin_requests(name: str) -> list[tuple[str, str]]:
    base = f"/api/graphs/{name}"
    return [("POST", f"{base}/publish"), ("POST", f"{base}/grow"), ("GET", f"{base}/epochs")]


def test_there_is_no_default_admin_token() -> None:
    assert ApiSettings.model_fields["admin_token"].default == ""


def test_with_no_admin_token_the_admin_routes_are_off(
    session: Session, db_url: str, artifact_dir: Path, published: Published
) -> None:
    """The finding: with SRG_ADMIN_TOKEN unset, ``Bearer change-me`` grew and published."""
    with make_client(session, db_url, artifact_dir, admin_token="") as off:
        for method, url in admin_requests(published.name):
            for headers in ({"Authorization": "Bearer change-me"}, {}, {"Authorization": "x"}):
                reply = off.request(method, url, headers=headers)
                assert reply.status_code == 403, (method, url, reply.text)
                assert reply.json() == OFF
    publications = session.scalar(select(func.count()).select_from(PublicationRow))
    assert publications == 1


def test_the_server_warns_at_start_when_admin_routes_are_off_and_never_logs_the_token(
    session: Session, db_url: str, artifact_dir: Path, caplog: pytest.LogCaptureFixture
) -> None:
    with caplog.at_level(logging.INFO):
        with make_client(session, db_url, artifact_dir, admin_token=""):
            pass
        off = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]
        assert off == ["admin routes are off (grow and publish answer 403): set SRG_ADMIN_TOKEN"]
        caplog.clear()
        with make_client(session, db_url, artifact_dir, admin_token="s3cret-admin-token"):
            pass
    assert not [r for r in caplog.records if r.levelno >= logging.WARNING]
    assert "s3cret" not in caplog.text


def test_admin_grow_answers_202_and_its_epochs_are_polled(
    client: TestClient, published: Published
) -> None:
    reply = client.post(f"/api/graphs/{published.name}/grow", json={"expansions": 5}, headers=ADMIN)
    assert reply.status_code == 202, reply.text
    queued = reply.json()
    assert queued == {
        "graph": published.name,
        "expansions": 5,
        "runs_on": "server",
        "request": queued["request"],
        "after_epoch": 0,
        "poll": f"/api/graphs/{published.name}/epochs?after=0",
    }
    # the test client returns once the background job is done; a server answers at once
    polled = client.get(queued["poll"], headers=ADMIN)
    assert polled.status_code == 200, polled.text
    answer = polled.json()
    assert answer["graph"] == published.name and answer["running"] is False
    epochs = answer["epochs"]
    assert [(e["number"], e["status"], e["expansions"]) for e in epochs] == [
        (1, "finished", 4),
        (2, "finished", 1),
    ]
    assert epochs[1]["planned"] == 1 and epochs[1]["finished_at"] is not None
    assert answer["growth"] == {
        "request": queued["request"],
        "expansions": 5,
        "runs_on": "server",
        "state": "finished",
        "reason": None,
    }
    later = client.get(f"/api/graphs/{published.name}/epochs?after=2", headers=ADMIN)
    assert later.json()["epochs"] == []


def test_a_background_growth_that_fails_says_why_on_its_poll(
    client: TestClient,
    published: Published,
    session: Session,
    artifacts: ArtifactStore,
    caplog: pytest.LogCaptureFixture,
) -> None:
    """Accepted (202), then failed after the answer: the poll says failed and why, not
    ``running: false`` beside finished epochs. The why names no path of the server (the
    ``corrupt/`` folder the file went to); the server's log does."""
    bundles = set(session.scalars(select(Clip.bundle).where(Clip.graph_id == published.graph_id)))
    for digest in bundles:
        path = artifacts.path_for(digest)
        path.write_bytes(path.read_bytes()[::-1])
    with caplog.at_level(logging.WARNING):
        reply = client.post(
            f"/api/graphs/{published.name}/grow", json={"expansions": 3}, headers=ADMIN
        )
        assert reply.status_code == 202, reply.text
        answer = client.get(reply.json()["poll"], headers=ADMIN).json()
    assert answer["running"] is False
    growth = answer["growth"]
    assert growth["request"] == reply.json()["request"] and growth["state"] == "failed"
    assert "does not match its hash" in growth["reason"]
    assert str(artifacts.root) not in growth["reason"] and "/corrupt" not in growth["reason"]
    assert any(str(artifacts.corrupt_path(digest)) in caplog.text for digest in bundles)


def test_a_failed_growth_names_what_failed_on_disk_but_not_the_file() -> None:
    """A write refused under the artifact directory: the poll's reason says why, the
    server's path stays in its log."""
    denied = PermissionError(13, "Permission denied", "/srv/srg/artifacts/ab/cd/.tmp-1")
    assert failure_reason(denied) == "PermissionError: Permission denied"
    assert failure_reason(ValueError("bad")) == "ValueError: bad"


def test_a_server_growth_whose_job_is_gone_is_reported_failed(
    client: TestClient, published: Published, session: Session
) -> None:
    """A request left running by a server that stopped is not running for ever."""
    request_id = add_request(session, published.graph_id, 9, "server")
    start_request(session, request_id)
    session.commit()
    growth = client.get(f"/api/graphs/{published.name}/epochs", headers=ADMIN).json()["growth"]
    assert growth["request"] == request_id and growth["state"] == "failed"
    assert "ended without recording" in growth["reason"]


def test_bad_admin_grow_requests_get_4xx_json(client: TestClient, published: Published) -> None:
    grow = f"/api/graphs/{published.name}/grow"
    assert client.post("/api/graphs/nope/grow", headers=ADMIN).status_code == 404
    assert client.get("/api/graphs/nope/epochs", headers=ADMIN).status_code == 404
    for payload in ({"expansions": 0}, {"expansions": 10_001}, {"expansions": "4"}, {"x": 1}):
        reply = client.post(grow, json=payload, headers=ADMIN)
        assert reply.status_code == 422 and reply.json()["error"] == "invalid request"
    assert client.get(f"{grow[:-5]}/epochs?after=-1", headers=ADMIN).status_code == 422
    jobs = client.app.state.growth_jobs  # type: ignore[attr-defined]
    assert jobs.claim(published.graph_id)  # as if a grow of this server were under way
    busy = client.post(grow, headers=ADMIN)
    assert busy.status_code == 409
    assert busy.json()["error"] == f"graph {published.name!r} is already growing in this server"
    assert client.get(f"{grow[:-5]}/epochs", headers=ADMIN).json()["running"] is True


def test_with_a_broker_admin_grow_sends_grow_epoch_to_the_workers(
    session: Session, db_url: str, artifact_dir: Path, published: Published
) -> None:
    settings: dict[str, Any] = {"broker_url": IDLE_BROKER, "growth_renders": False}
    with make_client(session, db_url, artifact_dir, **settings) as workers:
        grow = f"/api/graphs/{published.name}/grow"
        try:
            reply = workers.post(grow, json={"expansions": 7}, headers=ADMIN)
            assert reply.status_code == 202, reply.text
            assert reply.json()["runs_on"] == "workers" and reply.json()["after_epoch"] == 0
            sent = (published.graph_id, 7, False, reply.json()["request"])
            assert sent in tasks_queued(IDLE_BROKER, "srg.grow_epoch")
            start_epoch(session, published.graph_id, "sr-crowd")  # a worker's epoch is running
            session.commit()
            busy = workers.post(grow, headers=ADMIN)
            assert busy.status_code == 409
            assert busy.json()["error"].startswith("epoch 1 of graph 'api-toy' is running")
            assert busy.json()["details"]["poll"] == f"/api/graphs/{published.name}/epochs?after=1"
            assert sent not in tasks_queued(IDLE_BROKER, "srg.grow_epoch")
        finally:
            redis.Redis.from_url(IDLE_BROKER).delete("celery")  # the tasks nobody will run


def test_with_the_broker_down_admin_grow_is_a_503_at_once_and_its_request_failed(
    session: Session, db_url: str, artifact_dir: Path, published: Published
) -> None:
    """The finding: a 500 after 19 s (Celery's retries), the request ``queued`` for ever."""
    settings: dict[str, Any] = {"broker_url": DOWN_BROKER, "growth_renders": False}
    with make_client(session, db_url, artifact_dir, **settings) as workers:
        started = time.monotonic()
        reply = workers.post(f"/api/graphs/{published.name}/grow", headers=ADMIN)
        assert time.monotonic() - started < 5
        assert reply.status_code == 503, reply.text
        assert set(reply.json()) == {"error", "details"}
        assert reply.json()["error"].startswith("the broker cannot take the growth: ")
        growth = workers.get(f"/api/graphs/{published.name}/epochs", headers=ADMIN).json()
    assert growth["running"] is False
    assert growth["growth"] == {
        "request": growth["growth"]["request"],
        "expansions": 4,
        "runs_on": "workers",
        "state": "failed",
        "reason": reply.json()["error"],
    }


def tasks_queued(broker: str, task: str) -> list[tuple[Any, ...]]:
    """The arguments of each ``task`` waiting in the broker's default queue, taken off it."""
    found: list[tuple[Any, ...]] = []
    with Connection(broker) as connection, connection.SimpleQueue("celery") as queue:
        while True:
            try:
                message = queue.get(timeout=0.2)
            except queue.Empty:
                return found
            message.ack()
            if message.headers.get("task") == task:
                found.append(tuple(message.payload[0]))


@pytest.fixture
def served(tmp_path: Path) -> Iterator[Settings]:
    """Settings of a SQLite database holding the toy graph ``g``, growth without renders."""
    settings = Settings().replace(
        database_url=f"sqlite:///{tmp_path / 'admin.sqlite3'}",
        artifact_dir=tmp_path / "data",
        admin_token=ADMIN_TOKEN,
        growth_renders=False,
    )
    yield toy_graph_database(settings)


def test_over_http_the_grow_request_returns_before_the_growth_runs(
    served: Settings, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The finding: the route grew inside the request (up to 10,000 expansions)."""
    release = threading.Event()
    grow_graph = app.services.growing.grow_graph

    def held_grow_graph(*args: Any, **kwargs: Any) -> Any:
        assert release.wait(30), "the test never released the growth"
        return grow_graph(*args, **kwargs)

    monkeypatch.setattr(app.services.growing, "grow_graph", held_grow_graph)
    with serve_in_thread(create_app(served)) as base_url, httpx.Client(base_url=base_url) as http:
        reply = http.post("/api/graphs/g/grow", json={"expansions": 6}, headers=ADMIN, timeout=10)
        assert reply.status_code == 202, reply.text
        poll = reply.json()["poll"]
        waiting = http.get(poll, headers=ADMIN).json()
        assert waiting["running"] is True and waiting["epochs"] == []
        assert http.post("/api/graphs/g/grow", headers=ADMIN).status_code == 409
        release.set()
        deadline = time.monotonic() + 60
        while (answer := http.get(poll, headers=ADMIN).json())["running"]:
            assert time.monotonic() < deadline, answer
            time.sleep(0.05)
    assert [(e["status"], e["expansions"]) for e in answer["epochs"]] == [
        ("finished", 4),
        ("finished", 2),
    ]
