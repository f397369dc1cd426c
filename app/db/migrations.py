"""srg's Alembic migrations, wherever srg runs from, and whether a database is at their head.

Alembic's configuration is built in code, not read from ``alembic.ini``, so a checkout
and an installed wheel migrate alike (docs/design.md, "Packaging").
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from sqlalchemy import Engine

from app.db.data_loss import DROP_DATA
from app.db.errors import UPGRADE_HINT, DatabaseNotReady, shown_database, unavailable_raised

ROOT = Path(__file__).resolve().parents[2]


def migrations_dir() -> Path:
    """Where Alembic's migrations are: ``migrations/`` inside the ``app`` package when it was
    installed from a wheel, else ``alembic/`` at the top of its source checkout.

    The repository keeps them at its top, where the ``alembic`` command of a checkout finds
    them through ``alembic.ini``; a wheel carries the same files as ``app/migrations``
    (the wheel's ``sources`` in pyproject.toml), which an editable install does not make.
    """
    installed = Path(__file__).resolve().parents[1] / "migrations"
    return installed if installed.is_dir() else ROOT / "alembic"


def alembic_config(connection: Any = None, *, drop_data: bool = False) -> Any:
    """Alembic's Config of srg's migrations, optionally bound to an open ``connection``;
    with ``drop_data``, a run may lose stored rows and values (:mod:`app.db.data_loss`).

    Built here, not read from ``alembic.ini``, so that an installed srg (no checkout, no
    ini) migrates too; the database URL comes from Settings in ``env.py`` either way. On
    SQLite an open connection in a transaction must have its foreign keys off
    (:func:`app.db.foreign_keys.foreign_keys_off`, entered before the transaction began).
    """
    from alembic.config import Config

    config = Config()
    config.set_main_option("script_location", str(migrations_dir()))
    config.attributes[DROP_DATA] = drop_data
    if connection is not None:
        config.attributes["connection"] = connection
    return config


def require_current_schema(engine: Engine) -> None:
    """Refuse a database that is unreachable or not at this checkout's schema revision.

    Alembic's own record (``alembic_version``) against the migrations' head: a database
    made some other way, or not upgraded since a migration was added, would fail on its
    first request instead.
    """
    from alembic.runtime.migration import MigrationContext
    from alembic.script import ScriptDirectory

    heads = set(ScriptDirectory.from_config(alembic_config()).get_heads())
    with unavailable_raised(engine), engine.connect() as connection:
        current = set(MigrationContext.configure(connection).get_current_heads())
    if current != heads:
        raise DatabaseNotReady(
            f"the database {shown_database(engine.url)} is at schema revision "
            f"{', '.join(sorted(current)) or 'none'}, not {', '.join(sorted(heads))}: "
            f"{UPGRADE_HINT}"
        )
