"""Write transactions that survive SQLite's "database is locked" under concurrency.

The store begins SQLite transactions deferred: a request reads (the replay check, the
player lookup) and then writes. When another connection committed a write in between,
SQLite cannot upgrade the read snapshot and fails at once, without waiting out its busy
timeout (SQLITE_BUSY_SNAPSHOT). So on SQLite a write transaction first takes the write
lock with a statement that writes nothing (what ``BEGIN IMMEDIATE`` would do; the busy
timeout applies to it), and a lock error that still gets through rolls back and runs the
transaction again on a fresh snapshot, as for a serialization failure on a server
database. PostgreSQL needs neither: there the work runs once, as it is.

Within one process, SQLite writers also queue on a lock: SQLite lets one writer in at a
time anyway, and a waiter woken by a lock release starts at once, where SQLite's busy
handler would poll with sleeps of up to 100 ms.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from contextlib import nullcontext
from typing import TypeVar

from sqlalchemy import text
from sqlalchemy.exc import OperationalError
from sqlalchemy.orm import Session
from tenacity import (
    Retrying,
    retry_if_exception,
    stop_after_attempt,
    wait_random_exponential,
)

T = TypeVar("T")
ATTEMPTS = 8
FIRST_BACKOFF_S = 0.005
#: a write to no row: it makes SQLite take the write lock, waiting for it if need be
TAKE_SQLITE_WRITE_LOCK = text("UPDATE players SET id = id WHERE 0 = 1")
_sqlite_writer = threading.Lock()


def _locked(exc: BaseException) -> bool:
    return isinstance(exc, OperationalError) and "database is locked" in str(exc.orig)


def in_transaction(session: Session, work: Callable[[], T]) -> T:
    """``work()`` then commit; on SQLite's lock error roll back and run it again."""
    sqlite = session.get_bind().dialect.name == "sqlite"

    def attempt() -> T:
        try:
            with _sqlite_writer if sqlite else nullcontext():
                if sqlite:
                    session.execute(TAKE_SQLITE_WRITE_LOCK)
                result = work()
                session.commit()
            return result
        except OperationalError:
            session.rollback()
            raise

    retrying = Retrying(
        stop=stop_after_attempt(ATTEMPTS),
        wait=wait_random_exponential(multiplier=FIRST_BACKOFF_S, max=1.0),
        retry=retry_if_exception(_locked),
        reraise=True,
    )
    return retrying(attempt)
