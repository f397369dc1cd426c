"""SQL helpers shared by the store modules."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

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
