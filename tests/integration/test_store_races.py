"""Two writers racing past the pre-checks: the database's unique index decides, and the
store turns its refusal into our error family, not an ``IntegrityError``.

On PostgreSQL the second writer's read does not see the first's uncommitted row, so it
writes the same key and waits on the index; once the first commits it is refused. The
tests hold the first writer's commit until the second is seen waiting, so the race
happens every run. (SQLite takes its write lock before the read, so it has no such race.)
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterator

import pytest
from database_helpers import postgres_base_url, postgres_database
from sqlalchemy import Engine, text
from sqlalchemy.orm import Session, sessionmaker

from app.core.errors import SrgError
from app.core.graph.graph_entry import GraphScene
from app.db.engines import make_engine
from app.db.sessions import session_factory
from app.store.epochs import EpochTaken, start_epoch
from app.store.graph_catalogue import GraphExists, create_graph

pytestmark = pytest.mark.postgres

WAIT_S = 20.0


@pytest.fixture
def engine() -> Iterator[Engine]:
    for url in postgres_database(postgres_base_url(), migrated=True):
        engine = make_engine(url)
        yield engine
        engine.dispose()


def new_graph(session: Session, name: str) -> int:
    return create_graph(
        session,
        name=name,
        dynamics="toy",
        n_controls=3,
        frames_per_clip=10,
        scene=GraphScene(preset="small"),
    )


def waiting_writers(engine: Engine) -> int:
    """Backends of this database waiting for a lock another transaction holds."""
    with engine.connect() as connection:
        return int(
            connection.execute(
                text(
                    "SELECT count(*) FROM pg_locks l JOIN pg_stat_activity a ON a.pid = l.pid "
                    "WHERE NOT l.granted AND a.datname = current_database()"
                )
            ).scalar_one()
        )


def race(engine: Engine, write: Callable[[Session], object]) -> BaseException | None:
    """``write`` in two transactions: the second starts while the first is uncommitted,
    and the first commits once the second waits. What the second raised, if anything."""
    sessions: sessionmaker[Session] = session_factory(engine)
    raised: list[BaseException] = []
    with sessions() as first, sessions() as second:
        write(first)

        def racing() -> None:
            try:
                write(second)
                second.commit()
            except BaseException as exc:  # noqa: BLE001 - handed to the test to judge
                raised.append(exc)
                second.rollback()

        thread = threading.Thread(target=racing)
        thread.start()
        deadline = time.monotonic() + WAIT_S
        try:
            while waiting_writers(engine) == 0:
                assert time.monotonic() < deadline, "the second writer never waited"
                time.sleep(0.05)
        finally:  # the second writer goes on only once the first has ended
            first.commit()
            thread.join(WAIT_S)
        assert not thread.is_alive()
    return raised[0] if raised else None


def test_a_graph_name_taken_by_a_racing_writer_is_graph_exists(engine: Engine) -> None:
    refused = race(engine, lambda session: new_graph(session, "tank"))
    assert isinstance(refused, GraphExists)
    assert str(refused) == "a graph named 'tank' already exists"


def test_an_epoch_number_taken_by_a_racing_writer_is_epoch_taken(engine: Engine) -> None:
    with session_factory(engine)() as session:
        graph_id = new_graph(session, "tank")
        session.commit()
    refused = race(engine, lambda session: start_epoch(session, graph_id, "baseline"))
    assert isinstance(refused, EpochTaken)
    assert isinstance(refused, SrgError) and refused.http_status == 409
    assert str(refused) == f"epoch 1 of graph {graph_id} was opened by another writer"
