"""Engines from Settings, set up and made ready for srg.

SQLite is the embedded default, so its connections are set up to behave like a server
database as far as the store needs: foreign keys on, WAL so readers do not block the
writer, a busy timeout instead of instant "database is locked", and transactions that
SQLAlchemy (not the pysqlite driver) begins, so SAVEPOINTs work.

Every layer gets the engine of the :class:`~app.config.Settings` it was handed
(:func:`database_engine`, one engine per database and process), never one looked up in
the environment, so a test or a tool points a service at a database by its settings alone.

The embedded default is also migrated on first use (:func:`database_engine`), as a user of an
embedded database expects; a configured database is the operator's, so for one that does
not exist or has no tables the CLI says to run ``srg db upgrade`` instead, and nothing
(not even an empty SQLite file) is made.

A command that writes first has the whole SQLite file checked (:func:`require_intact`):
SQLite notices a damaged page only when a statement reads it.
"""

from __future__ import annotations

import threading
from collections import OrderedDict
from pathlib import Path
from typing import Any

from sqlalchemy import Engine, create_engine, event, inspect
from sqlalchemy.engine import URL, make_url
from sqlalchemy.exc import ArgumentError, NoSuchModuleError
from sqlalchemy.orm import Session

from app.config import Settings
from app.core.errors import InvalidInput
from app.db.errors import (
    UPGRADE_HINT,
    DatabaseNotReady,
    DatabaseUnusable,
    shown_database,
    unavailable_raised,
)
from app.db.foreign_keys import foreign_keys_off
from app.db.migrations import alembic_config

#: how long a SQLite writer waits for another's transaction: embedded runs share one file,
#: and a checkpoint of a 20k-frame experiment graph holds the lock for tens of seconds
SQLITE_BUSY_TIMEOUT_MS = 600_000


class InvalidDatabaseURL(InvalidInput):
    """The database URL cannot be parsed, or names a database SQLAlchemy does not know."""


def make_engine(url: str, **kwargs: Any) -> Engine:
    """An engine for ``url``; SQLite files get their parent directory and pragmas.

    Raises :class:`InvalidDatabaseURL` (one line, without echoing the URL, which may hold
    a password) for a URL that is not one.
    """
    parsed = parse_database_url(url)
    try:
        if parsed.get_backend_name() != "sqlite":
            return create_engine(parsed, pool_pre_ping=True, **kwargs)
        if parsed.database and parsed.database != ":memory:":
            Path(parsed.database).parent.mkdir(parents=True, exist_ok=True)
        engine = create_engine(parsed, **kwargs)
    except NoSuchModuleError:
        raise InvalidDatabaseURL(
            f"the database URL (SRG_DATABASE_URL) names an unknown database "
            f"{parsed.drivername!r}: use postgresql+psycopg:// or sqlite:///"
        ) from None
    event.listen(engine, "connect", _configure_sqlite)
    event.listen(engine, "begin", _begin_sqlite)
    return engine


def parse_database_url(url: str) -> URL:
    """``url`` parsed, or :class:`InvalidDatabaseURL` (the URL not echoed: a password)."""
    try:
        return make_url(url)
    except ArgumentError:
        raise InvalidDatabaseURL(
            "the database URL (SRG_DATABASE_URL) is not one: expected dialect+driver://..., "
            "e.g. postgresql+psycopg://user@host:5432/srg or sqlite:///var/srg.sqlite3"
        ) from None


def _configure_sqlite(dbapi_connection: Any, _record: Any) -> None:
    # Stop pysqlite from issuing BEGIN itself (it breaks SAVEPOINT); see _begin_sqlite.
    dbapi_connection.isolation_level = None
    cursor = dbapi_connection.cursor()
    cursor.execute("PRAGMA foreign_keys = ON")
    cursor.execute("PRAGMA journal_mode = WAL")
    cursor.execute(f"PRAGMA busy_timeout = {SQLITE_BUSY_TIMEOUT_MS}")
    cursor.close()


#: execution option naming SQLite's BEGIN mode ("IMMEDIATE": take the write lock at once)
SQLITE_BEGIN = "srg_sqlite_begin"


def _begin_sqlite(connection: Any) -> None:
    mode = connection.get_execution_options().get(SQLITE_BEGIN, "")
    connection.exec_driver_sql(f"BEGIN {mode}".strip())


def begin_immediate(session: Session) -> None:
    """Start ``session``'s transaction as a writer: BEGIN IMMEDIATE on SQLite.

    Call it before the transaction's first statement. On SQLite a deferred transaction
    that reads and then writes can fail when another writer committed in between; an
    immediate one waits for the write lock up front. Other databases lock rows instead.
    """
    if session.get_bind().dialect.name == "sqlite" and not session.in_transaction():
        session.connection(execution_options={SQLITE_BEGIN: "IMMEDIATE"})


