"""SQL helpers shared by the store modules."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from sqlalchemy import insert
from sqlalchemy.dialects import postgresql, sqlite
from sqlalchemy.orm import Session


def insert_ignoring_duplicates(
    session: Session, model: type[Any], rows: Sequence[dict[str, Any]]
) -> None:
    """Bulk insert ``rows``, skipping any whose key exists (content-keyed, so equal).

    Lets concurrent writers register the same artifact without a race on the check.
    """
    if not rows:
        return
    dialect = session.get_bind().dialect.name
    module = postgresql if dialect == "postgresql" else sqlite
    session.execute(module.insert(model).on_conflict_do_nothing(), list(rows))


def bulk_insert(session: Session, model: type[Any], rows: Sequence[dict[str, Any]]) -> None:
    """Insert ``rows`` through the Core table: an executemany, no ORM bookkeeping per row."""
    if rows:
        session.execute(insert(model.__table__), list(rows))


#: PostgreSQL's binary COPY: its signature, then 32-bit flags and header extension (none)
_COPY_HEADER = b"PGCOPY\n\xff\r\n\x00" + bytes(8)
#: the end of a binary COPY: a tuple of -1 fields
_COPY_TRAILER = b"\xff\xff"
#: big-endian binary widths of the integer column types
_BINARY_INTS = {"SMALLINT": ">i2", "INTEGER": ">i4", "BIGINT": ">i8"}


def insert_int_columns(session: Session, model: type[Any], columns: dict[str, np.ndarray]) -> None:
    """Insert rows given as equal-length integer ``columns`` (name -> array).

    On PostgreSQL through one binary ``COPY``, built by NumPy without a Python loop per
    row: thousands of rows (a trace's steps) cost a fraction of a millisecond where an
    executemany costs tens, so one upload's steps stop being most of its time. Elsewhere
    :func:`bulk_insert`.
    """
    names = list(columns)
    n = len(columns[names[0]])
    if n == 0:
        return
    if session.get_bind().dialect.name != "postgresql":
        stacked = np.column_stack([columns[name] for name in names]).tolist()
        bulk_insert(session, model, [dict(zip(names, row, strict=True)) for row in stacked])
        return
    table = model.__table__
    layout: list[tuple[str, str]] = [("fields", ">i2")]
    for name in names:
        width = _BINARY_INTS[table.c[name].type.compile(dialect=postgresql.dialect())]
        layout += [(f"{name}.length", ">i4"), (name, width)]
    tuples = np.zeros(n, dtype=np.dtype(layout))
    tuples["fields"] = len(names)
    for name in names:
        tuples[f"{name}.length"] = tuples.dtype[name].itemsize
        tuples[name] = columns[name]
    statement = f"COPY {table.name} ({', '.join(names)}) FROM STDIN (FORMAT BINARY)"
    driver: Any = session.connection().connection.driver_connection  # psycopg's
    with driver.cursor() as cursor, cursor.copy(statement) as copy:
        copy.write(_COPY_HEADER + tuples.tobytes() + _COPY_TRAILER)
