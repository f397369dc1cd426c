"""The declarative base every model shares.

A naming convention makes constraint names deterministic, so Alembic can drop and alter
them by name on PostgreSQL and recreate them in SQLite batch mode alike. Every
``Mapped[datetime]`` column is a :class:`UtcDateTime`: an instant, read back in UTC with
its offset on both databases.
"""

from __future__ import annotations

from datetime import UTC, datetime

from sqlalchemy import DateTime, Dialect, MetaData, func
from sqlalchemy.orm import DeclarativeBase, Mapped, mapped_column
from sqlalchemy.types import TypeDecorator

NAMING_CONVENTION = {
    "ix": "ix_%(column_0_label)s",
    "uq": "uq_%(table_name)s_%(column_0_N_name)s",
    "ck": "ck_%(table_name)s_%(constraint_name)s",
    "fk": "fk_%(table_name)s_%(column_0_N_name)s_%(referred_table_name)s",
    "pk": "pk_%(table_name)s",
}

#: length of a hex sha256 digest: the key of every artifact
HASH_LENGTH = 64


class UtcDateTime(TypeDecorator[datetime]):
    """``TIMESTAMP WITH TIME ZONE`` that reads back aware, in UTC, on SQLite too.

    SQLite has no time zones: it stores the text SQLAlchemy writes (or
    ``CURRENT_TIMESTAMP``, which is UTC) and reads it back naive, so a timestamp the
    API answered had no offset, which RFC 3339 (OpenAPI's ``date-time``) requires.
    Values are written as UTC (a naive one is taken to be UTC already) and read back
    with ``tzinfo=UTC`` whatever the database or its session time zone.
    """

    impl = DateTime(timezone=True)
    cache_ok = True

    def process_bind_param(self, value: datetime | None, dialect: Dialect) -> datetime | None:
        return None if value is None else _in_utc(value)

    def process_result_value(self, value: datetime | None, dialect: Dialect) -> datetime | None:
        return None if value is None else _in_utc(value)


def _in_utc(value: datetime) -> datetime:
    if value.tzinfo is None:
        return value.replace(tzinfo=UTC)
    return value.astimezone(UTC)


class Base(DeclarativeBase):
    metadata = MetaData(naming_convention=NAMING_CONVENTION)
    type_annotation_map = {datetime: UtcDateTime()}


def created_at_column() -> Mapped[datetime]:
    """A creation timestamp the database fills in, so every writer agrees on the clock."""
    return mapped_column(server_default=func.now(), nullable=False)
