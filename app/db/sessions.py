"""Sessions, and the unit of work of one step: callers own transactions.

The shell that runs a use case opens its :func:`transaction`, or hands the service a
:data:`Scope` that opens one per step.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import AbstractContextManager, contextmanager

from sqlalchemy import Engine, text
from sqlalchemy.orm import Session, sessionmaker

from app.db.engines import begin_immediate, get_engine


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
    background growth, with the app's ``factory``). On SQLite it begins as a writer
    (:func:`~app.db.engines.begin_immediate`): our units of work read and then write,
    and a deferred one fails at once when another process committed in between; so keep
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
