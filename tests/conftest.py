"""Shared fixtures: databases on SQLite and PostgreSQL, rolled-back sessions, artifacts.

Every database test runs on both backends. Each pytest run migrates its own fresh
databases with Alembic (a temp SQLite file; a PostgreSQL database named after
``SRG_TEST_POSTGRES_URL`` plus a random suffix, dropped afterwards), so several
engineers' runs on one server never collide. PostgreSQL being down is a failure, not a
skip: ``infra/test.sh`` starts it. Each test's session joins an outer transaction that
is rolled back afterwards, so tests see each other's writes never.
"""

from __future__ import annotations

import os
import uuid
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest
from alembic.config import Config
from sqlalchemy import Engine, text
from sqlalchemy.engine import make_url
from sqlalchemy.orm import Session

from alembic import command
from app.core.clipbank import MemoryClipBank
from app.core.graph import StateGraph
from app.core.growth import expand_blend_edge, initial_tree
from app.core.toy import ToyDynamics
from app.db import make_engine
from app.store.artifacts import ArtifactStore

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_POSTGRES_URL = "postgresql+psycopg://postgres@127.0.0.1:5432/srg_test"
BACKENDS = ["sqlite", pytest.param("postgresql", marks=pytest.mark.postgres)]


def alembic_config(connection: object | None = None) -> Config:
    config = Config(str(ROOT / "alembic.ini"))
    config.attributes["configure_logger"] = False
    if connection is not None:
        config.attributes["connection"] = connection
    return config


def migrate(url: str, revision: str = "head") -> None:
    engine = make_engine(url)
    try:
        with engine.begin() as connection:
            command.upgrade(alembic_config(connection), revision)
    finally:
        engine.dispose()


def _postgres_database(base_url: str) -> Iterator[str]:
    """A new, empty database on the server of ``base_url``; dropped afterwards."""
    url = make_url(base_url)
    name = f"{url.database or 'srg_test'}_{uuid.uuid4().hex[:10]}"
    admin = make_engine(
        url.set(database="postgres").render_as_string(hide_password=False),
        isolation_level="AUTOCOMMIT",
    )
    try:
        with admin.connect() as connection:
            connection.execute(text(f'CREATE DATABASE "{name}"'))
        yield url.set(database=name).render_as_string(hide_password=False)
        with admin.connect() as connection:
            connection.execute(text(f'DROP DATABASE IF EXISTS "{name}" WITH (FORCE)'))
    finally:
        admin.dispose()


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
        yield from _postgres_database(os.environ.get("SRG_TEST_POSTGRES_URL", DEFAULT_POSTGRES_URL))


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
        base = os.environ.get("SRG_TEST_POSTGRES_URL", DEFAULT_POSTGRES_URL)
        for url in _postgres_database(base):
            migrate(url)
            yield url


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
