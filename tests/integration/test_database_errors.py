"""Which database errors mean the database cannot serve (a 503, one CLI line) and which are
bugs (a 500, a traceback): real errors from real statements, on both backends."""

from __future__ import annotations

import sqlite3
import uuid
from pathlib import Path

import pytest
from database_helpers import postgres_base_url
from sqlalchemy import text
from sqlalchemy.engine import make_url
from sqlalchemy.exc import DBAPIError
from sqlalchemy.orm import Session

from app.db.engines import make_engine
from app.db.errors import (
    DatabaseNotReady,
    DatabaseUnavailable,
    createdb_command,
    database_unavailable,
)
from app.models import Player

#: the database the messages name where the test does not look at the name
SOME_URL = make_url("sqlite:///db")


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
        assert database_unavailable(raised(session, statement), SOME_URL) is None, statement


def test_a_missing_table_is_a_database_not_migrated(session: Session) -> None:
    unavailable = database_unavailable(raised(session, "SELECT * FROM no_such_table"), SOME_URL)
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
    unavailable = database_unavailable(caught.value, make_url(f"sqlite:///{path}"))
    assert isinstance(unavailable, DatabaseUnavailable) and unavailable.problem == "locked"
    assert str(unavailable) == f"cannot use the database {path} (locked): database is locked"


@pytest.mark.postgres
def test_a_postgresql_database_that_does_not_exist_says_how_to_create_it() -> None:
    """The finding: a missing database read as "unreachable", with no word of createdb."""
    base = make_url(postgres_base_url())
    url = base.set(port=base.port or 5432, database=f"srg_missing_{uuid.uuid4().hex[:10]}")
    engine = make_engine(url.render_as_string(hide_password=False))
    try:
        with pytest.raises(DBAPIError) as caught, engine.connect():
            pass
    finally:
        engine.dispose()
    unavailable = database_unavailable(caught.value, url)
    assert isinstance(unavailable, DatabaseNotReady) and unavailable.problem == "does not exist"
    create = f"createdb -h {url.host} -p {url.port} -U {url.username} {url.database}"
    assert f"create it with `{create}`, then run `srg db upgrade`" in str(unavailable)


@pytest.mark.postgres
def test_a_statement_timeout_is_named_as_one() -> None:
    """The finding: SQLSTATE 57014 read as its class, "stopped by its operator"."""
    url = make_url(postgres_base_url()).set(database="postgres")
    engine = make_engine(url.render_as_string(hide_password=False))
    try:
        with pytest.raises(DBAPIError) as caught, engine.connect() as connection:
            connection.exec_driver_sql("SET statement_timeout = '50ms'")
            connection.exec_driver_sql("SELECT pg_sleep(5)")
    finally:
        engine.dispose()
    assert getattr(caught.value.orig, "sqlstate", None) == "57014"
    unavailable = database_unavailable(caught.value, url)
    assert isinstance(unavailable, DatabaseUnavailable)
    assert unavailable.problem == "statement timeout"
    shown = url.render_as_string()
    assert str(unavailable).startswith(f"cannot use the database {shown} (statement timeout): ")


def test_the_createdb_line_names_only_what_the_url_gives() -> None:
    named = make_url("postgresql+psycopg://ops:secret@db.example:6543/srg")
    assert createdb_command(named) == "createdb -h db.example -p 6543 -U ops srg"
    assert createdb_command(make_url("postgresql+psycopg:///srg")) == "createdb srg"
    assert createdb_command(make_url("postgresql:///odd name")) == "createdb 'odd name'"
