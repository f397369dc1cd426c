"""Migrations: one head, up and down and up again, and the models match the DDL."""

from __future__ import annotations

from collections.abc import Callable

from alembic.autogenerate import compare_metadata
from alembic.config import Config
from alembic.migration import MigrationContext
from alembic.script import ScriptDirectory
from sqlalchemy import inspect

from alembic import command
from app.db import make_engine
from app.models import Base


def test_single_head(make_alembic_config: Callable[[object | None], Config]) -> None:
    assert len(ScriptDirectory.from_config(make_alembic_config(None)).get_heads()) == 1


def test_upgrade_downgrade_upgrade_matches_models(
    empty_db_url: str, make_alembic_config: Callable[[object | None], Config]
) -> None:
    engine = make_engine(empty_db_url)
    try:
        with engine.begin() as connection:
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
