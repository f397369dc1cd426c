"""`srg db upgrade|downgrade` keeps every row and every value, or changes nothing.

The findings: on SQLite, `srg db downgrade 0008` emptied every graph (batch mode's table
copies dropped the old table under foreign keys, cascading) and exited 0, as did an
upgrade from 0006, which lost every trace; and a round trip through 0011 nulled every
publication's stored threshold and every trace's high-error count on both databases.

Here a database is filled by srg itself (an experiment; a graph initialised, published,
played, grown, published and played again), then walked down revision by revision and
up again. Each step that would lose data is refused in one line, naming what, and
changes nothing; with ``--drop-data`` it goes through, and at head every row of every
table is back, equal in every column that no refusal named.
"""

from __future__ import annotations

import json
import re
import subprocess
from pathlib import Path
from typing import Any

import pytest
from alembic.migration import MigrationContext
from alembic.script import ScriptDirectory
from cli_helpers import one_line_error, srg
from database_helpers import alembic_config
from sqlalchemy import inspect, text

from alembic import command
from app.db.engines import make_engine
from app.db.foreign_keys import foreign_keys_off

#: table -> (its columns, its rows sorted)
Contents = dict[str, tuple[tuple[str, ...], list[tuple[Any, ...]]]]

#: what a refusal names: ``table (N rows...)`` or ``table.column (N values...)``
LOST = re.compile(r"(\w+(?:\.\w+)?) \(\d+ (?:rows?|values?)")

#: the tables that hold what users made and played, kept by every revision from 0001
KEPT_EVERYWHERE = {
    "artifacts", "graphs", "clips", "vertices", "edges", "growth_epochs", "publications",
    "publication_edges", "players", "traces", "trace_steps",
}  # fmt: skip


def contents(url: str) -> Contents:
    """Every table's columns and rows (sorted), Alembic's own aside."""
    engine = make_engine(url)
    try:
        with engine.connect() as connection:
            found = {}
            for table in inspect(connection).get_table_names():
                if table != "alembic_version":
                    result = connection.execute(text(f'SELECT * FROM "{table}"'))
                    rows = sorted((tuple(row) for row in result), key=repr)
                    found[table] = (tuple(result.keys()), rows)
            return found
    finally:
        engine.dispose()


def revision(url: str) -> str | None:
    engine = make_engine(url)
    try:
        with engine.connect() as connection:
            return MigrationContext.configure(connection).get_current_revision()
    finally:
        engine.dispose()


def projected(table: tuple[tuple[str, ...], list[tuple[Any, ...]]], drop: set[str]) -> object:
    """A table's rows without the columns in ``drop``."""
    columns, rows = table
    keep = [i for i, column in enumerate(columns) if column not in drop]
    return sorted((tuple(row[i] for i in keep) for row in rows), key=repr)


def db(var: Path, url: str, *args: str) -> subprocess.CompletedProcess[str]:
    return srg(var, "db", *args, SRG_DATABASE_URL=url)


def refused(done: subprocess.CompletedProcess[str]) -> set[str]:
    """What a refused migration said it would lose (one line, exit 2)."""
    one_line_error(done, "nothing was changed (--drop-data loses them)")
    return set(LOST.findall(done.stderr))


def fill(var: Path, url: str) -> None:
    """Graphs, publications with their thresholds, bot traces with their figures, an
    experiment with its checkpoint: made by srg's own commands."""

    def run(*args: str) -> None:
        done = srg(var, *args, SRG_DATABASE_URL=url)
        assert done.returncode == 0, done.stderr

    run("db", "upgrade")
    plan = ("--seeds", "0", "--checkpoints", "300", "--sessions", "3")
    run("experiment", *plan, "--strategies", "baseline")
    run("init", "kept")
    run("publish", "kept", "--no-render")
    run("play", "kept", "--sessions", "4", "--seed", "1")
    run("grow", "kept", "--expansions", "2")
    run("publish", "kept", "--no-render")
    run("play", "kept", "--sessions", "4", "--seed", "2")
    # the readers of each graph's sums count every trace (0013 numbers those they did not)
    for graph in json.loads(srg(var, "status", "--json", SRG_DATABASE_URL=url).stdout):
        run("analytics", graph["name"])


