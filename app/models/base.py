"""The declarative base every model shares.

A naming convention makes constraint names deterministic, so Alembic can drop and alter
them by name on PostgreSQL and recreate them in SQLite batch mode alike.
"""

from __future__ import annotations

from datetime import datetime

from sqlalchemy import DateTime, MetaData, func
from sqlalchemy.orm import DeclarativeBase, Mapped, mapped_column

NAMING_CONVENTION = {
    "ix": "ix_%(column_0_label)s",
    "uq": "uq_%(table_name)s_%(column_0_N_name)s",
    "ck": "ck_%(table_name)s_%(constraint_name)s",
    "fk": "fk_%(table_name)s_%(column_0_N_name)s_%(referred_table_name)s",
    "pk": "pk_%(table_name)s",
}

#: length of a hex sha256 digest: the key of every artifact
HASH_LENGTH = 64


class Base(DeclarativeBase):
    metadata = MetaData(naming_convention=NAMING_CONVENTION)


def created_at_column() -> Mapped[datetime]:
    """A creation timestamp the database fills in, so every writer agrees on the clock."""
    return mapped_column(DateTime(timezone=True), server_default=func.now(), nullable=False)
