"""A database srg cannot use stops a command before it serves or writes: one line, exit 2.

``srg serve`` checks its database before it listens (reachable, a database, migrated,
intact) rather than answering every request with a 503; the commands that write run
SQLite's ``quick_check`` first, since SQLite notices a damaged page only when a statement
reads it.
"""

from __future__ import annotations

import sqlite3
from pathlib import Path

import pytest
import uvicorn
from cli_helpers import ok, one_line_error, srg
from database_helpers import migrate

from app.config import Settings


@pytest.fixture
def started(monkeypatch: pytest.MonkeyPatch) -> list[object]:
    """The apps ``srg serve`` handed to uvicorn, which is not run: no test listens."""
    apps: list[object] = []
    monkeypatch.setattr(uvicorn, "run", lambda app, **_: apps.append(app))
    return apps


def garbage_file(path: Path) -> Path:
    path.write_bytes(b"SQLite format 3\x00" + bytes(range(256)) * 20)
    return path


def test_serve_starts_on_a_database_it_can_use(tmp_path: Path, started: list[object]) -> None:
    ok(tmp_path / "var", "serve")
    assert len(started) == 1


@pytest.mark.parametrize(
    ("database", "fragment"),
    [
        ("unreachable", "(unreachable)"),
        ("not a database", "(not a database)"),
        ("not migrated", "run `srg db upgrade`"),
    ],
)
def test_serve_refuses_a_database_it_cannot_use(
    tmp_path: Path, started: list[object], database: str, fragment: str
) -> None:
    """The finding: serve started without a word, and every request was a 500."""
    if database == "unreachable":
        url = "postgresql+psycopg://postgres@127.0.0.1:1/none"
    elif database == "not a database":
        url = f"sqlite:///{garbage_file(tmp_path / 'garbage.sqlite3')}"
    else:  # migrated once, not since the last migration was added
        url = f"sqlite:///{tmp_path / 'old.sqlite3'}"
        migrate(url, "0004")
    one_line_error(srg(tmp_path / "var", "serve", SRG_DATABASE_URL=url), fragment)
    assert started == []


def damage_a_page_nothing_reads(database: Path) -> None:
    """Overwrite the root page of the experiments table, which graph commands never read."""
    with sqlite3.connect(database) as connection:
        connection.execute("PRAGMA wal_checkpoint(TRUNCATE)")  # every page in the file
        (page_size,) = connection.execute("PRAGMA page_size").fetchone()
        (root,) = connection.execute(
            "SELECT rootpage FROM sqlite_schema WHERE name = 'experiments'"
        ).fetchone()
    connection.close()
    with database.open("r+b") as file:
        file.seek((root - 1) * page_size)
        file.write(bytes(range(256)) * (page_size // 256))


def test_commands_that_write_refuse_a_damaged_sqlite_file(tmp_path: Path) -> None:
    """The finding: grow, publish and play wrote on and exited 0, their reads missing the
    damaged page; reads stay unchecked (a quick_check reads the whole file)."""
    var = tmp_path / "var"
    ok(var, "init", "g")
    ok(var, "publish", "g")
    database = Path(Settings(var_dir=var).resolved_database_url.removeprefix("sqlite:///"))
    damage_a_page_nothing_reads(database)
    damaged = database.read_bytes()
    for command in (["grow", "g", "--expansions", "1"], ["publish", "g"], ["play", "g"]):
        one_line_error(srg(var, *command), "(corrupt)")
    assert database.read_bytes() == damaged
    assert "g" in ok(var, "status")