def column(table: tuple[tuple[str, ...], list[tuple[Any, ...]]], name: str) -> list[Any]:
    columns, rows = table
    return [row[columns.index(name)] for row in rows]


def migrated(done: subprocess.CompletedProcess[str]) -> None:
    assert done.returncode == 0, done.stderr


def test_every_revision_keeps_every_row_or_refuses(empty_db_url: str, tmp_path: Path) -> None:
    var, url = tmp_path / "var", empty_db_url
    fill(var, url)
    start = contents(url)
    scripts = ScriptDirectory.from_config(alembic_config()).walk_revisions()
    walk = [script.revision for script in scripts]  # head first
    head = walk[0]
    assert len(start["graphs"][1]) == 2 and len(start["publications"][1]) == 3
    assert start["experiments"][1] and start["experiment_checkpoints"][1]
    assert None not in column(start["publications"], "high_error_threshold")
    assert None not in column(start["traces"], "high_error_steps")
    assert None not in column(start["traces"], "ordinal")

    # the reported downgrade: refused, naming the thresholds and the high-error counts
    lost = refused(db(var, url, "downgrade", "0008"))
    assert {"publications.high_error_threshold", "traces.high_error_steps"} <= lost
    assert (contents(url), revision(url)) == (start, head)

    # a round trip that keeps the thresholds computes each trace's figures again
    assert refused(db(var, url, "downgrade", "0011")) >= {"traces.error", "play_visits"}
    migrated(db(var, url, "downgrade", "0011", "--drop-data"))
    migrated(db(var, url, "upgrade"))
    again = contents(url)
    assert projected(again["traces"], {"error"}) == projected(start["traces"], {"error"})
    # SQL adds the steps' errors in its own order: equal up to rounding
    assert column(again["traces"], "error") == pytest.approx(column(start["traces"], "error"))
    assert {t: c for t, c in again.items() if t != "traces"} == {
        t: c for t, c in start.items() if t != "traces"
    }

    # down revision by revision to 0001: refused where data would go, then asked for
    named: set[str] = set()
    for target in walk[1:]:
        before = contents(url)
        done = db(var, url, "downgrade", target)
        if done.returncode != 0:
            named |= refused(done)
            assert (contents(url), revision(url)) == (before, walk[walk.index(target) - 1])
            done = db(var, url, "downgrade", target, "--drop-data")
        migrated(done)
        assert revision(url) == target
        for table, (_, rows) in contents(url).items():
            if table in start and table not in named:
                assert len(rows) == len(start[table][1]), (target, table)
    assert set(contents(url)) >= KEPT_EVERYWHERE
    for target in reversed(walk[:-1]):
        migrated(db(var, url, "upgrade", target))

    # every row at both ends is equal in every column that no refusal named
    end = contents(url)
    assert set(end) == set(start) and KEPT_EVERYWHERE.isdisjoint(named)
    for table in set(start) - named:
        lost_columns = {name.split(".")[1] for name in named if name.startswith(f"{table}.")}
        assert end[table][0] == start[table][0]
        assert projected(end[table], lost_columns) == projected(start[table], lost_columns)


def test_an_upgrade_from_0006_keeps_every_trace(empty_db_url: str, tmp_path: Path) -> None:
    """0007 and 0009 rebuild players and graphs on SQLite: the finding lost every trace."""
    migrate_to_0006_with_traces(empty_db_url, traces=150)
    start = contents(empty_db_url)
    assert len(start["traces"][1]) == 150
    done = db(tmp_path / "var", empty_db_url, "upgrade")
    assert done.returncode == 0, done.stderr
    end = contents(empty_db_url)
    for table, (columns, rows) in start.items():
        added = set(end[table][0]) - set(columns)
        assert projected(end[table], added) == rows, table


