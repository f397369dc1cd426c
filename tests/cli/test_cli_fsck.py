"""`srg fsck`: a flipped bit anywhere is found, never used, and a clip is recomputed from
its stored state with its hash proved."""

from __future__ import annotations

import json
import sqlite3
from pathlib import Path

import pytest
from cli_helpers import ok, srg


@pytest.fixture
def var(tmp_path: Path) -> Path:
    var = tmp_path / "var"
    ok(var, "db", "upgrade")
    ok(var, "init", "toy1", "--dynamics", "toy")
    ok(var, "grow", "toy1", "--expansions", "4")
    return var


def _query(var: Path, sql: str) -> list[str]:
    with sqlite3.connect(var / "srg.sqlite3") as db:
        return [str(row[0]) for row in db.execute(sql)]


def _flip(var: Path, digest: str) -> None:
    path = var / "data" / digest[:2] / digest[2:4] / digest
    data = bytearray(path.read_bytes())
    data[len(data) // 2] ^= 0x04
    path.write_bytes(bytes(data))


def test_a_sound_store_passes(var: Path) -> None:
    result = json.loads(ok(var, "fsck", "--json"))
    assert result["database"] == ["ok"] and result["artifacts"] == result["verified"] > 0
    assert result["corrupt"] == result["missing"] == []


def test_corrupt_clips_are_found_moved_aside_and_recomputed_with_their_hash(var: Path) -> None:
    bundles = _query(var, "SELECT DISTINCT bundle FROM clips")
    deep = _query(var, "SELECT bundle FROM clips ORDER BY idx DESC LIMIT 1")[0]
    before = _query(var, "SELECT err FROM edges ORDER BY vertex, control")
    for digest in bundles:  # every clip, so a repair must walk back to the start state
        _flip(var, digest)
    found = srg(var, "fsck", "--json")
    assert found.returncode == 1
    assert set(json.loads(found.stdout)["corrupt"]) == set(bundles)
    told = srg(var, "fsck")  # the table counts what --json lists, rather than a wall of hashes
    assert f"{len(bundles)} items (--json lists them)" in told.stdout
    assert not any(digest in told.stdout for digest in bundles)
    corrupt = srg(var, "grow", "toy1", "--expansions", "1")
    assert corrupt.returncode == 2 and "does not match its hash" in corrupt.stderr
    repaired = json.loads(ok(var, "fsck", "--repair", "--json"))
    assert set(repaired["repaired"]) == set(bundles) and repaired["unrepaired"] == {}
    assert (var / "data" / deep[:2] / deep[2:4] / deep).is_file()
    again = json.loads(ok(var, "fsck", "--json"))
    assert again["verified"] == again["artifacts"] and again["corrupt"] == []
    assert _query(var, "SELECT err FROM edges ORDER BY vertex, control") == before
    ok(var, "grow", "toy1", "--expansions", "1")


def test_what_cannot_be_recomputed_is_reported_and_the_exit_says_so(var: Path) -> None:
    ok(var, "publish", "toy1")
    strip = _query(var, "SELECT animation FROM publication_edges WHERE animation IS NOT NULL")[0]
    _flip(var, strip)
    result = srg(var, "fsck", "--repair", "--json")
    assert result.returncode == 1
    assert "not recomputable" in json.loads(result.stdout)["unrepaired"][strip]
