"""Sessions, and the unit of work of one step: callers own transactions.

The shell that runs a use case hands the service its :class:`~app.config.Settings`; the
service opens :func:`transaction` on the settings' database, or is handed
:data:`Transactions` that open one per step (a server's own sessions: :func:`unit_of_work`).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import AbstractContextManager, contextmanager

from sqlalchemy import Engine, text
from sqlalchemy.orm import Session, sessionmaker

from app.config import Settings
from app.db.engines import begin_immediate, database_engine


def session_factory(engine: Engine) -> sessionmaker[Session]:
    """Sessions that keep loaded objects usable after commit (callers own transactions)."""
    return sessionmaker(bind=engine, expire_on_commit=False)


def database_sessions(settings: Settings) -> sessionmaker[Session]:
    """Sessions of the settings' database (its engine is shared: :func:`database_engine`)."""
    return session_factory(database_engine(settings))


#: opens the unit of work of one step: :func:`transaction` (a fresh, durable one) or the
#: caller's own (``app.services.epochs.in_session``)
Transactions = Callable[[], AbstractContextManager[Session]]


def transaction(settings: Settings) -> AbstractContextManager[Session]:
    """The unit of work of a CLI command and of a Celery task alike, on the settings'
    database: :func:`unit_of_work` of its sessions."""
    return unit_of_work(database_sessions(settings))


@contextmanager
def unit_of_work(factory: sessionmaker[Session]) -> Iterator[Session]:
    """One session whose work is committed at the end, or rolled back on any error.

    On SQLite it begins as a writer (:func:`~app.db.engines.begin_immediate`): our units
    of work read and then write, and a deferred one fails at once when another process
    committed in between; so keep them short and compute outside them
    (``app.services.epochs.run_epoch`` does).
    """
    with factory() as session:
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