def test_a_sqlite_migration_that_leaves_a_broken_foreign_key_is_rolled_back(
    tmp_path: Path,
) -> None:
    """With foreign keys off, nothing stops a migration leaving a key that points nowhere:
    ``PRAGMA foreign_key_check`` does, before the run commits, and SQLite's DDL rolls
    back with the rest, six migrations of it (a step left by an earlier bug stands in for
    the breakage). PostgreSQL enforces its keys all along."""
    url = f"sqlite:///{tmp_path / 'srg.sqlite3'}"
    migrate_to_0006_with_traces(url, traces=2)
    broken_foreign_key(url)
    start = contents(url)
    done = db(tmp_path / "var", url, "upgrade")
    one_line_error(done, "broken foreign keys (1 trace_steps rows refer to no traces row)")
    assert (contents(url), revision(url)) == (start, "0006")


#: a toy graph of two vertices and their sim edges, published, at revision 0006
AT_0006 = (
    "INSERT INTO artifacts (hash, size, media_type) VALUES ('b', 1, 'application/x-npz')",
    "INSERT INTO graphs (id, name, dynamics, scene, n_controls, frames_per_clip, seed, "
    "strategy, growing, revision, player_model) "
    "VALUES (1, 'kept', 'toy', '{}', 1, 10, 0, 'sr-crowd', false, 1, 'eq2')",
    "INSERT INTO clips (graph_id, idx, source, control, kinetic, potential, score, "
    "descriptor, bundle) VALUES (1, 0, 0, 0, 0.5, :blob, 1.0, :blob, 'b'), "
    "(1, 1, 1, 0, 0.5, :blob, 1.0, :blob, 'b')",
    "INSERT INTO vertices (graph_id, idx, control, clip_idx) VALUES (1, 0, 0, 0), (1, 1, 0, 1)",
    "INSERT INTO edges (graph_id, vertex, control, kind, clip_idx, dst, err) "
    "VALUES (1, 0, 0, 0, 1, 1, 0.0), (1, 1, 0, 0, 0, 0, 0.0)",
    "INSERT INTO growth_epochs (graph_id, number, strategy, status, expansions, relinks, "
    "size_frames, renders) VALUES (1, 1, 'sr-crowd', 'done', 0, 0, 20, true)",
    "INSERT INTO publications (id, graph_id, number, n_vertices, n_edges, size_frames, start) "
    "VALUES (1, 1, 1, 2, 2, 20, 0)",
    "INSERT INTO publication_edges (publication_id, vertex, control, dst, kind, err, score) "
    "VALUES (1, 0, 0, 1, 0, 0.0, 1.0), (1, 1, 0, 0, 0, 0.0, 1.0)",
    "INSERT INTO players (id, name, kind, token_hash) VALUES (1, 'bot-crowd', 'bot', 'hash')",
)
#: ``:n`` two-step sessions of the bot on the publication
TRACES = """
INSERT INTO traces (id, publication_id, player_id, idempotency_key, n_steps)
VALUES (:id, 1, 1, :key, 2)
"""
STEPS = "INSERT INTO trace_steps (trace_id, step, vertex, control) VALUES (:trace, :step, :step, 0)"


def migrate_to_0006_with_traces(url: str, *, traces: int) -> None:
    """``url`` migrated to 0006 and filled with plain SQL (srg writes at head only)."""
    engine = make_engine(url)
    try:
        with engine.connect() as connection, foreign_keys_off(connection), connection.begin():
            command.upgrade(alembic_config(connection), "0006")
            for statement in AT_0006:
                connection.execute(text(statement), {"blob": b"\x00"})
            ids = range(1, traces + 1)
            connection.execute(text(TRACES), [{"id": i, "key": f"k{i}"} for i in ids])
            connection.execute(
                text(STEPS), [{"trace": i, "step": step} for i in ids for step in (0, 1)]
            )
    finally:
        engine.dispose()


def broken_foreign_key(url: str) -> None:
    """A step of a trace that does not exist, written with foreign keys off (SQLite)."""
    engine = make_engine(url)
    try:
        with engine.connect() as connection, foreign_keys_off(connection), connection.begin():
            connection.execute(text(STEPS), {"trace": 99, "step": 0})
    finally:
        engine.dispose()
