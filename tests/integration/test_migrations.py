"""Migrations: one head, up and down and up again, and the models match the DDL."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import pytest
from alembic.autogenerate import compare_metadata
from alembic.config import Config
from alembic.migration import MigrationContext
from alembic.script import ScriptDirectory
from sqlalchemy import inspect, text
from sqlalchemy.exc import IntegrityError

from alembic import command
from app.db.engines import make_engine
from app.db.foreign_keys import foreign_keys_off
from app.models import Base


def test_single_head(make_alembic_config: Callable[[object | None], Config]) -> None:
    assert len(ScriptDirectory.from_config(make_alembic_config(None)).get_heads()) == 1


def test_upgrade_downgrade_upgrade_matches_models(
    empty_db_url: str, make_alembic_config: Callable[[object | None], Config]
) -> None:
    engine = make_engine(empty_db_url)
    try:
        with engine.connect() as connection, foreign_keys_off(connection), connection.begin():
            config = make_alembic_config(connection)
            command.upgrade(config, "head")
            assert set(Base.metadata.tables) <= set(inspect(connection).get_table_names())
            command.downgrade(config, "base")
            assert set(inspect(connection).get_table_names()) <= {"alembic_version"}
            command.upgrade(config, "head")
            context = MigrationContext.configure(connection, opts={"compare_type": True})
            assert compare_metadata(context, Base.metadata) == []
    finally:
        engine.dispose()


def test_0007_renames_human_players_to_people_and_back(
    empty_db_url: str, make_alembic_config: Callable[[object | None], Config]
) -> None:
    """Every player said its kind at registration, so existing rows need no guess."""
    insert = text("INSERT INTO players (name, kind, token_hash) VALUES (:name, :kind, :hash)")
    kinds = text("SELECT name, kind FROM players ORDER BY name")
    engine = make_engine(empty_db_url)
    try:
        with engine.connect() as connection, foreign_keys_off(connection), connection.begin():
            config = make_alembic_config(connection)
            command.upgrade(config, "0006")
            for name, kind in (("a-browser", "human"), ("bot-random", "bot")):
                connection.execute(insert, {"name": name, "kind": kind, "hash": name})
            command.upgrade(config, "0007")
            assert connection.execute(kinds).all() == [
                ("a-browser", "person"),
                ("bot-random", "bot"),
            ]
            with pytest.raises(IntegrityError), connection.begin_nested():
                connection.execute(insert, {"name": "old-client", "kind": "human", "hash": "x"})
            with pytest.raises(IntegrityError), connection.begin_nested():  # no default kind
                connection.execute(text("INSERT INTO players (name, token_hash) VALUES ('n', 'n')"))
            command.downgrade(config, "0006")
            assert connection.execute(kinds).all() == [
                ("a-browser", "human"),
                ("bot-random", "bot"),
            ]
    finally:
        engine.dispose()


def test_foreign_keys_go_off_only_outside_a_sqlite_transaction(tmp_path: Path) -> None:
    """SQLite ignores PRAGMA foreign_keys inside a transaction, where a migration with them
    on would cascade through batch mode's table copies: refused before anything runs.
    Outside one they go off for the block and on again after."""
    engine = make_engine(f"sqlite:///{tmp_path / 'srg.sqlite3'}")
    enforced = text("PRAGMA foreign_keys")
    try:
        with (
            engine.begin() as connection,
            pytest.raises(RuntimeError, match="before beginning one"),
            foreign_keys_off(connection),
        ):
            pass
        with engine.connect() as connection:
            with foreign_keys_off(connection), connection.begin():
                assert connection.execute(enforced).scalar() == 0
            assert connection.execute(enforced).scalar() == 1
    finally:
        engine.dispose()
