"""What a database error means to the user.

One that says the database cannot serve (:func:`database_unavailable`) is a 503 in the
API and one line from the CLI, and ``srg serve`` and the commands that write look for
those before they start (:func:`app.db.migrations.require_current_schema`,
:func:`app.db.engines.require_intact`). Any other database error is srg's bug and stays
one.
"""

from __future__ import annotations

import re
import shlex
import sqlite3
from collections.abc import Iterator
from contextlib import contextmanager

from sqlalchemy import Engine
from sqlalchemy.engine import URL
from sqlalchemy.exc import DBAPIError, OperationalError

from app.core.errors import Unavailable

#: the one line that says what to do about a database without srg's tables
UPGRADE_HINT = "run `srg db upgrade`"


class DatabaseUnavailable(Unavailable):
    """The database cannot serve srg now; ``problem`` says why in a few words.

    The message names the database (its file, or its URL without the password) for the
    operator; the API tells its clients the ``problem`` alone.
    """

    problem = "unavailable"

    def __init__(self, message: str, problem: str | None = None) -> None:
        super().__init__(message)
        self.problem = problem or self.problem


class DatabaseNotReady(DatabaseUnavailable):
    """The configured database does not exist yet (create it), or has no srg schema
    (upgrade it)."""

    problem = "not migrated"


class DatabaseUnusable(DatabaseUnavailable):
    """The database file is not a database, or a damaged one."""

    problem = "not a database"


def schema_missing(exc: DBAPIError) -> bool:
    """Whether ``exc`` says a table or column of srg's schema is not there (not migrated).

    SQLite says "no such table/column"; PostgreSQL raises undefined_table (42P01) or
    undefined_column (42703).
    """
    orig = exc.orig
    if getattr(orig, "sqlstate", None) in ("42P01", "42703"):
        return True
    return str(orig).startswith(("no such table", "no such column"))


#: what PostgreSQL answers a connection to a database it does not have (its SQLSTATE,
#: invalid_catalog_name 3D000, comes in the server's startup reply, which libpq turns into
#: this text only: psycopg's connection error carries no SQLSTATE)
_NO_SUCH_DATABASE = re.compile(r'FATAL:\s+database ".*" does not exist')


def database_missing(exc: DBAPIError) -> bool:
    """Whether ``exc`` says the server has no database of the configured name."""
    return (
        getattr(exc.orig, "sqlstate", None) == "3D000"
        or _NO_SUCH_DATABASE.search(str(exc.orig)) is not None
    )


def createdb_command(url: URL) -> str:
    """The ``createdb`` line that makes the PostgreSQL database ``url`` names, on its server
    and as its user (libpq's own defaults where the URL leaves a part out)."""
    words = ["createdb"]
    if url.host:
        words += ["-h", url.host]
    if url.port:
        words += ["-p", str(url.port)]
    if url.username:
        words += ["-U", url.username]
    words.append(url.database or "")
    return shlex.join(words)


#: SQLite's primary result codes (https://www.sqlite.org/rescode.html) that say the file
#: cannot serve as it is, whatever the statement; what each means to the user
_SQLITE_PROBLEMS = {
    sqlite3.SQLITE_BUSY: "locked",
    sqlite3.SQLITE_LOCKED: "locked",
    sqlite3.SQLITE_CANTOPEN: "cannot be opened",
    sqlite3.SQLITE_READONLY: "read-only",
    sqlite3.SQLITE_IOERR: "I/O error",
    sqlite3.SQLITE_FULL: "disk full",
    sqlite3.SQLITE_NOTADB: "not a database",
    sqlite3.SQLITE_CORRUPT: "corrupt",
}
#: PostgreSQL's SQLSTATE classes that say the server cannot serve now, whatever the statement
_SERVER_PROBLEMS = {
    "08": "unreachable",
    "53": "out of resources",
    "57": "stopped by its operator",
    "58": "I/O error",
}
#: the codes of those classes that mean more than their class: query_canceled (57014) is
#: what ``statement_timeout`` raises, a limit set on the server or the role, not an
#: operator stopping the server (a cancel request raises it too, and its line says so)
_SERVER_STATES = {"57014": "statement timeout"}


def database_unavailable(exc: DBAPIError, url: URL) -> DatabaseUnavailable | None:
    """What ``exc`` says about the database when it says it cannot serve; ``None`` for a bug.

    It cannot serve when its server cannot be reached (or dropped the connection), its
    file is not a database or is damaged, a lock outlasts the busy timeout and the write
    retries (:mod:`app.store.transactions`), or it has no srg schema, or (on a server) does
    not exist. A statement the database refuses (a constraint, a syntax error) is our bug
    and stays one; both drivers raise some of those as ``OperationalError`` too, so the
    driver's code decides, not the exception's class. The message names the database at
    ``url`` (:func:`shown_database`).
    """
    where = shown_database(url)
    if schema_missing(exc):
        return DatabaseNotReady(
            f"the database {where} has no srg schema (or an older one): {UPGRADE_HINT}"
        )
    if database_missing(exc):
        return DatabaseNotReady(
            f"the database {where} does not exist: create it with `{createdb_command(url)}`, "
            f"then {UPGRADE_HINT}",
            "does not exist",
        )
    orig = exc.orig
    if isinstance(orig, sqlite3.Error):
        problem = _SQLITE_PROBLEMS.get((getattr(orig, "sqlite_errorcode", None) or 0) & 0xFF)
    elif exc.connection_invalidated or (
        isinstance(exc, OperationalError) and getattr(orig, "sqlstate", None) is None
    ):
        problem = "unreachable"  # the connection failed or was lost: no SQLSTATE for that
    else:
        state = str(getattr(orig, "sqlstate", ""))
        problem = _SERVER_STATES.get(state) or _SERVER_PROBLEMS.get(state[:2])
    if problem is None:
        return None
    kind = DatabaseUnusable if problem in ("not a database", "corrupt") else DatabaseUnavailable
    detail = (str(orig).splitlines() or [type(orig).__name__])[0]
    return kind(f"cannot use the database {where} ({problem}): {detail}", problem)


def shown_database(url: URL) -> str:
    """How messages name a database: its file for SQLite, else its URL without password."""
    if url.get_backend_name() == "sqlite" and url.database:
        return url.database
    return url.render_as_string(hide_password=True)


@contextmanager
def unavailable_raised(engine: Engine) -> Iterator[None]:
    """Raise what :func:`database_unavailable` makes of a database error, where it is one."""
    try:
        yield
    except DBAPIError as exc:
        unavailable = database_unavailable(exc, engine.url)
        if unavailable is None:
            raise
        raise unavailable from None
