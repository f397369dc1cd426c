"""Engine and session factory from Settings.

SQLite is the embedded default, so its connections are set up to behave like a server
database as far as the store needs: foreign keys on, WAL so readers do not block the
writer, a busy timeout instead of instant "database is locked", and transactions that
SQLAlchemy (not the pysqlite driver) begins, so SAVEPOINTs work.

The embedded default is also migrated on first use (:func:`get_engine`), as a user of an
embedded database expects; a configured database is the operator's, so for one that does
not exist or has no tables the CLI says to run ``srg db upgrade`` instead, and nothing
(not even an empty SQLite file) is made.

What a database error means to the user has its home here too
(:func:`database_unavailable`): one that says the database cannot serve is a 503 in the
API and one line from the CLI, and ``srg serve`` and the commands that write look for
those before they start (:func:`require_current_schema`, :func:`require_intact`).
"""

from __future__ import annotations

import re
import shlex
import sqlite3
from collections.abc import Callable, Iterator
from contextlib import AbstractContextManager, contextmanager
from functools import lru_cache
from pathlib import Path
from typing import Any

from sqlalchemy import Engine, create_engine, event, inspect, text
from sqlalchemy.engine import URL, make_url
from sqlalchemy.exc import ArgumentError, DBAPIError, NoSuchModuleError, OperationalError
from sqlalchemy.orm import Session, sessionmaker

from app.config import get_settings
from app.core.errors import InvalidInput, Unavailable

ROOT = Path(__file__).resolve().parents[1]

#: how long a SQLite writer waits for another's transaction: embedded runs share one file,
#: and a checkpoint of a 20k-frame experiment graph holds the lock for tens of seconds
SQLITE_BUSY_TIMEOUT_MS = 600_000


#: the one line that says what to do about a database without srg's tables
UPGRADE_HINT = "run `srg db upgrade`"


class InvalidDatabaseURL(InvalidInput):
    """The database URL cannot be parsed, or names a database SQLAlchemy does not know."""


class DatabaseUnavailable(Unavailable):
    """The database cannot serve srg now; ``problem`` says why in a few words.

    The message names the database (its file, or its URL without the password) for the
    operator; the API tells its clients the ``problem`` alone.
    """

    problem = "unavailable"

    def __init__(self, message: str, problem: str | None = None) -> None:
        super().__init__(message)
        self.problem = problem or self.problem


class DatabaseNotReady(DatabaseUnavailable):
    """The configured database does not exist yet (create it), or has no srg schema
    (upgrade it)."""

    problem = "not migrated"


class DatabaseUnusable(DatabaseUnavailable):
    """The database file is not a database, or a damaged one."""

    problem = "not a database"


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


