"""The in-process growth claim: which process grows a graph itself, held while it lives.

``srg grow`` and a server's background growth run a graph's epochs in their own process
(:mod:`app.services.growing`); the workers run them as tasks. An in-process grower that
finds an epoch running must know whether another live grower is running it, or whether
it was left by one that died (a killed ``srg grow``), which it then finishes. An epoch's
heartbeat cannot tell: a live epoch may sit minutes on one clip, and a dead one was
alive a moment ago. So the grower holds a claim that the operating system or the
database drops with the process:

- PostgreSQL: a session-level advisory lock on a connection of its own, in autocommit
  (no transaction is held open for the hours a grow may take); a process that dies
  closes its connection, and the server releases the lock;
- SQLite: an exclusive ``flock`` of a file beside the database file, one per graph (a
  SQLite database is one machine's file, so all its growers share that machine); the
  kernel releases it with the process. The file is named for the database file itself,
  symlinks resolved: a grower that reaches the database through a symlink takes the
  same claim, not one of its own. An in-memory database has one process: no claim.
"""

from __future__ import annotations

import fcntl
import os
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from sqlalchemy import Engine, func, select

from app.core.errors import Conflict

#: the first key of srg's advisory locks (the second is the graph's id): "SRGg"
ADVISORY_NAMESPACE = 0x53524767


class GrowingElsewhere(Conflict):
    """Another live process (an ``srg grow``, a server's growth) grows the graph itself."""


@contextmanager
def growth_claim(engine: Engine, graph_id: int, graph_name: str) -> Iterator[None]:
    """Hold the graph's growth claim for the block; :class:`GrowingElsewhere` at once
    if another process holds it."""
    with _claimed(engine, graph_id) as held:
        if not held:
            raise _growing_elsewhere(graph_name)
        yield


def refuse_if_claimed(
    engine: Engine, graph_id: int, graph_name: str, *, details: object = None
) -> None:
    """:class:`GrowingElsewhere` (with ``details``) if another process holds the graph's
    growth claim now; a growth started here would be refused."""
    with _claimed(engine, graph_id) as held:
        if not held:
            raise _growing_elsewhere(graph_name, details)


def _growing_elsewhere(graph_name: str, details: object = None) -> GrowingElsewhere:
    return GrowingElsewhere(
        f"graph {graph_name!r} is being grown by another process (an `srg grow`, or a "
        "server's growth); grow once it has finished",
        details=details,
    )


@contextmanager
def _claimed(engine: Engine, graph_id: int) -> Iterator[bool]:
    """Try to take the claim: True held for the block, False taken by another."""
    if engine.dialect.name == "sqlite":
        with _file_claim(engine, graph_id) as held:
            yield held
        return
    with engine.connect().execution_options(isolation_level="AUTOCOMMIT") as connection:
        lock = func.pg_try_advisory_lock(ADVISORY_NAMESPACE, graph_id)
        held = bool(connection.scalar(select(lock)))
        try:
            yield held
        finally:
            if held:
                connection.scalar(select(func.pg_advisory_unlock(ADVISORY_NAMESPACE, graph_id)))


@contextmanager
def _file_claim(engine: Engine, graph_id: int) -> Iterator[bool]:
    database = engine.url.database
    if database in (None, "", ":memory:"):
        yield True
        return
    path = Path(f"{Path(database).resolve()}.grow-{graph_id}.lock")
    fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o600)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            yield False
            return
        yield True  # closing the descriptor releases the lock
    finally:
        os.close(fd)
