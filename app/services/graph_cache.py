"""A per-process cache of loaded graphs, keyed by (database, graph, revision).

Loading a graph of 100k edges takes seconds, and a worker integrates expansion after
expansion into the same graph. So a worker keeps the graph it last wrote or read and
reuses it while the database's ``graphs.revision`` is still the one it holds; when
another worker (or a relink, or a publication) moved the revision, it reloads.

A graph changed in a transaction that has not committed yet is only reused by that same
session; it becomes everyone's when the session commits and is dropped on rollback. An
entry is taken out of the cache while a caller mutates it, so a failure half-way through
leaves nothing behind but a reload.
"""

from __future__ import annotations

import weakref
from collections.abc import Callable
from dataclasses import dataclass

from sqlalchemy import Connection, event
from sqlalchemy.orm import Session

from app.store.graph_catalogue import graph_revision

Key = tuple[str, str, int]


@dataclass
class _Entry:
    revision: int
    value: object
    #: the session whose uncommitted transaction wrote this revision; None once committed
    owner: weakref.ReferenceType[Session] | None


class GraphCache:
    def __init__(self) -> None:
        self._entries: dict[Key, _Entry] = {}

    @staticmethod
    def key(session: Session, graph_id: int, scope: str) -> Key:
        return (session.get_bind().engine.url.render_as_string(), scope, graph_id)

    def take(self, session: Session, graph_id: int, scope: str) -> object | None:
        """Remove and return the cached value if it is at the database's current revision."""
        key = self.key(session, graph_id, scope)
        entry = self._entries.pop(key, None)
        if entry is None:
            return None
        current = graph_revision(session, graph_id)
        usable = entry.owner is None or entry.owner() is session
        return entry.value if usable and entry.revision == current else None

    def put(self, session: Session, graph_id: int, scope: str, value: object) -> None:
        """Keep ``value`` as the graph at the revision ``session`` now sees."""
        key = self.key(session, graph_id, scope)
        revision = graph_revision(session, graph_id)
        if revision is None:
            return
        pending = session.in_transaction()
        entry = _Entry(revision, value, weakref.ref(session) if pending else None)
        self._entries[key] = entry
        if entry.owner is not None:
            event.listen(session, "after_commit", self._settle(key, entry), once=True)
            event.listen(session, "after_rollback", self._drop(key, entry), once=True)

    def clear(self) -> None:
        self._entries.clear()

    def _settle(self, key: Key, entry: _Entry) -> Callable[[Session], None]:
        def settle(session: Session) -> None:
            bind = session.bind
            if isinstance(bind, Connection) and bind.in_transaction():
                # a session joined to an outer transaction (tests): nothing is committed yet
                self._drop(key, entry)(session)
            elif self._entries.get(key) is entry:
                entry.owner = None

        return settle

    def _drop(self, key: Key, entry: _Entry) -> Callable[[Session], None]:
        def drop(_: Session) -> None:
            if self._entries.get(key) is entry:
                del self._entries[key]

        return drop


#: the one cache of this process (each worker process has its own)
graph_cache = GraphCache()