#: engines kept per process, most recently used last; the one pushed out is disposed
#: (a process uses one database; tests and tools that visit many close what they leave)
ENGINES_KEPT = 4
_engines: OrderedDict[tuple[str, bool], Engine] = OrderedDict()
_engines_lock = threading.Lock()


def database_engine(settings: Settings) -> Engine:
    """The engine of the settings' database, made ready for use where that is ours to do;
    one per database and process, so its connection pool is shared.

    The embedded default (no ``SRG_DATABASE_URL``) is migrated to the latest schema on
    first use: a fresh checkout needs no ``srg db upgrade``. A configured SQLite file
    that does not exist is not made (that would leave an empty file behind a failing
    command): :class:`DatabaseNotReady` says to run ``srg db upgrade``, as the CLI does
    for a configured database without tables.
    """
    key = (settings.resolved_database_url, bool(settings.database_url))
    with _engines_lock:
        engine = _engines.get(key)
        if engine is None:
            engine = _ready_engine(*key)
            _engines[key] = engine
            if len(_engines) > ENGINES_KEPT:
                _engines.popitem(last=False)[1].dispose()
        _engines.move_to_end(key)
        return engine


def _ready_engine(url: str, configured: bool) -> Engine:
    file = sqlite_file(url)
    if configured and file is not None and not file.exists():
        raise DatabaseNotReady(f"no database file at {file}: {UPGRADE_HINT} to create it")
    engine = make_engine(url)
    if not configured:
        try:
            create_embedded_schema(engine)
        except BaseException:
            engine.dispose()
            raise
    return engine


def dispose_engines() -> None:
    """Close every kept engine's connections (a process about to end, or to fork)."""
    with _engines_lock:
        while _engines:
            _engines.popitem()[1].dispose()


def sqlite_file(url: str) -> Path | None:
    """The file of a SQLite URL (``None`` for other databases and in-memory SQLite)."""
    parsed = parse_database_url(url)
    if parsed.get_backend_name() != "sqlite" or parsed.database in (None, "", ":memory:"):
        return None
    return Path(parsed.database)


def create_embedded_schema(engine: Engine) -> bool:
    """Migrate a database without any table to the latest schema; ``True`` if it did.

    A database with tables is left alone, whatever their revision (``srg db upgrade``
    moves it). The check and the migration share one writer's transaction (BEGIN
    IMMEDIATE on SQLite), so two commands started at once on a fresh checkout migrate
    it once; SQLite's foreign keys go off before it begins, as every migration needs
    (:mod:`app.db.foreign_keys`).
    """
    from alembic import command

    with unavailable_raised(engine):
        writer = engine.connect().execution_options(**{SQLITE_BEGIN: "IMMEDIATE"})
        with writer as connection, foreign_keys_off(connection), connection.begin():
            if inspect(connection).get_table_names():
                return False
            command.upgrade(alembic_config(connection), "head")
    return True


def require_intact(settings: Settings) -> None:
    """Refuse a SQLite file that ``PRAGMA quick_check`` finds damaged, before writing to it.

    SQLite notices a damaged page only when a statement reads it, so a command whose
    reads miss the damage (growth, publishing and play read a few rows each) writes on,
    spreading it, and succeeds. quick_check reads every page once, skipping
    integrity_check's comparison of each index with its table; so its cost grows with the
    file: about 0.3 s for 300 MB from the page cache on two busy cores, next to the
    seconds to hours of a command that writes. That is why the commands that write run it
    once at their start, and neither reads nor each transaction do. A database server
    checks its own pages: there it only connects.
    """
    require_engine_intact(database_engine(settings))


def require_engine_intact(engine: Engine) -> None:
    """:func:`require_intact` on ``engine``'s database. A connection that SQLite has read
    pages with keeps them between transactions in WAL mode, so a file overwritten since
    is noticed only through a new connection (an engine without a pool)."""
    with unavailable_raised(engine), engine.connect() as connection:
        if connection.dialect.name != "sqlite":
            return
        found = [row[0] for row in connection.exec_driver_sql("PRAGMA quick_check(1)")]
    if found != ["ok"]:  # the first problem, under a "*** in database main ***" line
        raise DatabaseUnusable(
            f"cannot use the database {shown_database(engine.url)} (corrupt): "
            f"{found[0].splitlines()[-1]}; restore it from a backup",
            "corrupt",
        )
