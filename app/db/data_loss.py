"""What a run of migrations must keep: every row of every table, every value of every column.

A migration that drops or rebuilds a table, or drops a column, can lose what users stored,
and nothing told them: on SQLite a downgrade to 0008 emptied every graph by cascade, and
a round trip through 0011 nulled every publication's stored threshold (0011's downgrade
drops the column; 0012's upgrade then counts every trace's high-error steps against
NULL). So a run counts, inside its transaction, each table's rows and each column's
values (those not NULL) before and after (:func:`count_data`); a table that had rows and
is gone or has fewer, or a column that had values and is gone or has fewer, stops the run
before it commits, naming each (:func:`require_data_kept`): nothing is changed. Unless
the user asked to lose them (``srg db downgrade REV --drop-data``; Alembic's
``config.attributes[DROP_DATA]``).

Counts, not contents: a migration may rewrite values (0007 renames ``human`` to
``person``), and sums that a downgrade drops are lost all the same, even where the
upgrade would compute them again from the steps (0012's ``traces.error``): the check
holds no list of what is derived, which would be a second home for each migration's
rules. Alembic's own ``alembic_version`` is not data. A migration whose downgrade drops a
table of rows it wrote itself (0011's ``edge_kinds`` lookup) names it in its module's
``OWN_ROWS``: dropping those loses nothing of the user's.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import sqlalchemy as sa
from sqlalchemy.engine import Connection

from app.core.errors import Conflict

#: key of Alembic's ``config.attributes``: ``True`` when the user asked to lose data
DROP_DATA = "drop_data"

#: Alembic's record of the revision, rewritten by every run
VERSION_TABLE = "alembic_version"


class DataLoss(Conflict):
    """A run of migrations would lose stored rows or values; it was rolled back."""


@dataclass(frozen=True)
class TableCount:
    """A table's rows, and the values (not NULL) of each of its columns."""

    rows: int
    values: dict[str, int]


def count_data(connection: Connection) -> dict[str, TableCount]:
    """Rows and values of every table on ``connection`` (views aside), one scan each."""
    inspector = sa.inspect(connection)
    counts = {}
    for name in inspector.get_table_names():
        if name == VERSION_TABLE:
            continue
        columns = [column["name"] for column in inspector.get_columns(name)]
        table = sa.table(name, *(sa.column(column) for column in columns))
        rows, *values = connection.execute(
            sa.select(sa.func.count(), *(sa.func.count(table.c[c]) for c in columns))
        ).one()
        counts[name] = TableCount(rows, dict(zip(columns, values, strict=True)))
    return counts


def lost_data(
    before: dict[str, TableCount], after: dict[str, TableCount], own_rows: Iterable[str] = ()
) -> list[str]:
    """What ``after`` lacks of ``before``, one phrase each: ``table (N rows)`` for a table
    gone, ``table (N rows, M after)`` for one with fewer rows (its columns then go unsaid),
    ``table.column (N values)`` and ``(N values, M after)`` alike for a column. Tables in
    ``own_rows`` may go."""
    excused = set(own_rows)
    lost = []
    for name, was in sorted(before.items()):
        now = after.get(name)
        if now is None:
            if was.rows and name not in excused:
                lost.append(f"{name} ({_counted(was.rows, 'row')})")
        elif now.rows < was.rows:
            lost.append(f"{name} ({_counted(was.rows, 'row')}, {now.rows} after)")
        else:
            for column, values in was.values.items():
                kept = now.values.get(column)
                if kept is None and values:
                    lost.append(f"{name}.{column} ({_counted(values, 'value')})")
                elif kept is not None and kept < values:
                    lost.append(f"{name}.{column} ({_counted(values, 'value')}, {kept} after)")
    return lost


def _counted(count: int, noun: str) -> str:
    return f"{count} {noun}" if count == 1 else f"{count} {noun}s"


def require_data_kept(
    before: dict[str, TableCount],
    connection: Connection,
    applied_modules: Iterable[object],
    *,
    drop_data: bool,
) -> None:
    """Refuse (:class:`DataLoss`) a run that lost what ``before`` counted, unless
    ``drop_data``; call it inside the run's transaction, so that raising rolls it back.
    ``applied_modules`` are the migrations' modules the run applied (their ``OWN_ROWS``)."""
    if drop_data:
        return
    own_rows = [name for module in applied_modules for name in getattr(module, "OWN_ROWS", ())]
    lost = lost_data(before, count_data(connection), own_rows)
    if lost:
        raise DataLoss(f"it would lose {', '.join(lost)}; nothing was changed")
