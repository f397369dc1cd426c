"""The graph lock: one writer of a graph's structure at a time.

Planning an epoch, integrating an expansion, relinking and publishing all rewrite the
graph from the copy they loaded; they take this lock first, so two of them never write
diffs against the same revision.
"""

from __future__ import annotations

from sqlalchemy import select
from sqlalchemy.orm import Session

from app.core.graph.graph_entry import GraphEntry
from app.db.engines import begin_immediate
from app.models import Graph
from app.store.epochs import Epoch, get_epoch
from app.store.graph_catalogue import GraphNotFound, entry_of, graph_entry


def lock_graph(session: Session, graph_id: int) -> GraphEntry:
    """The graph, its row locked until the transaction ends.

    PostgreSQL: ``SELECT ... FOR UPDATE``. SQLite has no row locks: the transaction is
    begun IMMEDIATE (the database's write lock), which must happen before any statement
    of the transaction, so call this first.
    """
    row = _locked_row(session, graph_id, skip_locked=False)
    if row is None:
        raise GraphNotFound(f"no graph {graph_id!r}")
    return entry_of(row)


def lock_named_graph(session: Session, name: str | int) -> GraphEntry:
    """:func:`lock_graph` of the graph by name or id."""
    begin_immediate(session)  # before the first statement: see lock_graph
    return lock_graph(session, graph_entry(session, name).id)


def lock_graph_if_free(session: Session, graph_id: int) -> GraphEntry | None:
    """The graph locked as :func:`lock_graph` locks it, or None at once where another
    transaction holds it (PostgreSQL's ``SKIP LOCKED``; SQLite waits for its write lock).

    For work that a later attempt does as well, so that a worker does not sit blocked
    behind a long writer (a publication rendering its animations) only to find the work
    done.
    """
    row = _locked_row(session, graph_id, skip_locked=True)
    return None if row is None else entry_of(row)


def _locked_row(session: Session, graph_id: int, *, skip_locked: bool) -> Graph | None:
    begin_immediate(session)
    stmt = select(Graph).where(Graph.id == graph_id).execution_options(populate_existing=True)
    if session.get_bind().dialect.name != "sqlite":
        stmt = stmt.with_for_update(skip_locked=skip_locked)
    return session.scalars(stmt).one_or_none()


def lock_epoch_graph(session: Session, epoch_id: int) -> tuple[Epoch, GraphEntry]:
    """The epoch, read again under its graph's lock, and the locked graph.

    The epoch is refreshed once the lock is held: a writer that held the lock before
    may have finished it meanwhile.
    """
    begin_immediate(session)  # before the first statement: see lock_graph
    graph = lock_graph(session, get_epoch(session, epoch_id).graph_id)
    return get_epoch(session, epoch_id, fresh=True), graph
