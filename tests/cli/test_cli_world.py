"""`srg init --world`: a graph remembers the world seed of its start state, and fsck
recomputes its clips from that start."""

from __future__ import annotations

import json
import sqlite3
from pathlib import Path

import pytest
from cli_helpers import ok, one_line_error, srg


def _query(var: Path, sql: str) -> list[tuple[object, ...]]:
    with sqlite3.connect(var / "srg.sqlite3") as db:
        return list(db.execute(sql))


@pytest.mark.parametrize(
    ("world", "fragment"),
    [
        ("-1", "'--world': Input should be greater than or equal to 0"),
        ("2147483648", "'--world': Input should be less than or equal to 2147483647"),
    ],
)
def test_a_world_out_of_range_is_one_line_and_writes_nothing(
    tmp_path: Path, world: str, fragment: str
) -> None:
    ok(tmp_path, "db", "upgrade")
    one_line_error(srg(tmp_path, "init", "refused", "--world", world), fragment)
    assert _query(tmp_path, "SELECT name FROM graphs") == []


def test_a_world_graph_starts_elsewhere_and_fsck_recomputes_it_from_there(
    tmp_path: Path,
) -> None:
    ok(tmp_path, "db", "upgrade")
    ok(tmp_path, "init", "canonical")
    ok(tmp_path, "init", "world3", "--world", "3")
    assert _query(tmp_path, "SELECT name, world FROM graphs ORDER BY id") == [
        ("canonical", None),
        ("world3", 3),
    ]
    bundles = _query(
        tmp_path,
        "SELECT c.bundle FROM clips c JOIN graphs g ON g.id = c.graph_id"
        " WHERE g.name = 'world3' ORDER BY c.idx",
    )
    canonical = _query(
        tmp_path,
        "SELECT c.bundle FROM clips c JOIN graphs g ON g.id = c.graph_id"
        " WHERE g.name = 'canonical' ORDER BY c.idx",
    )
    assert bundles[0] != canonical[0]  # the first clip already starts from another state
    for (digest,) in bundles:  # every clip: a repair walks back to the world's start
        path = tmp_path / "data" / str(digest)[:2] / str(digest)[2:4] / str(digest)
        data = bytearray(path.read_bytes())
        data[len(data) // 2] ^= 0x04
        path.write_bytes(bytes(data))
    repaired = json.loads(ok(tmp_path, "fsck", "--repair", "--json"))
    assert set(repaired["repaired"]) == {str(d) for (d,) in bundles}
    assert repaired["unrepaired"] == {}
