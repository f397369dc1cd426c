"""Shared fixtures: databases on SQLite and PostgreSQL, rolled-back sessions, artifacts.

Every database test runs on both backends. Each pytest run migrates its own fresh
databases with Alembic (a temp SQLite file; a PostgreSQL database named after
``SRG_TEST_POSTGRES_URL`` plus a random suffix, dropped afterwards), so several
engineers' runs on one server never collide. PostgreSQL being down is a failure, not a
skip: ``infra/test.sh`` starts it. Each test's session joins an outer transaction that
is rolled back afterwards, so tests see each other's writes never.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from pathlib import Path

import pytest
from alembic.config import Config
from database_helpers import alembic_config, migrate, postgres_base_url, postgres_database
from sqlalchemy import Engine
from sqlalchemy.orm import Session

from app.core.graph.clipbank import MemoryClipBank
from app.core.graph.state_graph import StateGraph
from app.core.graph.toy import ToyDynamics
from app.core.growth.expansion import expand_blend_edge, initial_tree
from app.db.engines import make_engine
from app.store.artifacts import ArtifactStore

BACKENDS = ["sqlite", pytest.param("postgresql", marks=pytest.mark.postgres)]


@pytest.fixture
def make_alembic_config() -> Callable[[object | None], Config]:
    """Alembic's Config for this repository, optionally bound to an open connection."""
    return alembic_config


@pytest.fixture(params=BACKENDS)
def empty_db_url(request: pytest.FixtureRequest, tmp_path: Path) -> Iterator[str]:
    """A URL of an empty database (no tables) of the parametrised backend."""
    if request.param == "sqlite":
        yield f"sqlite:///{tmp_path / 'empty.sqlite3'}"
    else:
        yield from postgres_database(postgres_base_url())


@pytest.fixture(scope="session", params=BACKENDS)
def db_url(
    request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory
) -> Iterator[str]:
    """A database migrated to head, shared by the whole run (tests roll back)."""
    if request.param == "sqlite":
        url = f"sqlite:///{tmp_path_factory.mktemp('db') / 'srg.sqlite3'}"
        migrate(url)
        yield url
    else:
        yield from postgres_database(postgres_base_url(), migrated=True)


@pytest.fixture(scope="session")
def engine(db_url: str) -> Iterator[Engine]:
    engine = make_engine(db_url)
    yield engine
    engine.dispose()


@pytest.fixture
def session(engine: Engine) -> Iterator[Session]:
    """A session inside a transaction that is rolled back after the test.

    Store code never commits, and a ``session.commit()`` would only release a
    savepoint (``join_transaction_mode="create_savepoint"``), so nothing persists.
    """
    with engine.connect() as connection:
        outer = connection.begin()
        with Session(bind=connection, join_transaction_mode="create_savepoint") as session:
            yield session
        outer.rollback()


@pytest.fixture
def artifact_dir(tmp_path: Path) -> Path:
    return tmp_path / "artifacts"


@pytest.fixture
def artifacts(artifact_dir: Path) -> ArtifactStore:
    return ArtifactStore(artifact_dir)


@pytest.fixture
def toy_graph() -> tuple[ToyDynamics, StateGraph, MemoryClipBank]:
    """A small grown toy graph: the depth-2 tree plus two expansions."""
    dynamics = ToyDynamics()
    bank = MemoryClipBank()
    graph = initial_tree(dynamics, bank)
    for _ in range(2):
        expand_blend_edge(graph, bank, dynamics, int(graph.blend_edges()[0]))
    return dynamics, graph, bank
