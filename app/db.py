"""Engine and session factory from Settings.

SQLite is the embedded default, so its connections are set up to behave like a server
database as far as the store needs: foreign keys on, WAL so readers do not block the
writer, a busy timeout instead of instant "database is locked", and transactions that
SQLAlchemy (not the pysqlite driver) begins, so SAVEPOINTs work.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import AbstractContextManager, contextmanager
from functools import lru_cache
from pathlib import Path
from typing import Any

from sqlalchemy import Engine, create_engine, event
from sqlalchemy.engine import make_url
from sqlalchemy.orm import Session, sessionmaker

from app.config import get_settings

#: how long a SQLite writer waits for another's transaction: embedded runs share one file,
#: and a checkpoint of a 20k-frame experiment graph holds the lock for tens of seconds
SQLITE_BUSY_TIMEOUT_MS = 600_000


def make_engine(url: str, **kwargs: Any) -> Engine:
    """An engine for ``url``; SQLite files get their parent directory and pragmas."""
    parsed = make_url(url)
    if parsed.get_backend_name() != "sqlite":
        return create_engine(url, pool_pre_ping=True, **kwargs)
    if parsed.database and parsed.database != ":memory:":
        Path(parsed.database).parent.mkdir(parents=True, exist_ok=True)
    engine = create_engine(url, **kwargs)
    event.listen(engine, "connect", _configure_sqlite)
    event.listen(engine, "begin", _begin_sqlite)
    return engine


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
    return make_engine(get_settings().resolved_database_url)


def session_factory(engine: Engine | None = None) -> sessionmaker[Session]:
    """Sessions that keep loaded objects usable after commit (callers own transactions)."""
    return sessionmaker(bind=engine or get_engine(), expire_on_commit=False)


#: opens the unit of work of one step: :func:`transaction` (a fresh, durable one) or the
#: caller's own (``app.services.growth.in_session``)
Scope = Callable[[], AbstractContextManager[Session]]


@contextmanager
def transaction(factory: sessionmaker[Session] | None = None) -> Iterator[Session]:
    """One session whose work is committed at the end, or rolled back on any error.

    The unit of work of a CLI command and of a Celery task alike (and of the API's
    background growth, with the app's ``factory``). On SQLite it begins
    as a writer (:func:`begin_immediate`): our units of work read and then write, and
    a deferred one fails at once when another process committed in between; so keep
    them short and compute outside them (``app.services.growth.run_epoch`` does).
    """
    with (factory or session_factory())() as session:
        begin_immediate(session)
        try:
            yield session
            session.commit()
        except BaseException:
            session.rollback()
            raise
