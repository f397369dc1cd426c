"""Which database errors mean the database cannot serve (a 503, one CLI line) and which are
bugs (a 500, a traceback): real errors from real statements, on both backends."""

from __future__ import annotations

import sqlite3
from pathlib import Path

import pytest
from sqlalchemy import text
from sqlalchemy.exc import DBAPIError
from sqlalchemy.orm import Session

from app.db import DatabaseUnavailable, database_unavailable, make_engine
from app.models import Player


def raised(session: Session, statement: str) -> DBAPIError:
    """What ``statement`` raises, its savepoint rolled back so the test's session goes on."""
    with pytest.raises(DBAPIError) as caught, session.begin_nested():
        session.execute(text(statement))
    return caught.value


def test_statements_the_database_refuses_are_bugs(session: Session) -> None:
    session.add(Player(name="twice", kind="bot", token_hash="a" * 64))
    session.flush()
    duplicate = "INSERT INTO players (name, kind, token_hash) VALUES ('twice', 'bot', 'b')"
    for statement in (duplicate, "SELEC 1", "SELECT no_such_function(1)"):
        assert database_unavailable(raised(session, statement), "db") is None, statement


def test_a_missing_table_is_a_database_not_migrated(session: Session) -> None:
    unavailable = database_unavailable(raised(session, "SELECT * FROM no_such_table"), "db")
    assert unavailable is not None and unavailable.problem == "not migrated"
    assert "run `srg db upgrade`" in str(unavailable)


def test_a_lock_that_outlasts_the_busy_timeout_is_unavailable(tmp_path: Path) -> None:
    path = tmp_path / "locked.sqlite3"
    holder = sqlite3.connect(path, isolation_level=None)
    holder.execute("PRAGMA journal_mode = WAL")  # as srg's connections have it
    holder.execute("CREATE TABLE t (x INTEGER)")
    holder.execute("BEGIN IMMEDIATE")  # another process's writer, holding the lock
    engine = make_engine(f"sqlite:///{path}")
    try:
        with engine.connect() as connection:
            connection.exec_driver_sql("PRAGMA busy_timeout = 0")
            with pytest.raises(DBAPIError) as caught:
                connection.exec_driver_sql("INSERT INTO t VALUES (1)")
    finally:
        engine.dispose()
        holder.close()
    unavailable = database_unavailable(caught.value, str(path))
    assert isinstance(unavailable, DatabaseUnavailable) and unavailable.problem == "locked"
    assert str(unavailable) == f"cannot use the database {path} (locked): database is locked"
