"""Alembic environment: the URL comes from Settings, the target metadata from app.models.

A caller may hand over an open connection in ``config.attributes["connection"]`` (the
tests do, to migrate a throwaway database); otherwise an engine is built from Settings
with the same connection setup as the application (app.db.engines.make_engine).
``render_as_batch`` makes ALTERs run on SQLite as copy-and-move.

A run keeps what is stored, or changes nothing:

- It is one transaction on SQLite too (``transactional_ddl``): engines.py begins SQLite's
  transactions itself, so its DDL is transactional, and Alembic's default there (a
  transaction per migration) would leave a run that fails halfway at the revision before.
- SQLite's foreign keys are off around it (app.db.foreign_keys): batch mode's copy drops
  the old table, which under foreign keys deletes every row that refers to it; before it
  commits, ``PRAGMA foreign_key_check`` must find no broken key.
- Before it commits, every table keeps its rows and every column its values
  (app.db.data_loss), unless ``config.attributes["drop_data"]`` says to lose them.
"""

from __future__ import annotations

from logging.config import fileConfig

from alembic.runtime.migration import MigrationInfo
from sqlalchemy.engine import Connection

from alembic import context
from app.config import get_settings
from app.db.data_loss import DROP_DATA, count_data, require_data_kept
from app.db.engines import make_engine
from app.db.foreign_keys import foreign_keys_off, require_foreign_keys_hold
from app.models import Base

config = context.config
if config.config_file_name is not None and config.attributes.get("configure_logger", True):
    fileConfig(config.config_file_name, disable_existing_loggers=False)

target_metadata = Base.metadata


def run_migrations(connection: Connection) -> None:
    applied: list[MigrationInfo] = []
    context.configure(
        connection=connection,
        target_metadata=target_metadata,
        render_as_batch=True,
        compare_type=True,
        transactional_ddl=True,
        on_version_apply=lambda step, **_: applied.append(step),
    )
    with context.begin_transaction():
        before = count_data(connection)
        context.run_migrations()
        require_data_kept(
            before,
            connection,
            [step.up_revision.module for step in applied],
            drop_data=bool(config.attributes.get(DROP_DATA)),
        )
        require_foreign_keys_hold(connection)


def run_migrations_offline() -> None:
    context.configure(
        url=get_settings().resolved_database_url,
        target_metadata=target_metadata,
        render_as_batch=True,
        literal_binds=True,
    )
    with context.begin_transaction():
        context.run_migrations()


def run_migrations_online() -> None:
    connection = config.attributes.get("connection")
    if connection is not None:
        with foreign_keys_off(connection):
            run_migrations(connection)
        return
    engine = make_engine(get_settings().resolved_database_url)
    try:
        with engine.connect() as connection, foreign_keys_off(connection):
            run_migrations(connection)
    finally:
        engine.dispose()


if context.is_offline_mode():
    run_migrations_offline()
else:
    run_migrations_online()
