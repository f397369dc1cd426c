"""Test databases: Alembic migrations and throwaway PostgreSQL databases.

Shared by tests/conftest.py (every database test) and tests/tasks (the worker processes
need a committed, migrated database of their own).
"""

from __future__ import annotations

import os
import uuid
from collections.abc import Iterator
from pathlib import Path

from alembic.config import Config
from sqlalchemy import text
from sqlalchemy.engine import make_url

from alembic import command
from app.db.data_loss import DROP_DATA
from app.db.engines import make_engine

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_POSTGRES_URL = "postgresql+psycopg://postgres@127.0.0.1:5432/srg_test"


def postgres_base_url() -> str:
    return os.environ.get("SRG_TEST_POSTGRES_URL", DEFAULT_POSTGRES_URL)


def alembic_config(connection: object | None = None, *, drop_data: bool = False) -> Config:
    """Alembic's Config of this checkout's ``alembic.ini``, optionally bound to an open
    connection (on SQLite, one in a transaction needs ``foreign_keys_off`` entered before
    it began); ``drop_data`` lets a run lose stored data (app.db.data_loss)."""
    config = Config(str(ROOT / "alembic.ini"))
    config.attributes["configure_logger"] = False
    config.attributes[DROP_DATA] = drop_data
    if connection is not None:
        config.attributes["connection"] = connection
    return config


def migrate(url: str, revision: str = "head") -> None:
    """Upgrade ``url`` to ``revision`` in one transaction (Alembic's own, on a connection
    handed over outside one: env.py turns SQLite's foreign keys off before it begins)."""
    engine = make_engine(url)
    try:
        with engine.connect() as connection:
            command.upgrade(alembic_config(connection), revision)
    finally:
        engine.dispose()


def postgres_database(base_url: str, *, migrated: bool = False) -> Iterator[str]:
    """A new database on the server of ``base_url`` (migrated to head if asked); dropped after.

    Named after the base database plus a random suffix, so that several runs on one
    server never collide.
    """
    url = make_url(base_url)
    name = f"{url.database or 'srg_test'}_{uuid.uuid4().hex[:10]}"
    admin = make_engine(
        url.set(database="postgres").render_as_string(hide_password=False),
        isolation_level="AUTOCOMMIT",
    )
    try:
        with admin.connect() as connection:
            connection.execute(text(f'CREATE DATABASE "{name}"'))
        created = url.set(database=name).render_as_string(hide_password=False)
        if migrated:
            migrate(created)
        yield created
        with admin.connect() as connection:
            connection.execute(text(f'DROP DATABASE IF EXISTS "{name}" WITH (FORCE)'))
    finally:
        admin.dispose()
