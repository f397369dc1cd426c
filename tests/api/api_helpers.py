"""Helpers of the API tests: a client on the test's session, players, traces, row counts."""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from fastapi.testclient import TestClient
from sqlalchemy import func, select
from sqlalchemy.orm import Session

from app.api.app import create_app
from app.api.deps import get_session, growth_transactions
from app.config import Settings
from app.core.graph.publication import Publication
from app.models import Player, Trace, TraceStep
from app.services.epochs import in_session

ADMIN_TOKEN = "test-admin-token"


@dataclass(frozen=True)
class Published:
    name: str
    graph_id: int
    publication_id: int
    publication: Publication
    #: an image artifact attached to edge 0 (vertex 0, control 0) only
    animation: str
    #: a clip bundle artifact: stored, but not an animation
    bundle: str


def make_client(
    session: Session,
    db_url: str,
    artifact_dir: Path,
    *,
    peer: str = "testclient",
    **settings: Any,
) -> TestClient:
    """A client of an app on the test's session; requests come from the address ``peer``.

    Rate limits are kept in the app's memory unless ``rate_limit_storage`` says otherwise,
    so no test shares its windows with another (or with another run on the same Redis).
    """
    values: dict[str, Any] = {
        "database_url": db_url,
        "artifact_dir": artifact_dir,
        "admin_token": ADMIN_TOKEN,
        "rate_limit_storage": "memory://",
        **settings,
    }
    app = create_app(Settings().replace(**values))

    def joined_session() -> Iterator[Session]:
        try:
            yield session
        except BaseException:
            session.rollback()
            raise

    app.dependency_overrides[get_session] = joined_session
    # background growth in the test's session too (the test client runs it before answering)
    app.dependency_overrides[growth_transactions] = lambda: in_session(session)
    return TestClient(app, client=(peer, 50000))


def register(client: TestClient, kind: str = "person") -> dict[str, str]:
    """Authorization headers of a freshly registered player."""
    reply = client.post("/api/players", json={"kind": kind})
    assert reply.status_code == 201, reply.text
    return {"Authorization": f"Bearer {reply.json()['token']}"}


def walk(publication: Publication, controls: list[int]) -> list[list[int]]:
    """The trace that plays ``controls`` from the start vertex."""
    steps, vertex = [], publication.start
    for control in controls:
        steps.append([vertex, control])
        vertex = publication.destination(vertex, control)
    return steps


def row_counts(session: Session) -> tuple[int, int, int]:
    """(traces, trace steps, sum of traces.n_steps): equal step counts mean no partial trace."""
    traces = session.scalar(select(func.count()).select_from(Trace)) or 0
    steps = session.scalar(select(func.count()).select_from(TraceStep)) or 0
    declared = session.scalar(select(func.coalesce(func.sum(Trace.n_steps), 0))) or 0
    return int(traces), int(steps), int(declared)


def player_count(session: Session) -> int:
    return int(session.scalar(select(func.count()).select_from(Player)) or 0)


def toy_graph_database(settings: Settings) -> Settings:
    """Make the tables of ``settings``' SQLite file and the toy graph ``g`` in it."""
    from app.db.engines import make_engine
    from app.db.sessions import session_factory
    from app.models import Base
    from app.services.creation import init_graph

    engine = make_engine(settings.resolved_database_url)
    Base.metadata.create_all(engine)
    with session_factory(engine)() as session:
        init_graph(session, settings, name="g", strategy="sr-heuristic")
        session.commit()
    engine.dispose()
    return settings
