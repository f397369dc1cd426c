"""`srg gc`: the orphaned artifacts of an interrupted grow go; the graph's own stay."""

from __future__ import annotations

import json
import os
import re
import time
from datetime import UTC, datetime
from pathlib import Path

import pytest
from cli_helpers import ok, one_line_error, srg
from sqlalchemy import insert, select

from app.db.engines import make_engine
from app.models import Artifact

HOURS_AGO = time.time() - 2 * 3600


@pytest.fixture
def var(tmp_path: Path) -> Path:
    var = tmp_path / "var"
    ok(var, "db", "upgrade")
    ok(var, "init", "toy1")
    ok(var, "grow", "toy1", "--expansions", "3")
    return var


def artifact_files(var: Path) -> set[Path]:
    return {path for path in (var / "data").rglob("*") if path.is_file()}


def test_gc_collects_what_an_interrupted_grow_left_and_keeps_the_graph(var: Path) -> None:
    used = artifact_files(var)
    for path in used:  # the graph's own files are old too: they stay because rows use them
        os.utime(path, (HOURS_AGO, HOURS_AGO))
    # what Ctrl-C mid-grow leaves: a file whose row never committed, a temporary file,
    # and (from an older interruption) a registered row nothing references
    orphan = var / "data" / "ab" / "cd" / ("abcd" + "0" * 60)
    orphan.parent.mkdir(parents=True)
    orphan.write_bytes(b"x" * 100)
    temporary = orphan.parent / ".tmp-k3j4"
    temporary.write_bytes(b"y" * 10)
    unreferenced = "ef01" + "1" * 60
    row_file = var / "data" / "ef" / "01" / unreferenced
    row_file.parent.mkdir(parents=True)
    row_file.write_bytes(b"z" * 1000)
    for path in (orphan, temporary, row_file):
        os.utime(path, (HOURS_AGO, HOURS_AGO))
    engine = make_engine(f"sqlite:///{var / 'srg.sqlite3'}")
    with engine.begin() as connection:
        connection.execute(
            insert(Artifact).values(
                hash=unreferenced,
                size=1000,
                media_type="x/y",
                created_at=datetime(2000, 1, 1, tzinfo=UTC),
            )
        )
    fresh = var / "data" / "ab" / "cd" / ("abcd" + "2" * 60)  # a running grow's, just written
    fresh.write_bytes(b"f")

    dry = json.loads(ok(var, "gc", "--dry-run", "--json"))
    assert dry == {
        "dry_run": True,
        "older_than_s": 3600.0,
        "rows": 1,
        "files": 3,
        "bytes_freed": 1110,
    }
    assert artifact_files(var) == used | {orphan, temporary, row_file, fresh}

    done = json.loads(ok(var, "gc", "--json"))
    assert (done["rows"], done["files"], done["bytes_freed"]) == (1, 3, 1110)
    assert artifact_files(var) == used | {fresh}
    with engine.connect() as connection:
        assert unreferenced not in set(connection.scalars(select(Artifact.hash)))
    engine.dispose()
    ok(var, "grow", "toy1", "--expansions", "2")  # loads every clip bundle it kept
    ok(var, "publish", "toy1")
    assert json.loads(ok(var, "gc", "--json"))["rows"] == 0
    table = ok(var, "gc")
    for figure in ("rows", "files", "bytes freed"):
        assert re.search(rf"^\s*{figure}\s+0\s*$", table, re.MULTILINE), table


@pytest.mark.parametrize(
    ("grace", "says"),
    [
        ("-1", "'--older-than': Input should be greater than or equal to 0"),
        ("nan", "'--older-than': Input should be greater than or equal to 0"),
        ("inf", "--older-than must be a finite number of seconds"),
    ],
)
def test_a_grace_period_that_is_no_number_of_seconds_is_refused_before_any_scan(
    var: Path, grace: str, says: str
) -> None:
    done = srg(var, "gc", "--older-than", grace)
    one_line_error(done, says)
    assert len(done.stderr.splitlines()) == 1, done.stderr  # no progress bar first
