"""Write transactions that survive SQLite's "database is locked" under concurrency.

On SQLite a transaction that reads and then writes fails at once, without waiting out
the busy timeout, when another connection committed a write after its first read
(SQLITE_BUSY_SNAPSHOT). So a write transaction here begins as a writer, the one way srg
takes SQLite's write lock everywhere (:func:`app.db.engines.begin_immediate`, which a
Celery task's and a CLI command's transactions use too): whatever the session had open,
its reads, is committed first, then the work runs in a transaction begun IMMEDIATE (the
busy timeout applies to taking the lock). A lock error that still gets through rolls
back and runs the work again, as for a serialization failure on a server database.
PostgreSQL needs neither: there the work runs once, as it is.

Within one process, SQLite writers also queue on a lock: SQLite lets one writer in at a
time anyway, and a waiter woken by a lock release starts at once, where SQLite's busy
handler would poll with sleeps of up to 100 ms.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from contextlib import nullcontext
from typing import TypeVar

from sqlalchemy.exc import OperationalError
from sqlalchemy.orm import Session
from tenacity import (
    Retrying,
    retry_if_exception,
    stop_after_attempt,
    wait_random_exponential,
)

from app.db.engines import begin_immediate

T = TypeVar("T")
ATTEMPTS = 8
FIRST_BACKOFF_S = 0.005
_sqlite_writer = threading.Lock()


def _locked(exc: BaseException) -> bool:
    return isinstance(exc, OperationalError) and "database is locked" in str(exc.orig)


def in_transaction(session: Session, work: Callable[[], T]) -> T:
    """``work()`` in a write transaction of its own, then commit; on SQLite's lock error
    roll back and run it again. What the session had open before is committed first."""
    sqlite = session.get_bind().dialect.name == "sqlite"
    if session.in_transaction():
        session.commit()

    def attempt() -> T:
        try:
            with _sqlite_writer if sqlite else nullcontext():
                begin_immediate(session)
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