@lru_cache(maxsize=1)
def get_engine() -> Engine:
    """The engine of the configured database, made ready for use where that is ours to do.

    The embedded default (no ``SRG_DATABASE_URL``) is migrated to the latest schema on
    first use: a fresh checkout needs no ``srg db upgrade``. A configured SQLite file
    that does not exist is not made (that would leave an empty file behind a failing
    command): :class:`DatabaseNotReady` says to run ``srg db upgrade``, as the CLI does
    for a configured database without tables.
    """
    settings = get_settings()
    url = settings.resolved_database_url
    file = sqlite_file(url)
    if settings.database_url and file is not None and not file.exists():
        raise DatabaseNotReady(f"no database file at {file}: {UPGRADE_HINT} to create it")
    engine = make_engine(url)
    if not settings.database_url:
        try:
            create_embedded_schema(engine)
        except BaseException:
            engine.dispose()
            raise
    return engine


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
    it once.
    """
    from alembic import command

    with unavailable_raised(engine):
        writer = engine.connect().execution_options(**{SQLITE_BEGIN: "IMMEDIATE"})
        with writer as connection, connection.begin():
            if inspect(connection).get_table_names():
                return False
            command.upgrade(alembic_config(connection), "head")
    return True


def migrations_dir() -> Path:
    """Where Alembic's migrations are: ``migrations/`` inside this package when it was
    installed from a wheel, else ``alembic/`` at the top of its source checkout.

    The repository keeps them at its top, where the ``alembic`` command of a checkout finds
    them through ``alembic.ini``; a wheel carries the same files as ``app/migrations``
    (``package-dir`` in pyproject.toml), which an editable install does not make.
    """
    installed = Path(__file__).resolve().parent / "migrations"
    return installed if installed.is_dir() else ROOT / "alembic"


def alembic_config(connection: Any = None) -> Any:
    """Alembic's Config of srg's migrations, optionally bound to an open ``connection``.

    Built here, not read from ``alembic.ini``, so that an installed srg (no checkout, no
    ini) migrates too; the database URL comes from Settings in ``env.py`` either way.
    """
    from alembic.config import Config

    config = Config()
    config.set_main_option("script_location", str(migrations_dir()))
    if connection is not None:
        config.attributes["connection"] = connection
    return config


def schema_missing(exc: DBAPIError) -> bool:
    """Whether ``exc`` says a table or column of srg's schema is not there (not migrated).

    SQLite says "no such table/column"; PostgreSQL raises undefined_table (42P01) or
    undefined_column (42703).
    """
    orig = exc.orig
    if getattr(orig, "sqlstate", None) in ("42P01", "42703"):
        return True
    return str(orig).startswith(("no such table", "no such column"))


#: what PostgreSQL answers a connection to a database it does not have (its SQLSTATE,
#: invalid_catalog_name 3D000, comes in the server's startup reply, which libpq turns into
#: this text only: psycopg's connection error carries no SQLSTATE)
_NO_SUCH_DATABASE = re.compile(r'FATAL:\s+database ".*" does not exist')


def database_missing(exc: DBAPIError) -> bool:
    """Whether ``exc`` says the server has no database of the configured name."""
    return (
        getattr(exc.orig, "sqlstate", None) == "3D000"
        or _NO_SUCH_DATABASE.search(str(exc.orig)) is not None
    )


def createdb_command(url: URL) -> str:
    """The ``createdb`` line that makes the PostgreSQL database ``url`` names, on its server
    and as its user (libpq's own defaults where the URL leaves a part out)."""
    words = ["createdb"]
    if url.host:
        words += ["-h", url.host]
    if url.port:
        words += ["-p", str(url.port)]
    if url.username:
        words += ["-U", url.username]
    words.append(url.database or "")
    return shlex.join(words)


#: SQLite's primary result codes (https://www.sqlite.org/rescode.html) that say the file
#: cannot serve as it is, whatever the statement; what each means to the user
_SQLITE_PROBLEMS = {
    sqlite3.SQLITE_BUSY: "locked",
    sqlite3.SQLITE_LOCKED: "locked",
    sqlite3.SQLITE_CANTOPEN: "cannot be opened",
    sqlite3.SQLITE_READONLY: "read-only",
    sqlite3.SQLITE_IOERR: "I/O error",
    sqlite3.SQLITE_FULL: "disk full",
    sqlite3.SQLITE_NOTADB: "not a database",
    sqlite3.SQLITE_CORRUPT: "corrupt",
}
#: PostgreSQL's SQLSTATE classes that say the server cannot serve now, whatever the statement
_SERVER_PROBLEMS = {
    "08": "unreachable",
    "53": "out of resources",
    "57": "stopped by its operator",
    "58": "I/O error",
}


def database_unavailable(exc: DBAPIError, url: URL) -> DatabaseUnavailable | None:
    """What ``exc`` says about the database when it says it cannot serve; ``None`` for a bug.

    It cannot serve when its server cannot be reached (or dropped the connection), its
    file is not a database or is damaged, a lock outlasts the busy timeout and the write
    retries (:mod:`app.store.transactions`), or it has no srg schema, or (on a server) does
    not exist. A statement the database refuses (a constraint, a syntax error) is our bug
    and stays one; both drivers raise some of those as ``OperationalError`` too, so the
    driver's code decides, not the exception's class. The message names the database at
    ``url`` (:func:`shown_database`).
    """
    where = shown_database(url)
    if schema_missing(exc):
        return DatabaseNotReady(
            f"the database {where} has no srg schema (or an older one): {UPGRADE_HINT}"
        )
    if database_missing(exc):
        return DatabaseNotReady(
            f"the database {where} does not exist: create it with `{createdb_command(url)}`, "
            f"then {UPGRADE_HINT}",
            "does not exist",
        )
    orig = exc.orig
    if isinstance(orig, sqlite3.Error):
        problem = _SQLITE_PROBLEMS.get((getattr(orig, "sqlite_errorcode", None) or 0) & 0xFF)
    elif exc.connection_invalidated or (
        isinstance(exc, OperationalError) and getattr(orig, "sqlstate", None) is None
    ):
        problem = "unreachable"  # the connection failed or was lost: no SQLSTATE for that
    else:
        problem = _SERVER_PROBLEMS.get(str(getattr(orig, "sqlstate", ""))[:2])
    if problem is None:
        return None
    kind = DatabaseUnusable if problem in ("not a database", "corrupt") else DatabaseUnavailable
    detail = (str(orig).splitlines() or [type(orig).__name__])[0]
    return kind(f"cannot use the database {where} ({problem}): {detail}", problem)


def shown_database(url: URL) -> str:
    """How messages name a database: its file for SQLite, else its URL without password."""
    if url.get_backend_name() == "sqlite" and url.database:
        return url.database
    return url.render_as_string(hide_password=True)


@contextmanager
def unavailable_raised(engine: Engine) -> Iterator[None]:
    """Raise what :func:`database_unavailable` makes of a database error, where it is one."""
    try:
        yield
    except DBAPIError as exc:
        unavailable = database_unavailable(exc, engine.url)
        if unavailable is None:
            raise
        raise unavailable from None


def require_intact(engine: Engine | None = None) -> None:
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
    engine = engine or get_engine()
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


def session_factory(engine: Engine | None = None) -> sessionmaker[Session]:
    """Sessions that keep loaded objects usable after commit (callers own transactions)."""
    return sessionmaker(bind=engine or get_engine(), expire_on_commit=False)


#: opens the unit of work of one step: :func:`transaction` (a fresh, durable one) or the
#: caller's own (``app.services.epochs.in_session``)
Scope = Callable[[], AbstractContextManager[Session]]


@contextmanager
def transaction(factory: sessionmaker[Session] | None = None) -> Iterator[Session]:
    """One session whose work is committed at the end, or rolled back on any error.

    The unit of work of a CLI command and of a Celery task alike (and of the API's
    background growth, with the app's ``factory``). On SQLite it begins
    as a writer (:func:`begin_immediate`): our units of work read and then write, and
    a deferred one fails at once when another process committed in between; so keep
    them short and compute outside them (``app.services.epochs.run_epoch`` does).
    """
    with (factory or session_factory())() as session:
        begin_immediate(session)
        try:
            yield session
            session.commit()
        except BaseException:
            session.rollback()
            raise


def ping(session: Session) -> None:
    """Ask the database to answer one trivial statement; raises what the driver raises."""
    session.execute(text("SELECT 1"))
