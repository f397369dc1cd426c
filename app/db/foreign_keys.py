"""SQLite's foreign keys around a migration: off while batch mode rebuilds tables, checked
before the migration commits.

Batch mode alters a SQLite table by copying it: a new table, the rows copied over, the old
table dropped, the new one renamed. Under ``PRAGMA foreign_keys = ON``, which every srg
connection sets (:mod:`app.db.engines`), the drop first deletes the old table's rows, and
``ON DELETE CASCADE`` takes every row that refers to them: rebuilding ``graphs`` (0009)
emptied vertices, clips, edges, publications, traces and their steps, and rebuilding
``players`` (0007) every trace. SQLite's own recipe for such a change
(https://www.sqlite.org/lang_altertable.html#otheralter) turns foreign keys off around it
and runs ``PRAGMA foreign_key_check`` before committing; so do srg's migrations.

SQLite ignores ``PRAGMA foreign_keys`` inside a transaction, so it is set on the connection
before the migration's transaction begins, and set back after it ends. Other databases
keep their rows through DDL: nothing to do there.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

from sqlalchemy.engine import Connection

from app.core.errors import Inconsistent


@contextmanager
def foreign_keys_off(connection: Connection) -> Iterator[None]:
    """Run the block with SQLite's foreign keys off on ``connection``; on again after, if
    they were on.

    The pragma goes to the driver's connection: a statement through SQLAlchemy would begin
    a transaction first (engines.py issues BEGIN itself), and there the pragma does
    nothing. So a connection already in a transaction must have them off already; one
    that has them on is refused (``RuntimeError``, srg's bug), since a migration on it
    could cascade. Call this before beginning the transaction the migration runs in, and
    end that transaction inside the block, or they could not go on again.
    """
    if connection.dialect.name != "sqlite":
        yield
        return
    driver: Any = connection.connection.driver_connection
    were_on = _enforced(driver)
    driver.execute("PRAGMA foreign_keys = OFF")
    if _enforced(driver):
        raise RuntimeError(
            "a SQLite migration needs foreign keys off, which cannot change inside a "
            "transaction: enter foreign_keys_off(connection) before beginning one"
        )
    try:
        yield
    finally:
        if were_on:
            driver.execute("PRAGMA foreign_keys = ON")
    if _enforced(driver) != were_on:  # a pooled connection would go on without them
        raise RuntimeError("foreign_keys_off's block left a transaction open: end it inside")


def _enforced(driver: Any) -> bool:
    return bool(driver.execute("PRAGMA foreign_keys").fetchone()[0])


def require_foreign_keys_hold(connection: Connection) -> None:
    """Refuse (:class:`~app.core.errors.Inconsistent`) rows whose foreign key points at no
    row, as a migration that ran with foreign keys off could leave them; call it inside the
    migration's transaction, so that raising rolls the migration back. SQLite only: other
    databases enforced their keys all along."""
    if connection.dialect.name != "sqlite":
        return
    broken = Counter(
        (row[0], row[2]) for row in connection.exec_driver_sql("PRAGMA foreign_key_check")
    )
    if broken:
        found = ", ".join(
            f"{count} {table} rows refer to no {parent} row"
            for (table, parent), count in sorted(broken.items())
        )
        raise Inconsistent(f"the migration would leave broken foreign keys ({found}): rolled back")
