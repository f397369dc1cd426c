"""`srg fsck`: a flipped bit anywhere is found, never used, and a clip is recomputed from
its stored state with its hash proved; a strip is rendered again from its clip, by a
repair or by the next publish."""

from __future__ import annotations

import hashlib
import json
import sqlite3
from pathlib import Path

import pytest
from cli_helpers import ok, srg
from fastapi.testclient import TestClient

from app.api.app import create_app
from app.config import Settings
from app.db.engines import dispose_engines


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
    """A blend strip of publication 1 whose edge was expanded since: no clip or edge of
    the graph shows it, so nothing says what to render."""
    ok(var, "publish", "toy1")
    ok(var, "grow", "toy1", "--expansions", "1")
    strip = _query(
        var,
        "SELECT animation FROM publication_edges WHERE animation IS NOT NULL"
        " AND animation NOT IN (SELECT animation FROM edges WHERE animation IS NOT NULL)"
        " AND animation NOT IN (SELECT animation FROM clips WHERE animation IS NOT NULL)",
    )[0]
    _flip(var, strip)
    result = srg(var, "fsck", "--repair", "--json")
    assert result.returncode == 1
    assert "not recomputable" in json.loads(result.stdout)["unrepaired"][strip]


def _published_strips(var: Path, number: int) -> dict[str, str]:
    """Publication ``number``'s strips by edge ("vertex.control")."""
    rows = _query(
        var,
        "SELECT e.vertex || '.' || e.control || ' ' || e.animation FROM publication_edges e"
        f" JOIN publications p ON p.id = e.publication_id WHERE p.number = {number}"
        " AND e.animation IS NOT NULL",
    )
    return dict(row.split(" ") for row in rows)


def _rotted_strips(var: Path) -> tuple[str, str]:
    """A clip's strip and a blend edge's of publication 1 (one no clip shows: a blend may
    equal a clip's), a byte of each flipped."""
    strips = (
        "SELECT e.animation FROM publication_edges e JOIN publications p"
        " ON p.id = e.publication_id WHERE p.number = 1 AND e.animation IS NOT NULL"
    )
    sim = _query(var, f"{strips} AND e.kind = 0 LIMIT 1")[0]
    blend = _query(
        var,
        f"{strips} AND e.kind = 1 AND e.animation NOT IN"
        " (SELECT animation FROM clips WHERE animation IS NOT NULL) LIMIT 1",
    )[0]
    _flip(var, sim)
    _flip(var, blend)
    return sim, blend


def _served(var: Path, digests: set[str]) -> dict[str, tuple[int, bool]]:
    """Each animation's HTTP status and whether its body hashes to its digest."""
    try:
        with TestClient(create_app(Settings(var_dir=var, database_url=""))) as client:
            replies = {digest: client.get(f"/api/animations/{digest}") for digest in digests}
    finally:
        dispose_engines()
    return {
        digest: (reply.status_code, hashlib.sha256(reply.content).hexdigest() == digest)
        for digest, reply in replies.items()
    }


@pytest.mark.parametrize("found_first", [False, True], ids=["in-place", "moved-aside"])
def test_a_rotted_strip_is_rendered_again_at_the_next_publish(var: Path, found_first: bool) -> None:
    """Rotted in place, or already found and moved aside by a read: the next publication
    shows a strip rendered again from the clip, the same bytes under the same digest (the
    render is deterministic), which heals the first publication's too."""
    ok(var, "publish", "toy1")
    first = _published_strips(var, 1)
    rotted = set(_rotted_strips(var))
    if found_first:
        assert srg(var, "fsck").returncode == 1
    published = json.loads(ok(var, "publish", "toy1", "--json"))
    assert published["number"] == 2 and published["rerendered_strips"] == len(rotted)
    second = _published_strips(var, 2)
    assert second == first
    assert _served(var, set(second.values())) == {d: (200, True) for d in second.values()}
    clean = json.loads(ok(var, "fsck", "--json"))
    assert clean["verified"] == clean["artifacts"] and clean["corrupt"] == clean["missing"] == []


def test_a_rotted_strip_is_rendered_again_by_a_repair(var: Path) -> None:
    """Its clip's bundle rotted too: the repair recomputes the clip first, then renders the
    strip from it, and stores it only under the digest it hashes to."""
    ok(var, "publish", "toy1")
    sim, blend = _rotted_strips(var)
    bundle = _query(var, f"SELECT bundle FROM clips WHERE animation = '{sim}' ORDER BY idx")[0]
    _flip(var, bundle)
    repaired = json.loads(ok(var, "fsck", "--repair", "--json"))
    assert set(repaired["corrupt"]) == set(repaired["repaired"]) == {sim, blend, bundle}
    assert repaired["unrepaired"] == {}
    assert _served(var, {sim, blend}) == {sim: (200, True), blend: (200, True)}
    clean = json.loads(ok(var, "fsck", "--json"))
    assert clean["verified"] == clean["artifacts"] and clean["corrupt"] == clean["missing"] == []
    published = json.loads(ok(var, "publish", "toy1", "--json"))
    assert published["rerendered_strips"] == 0
    assert _published_strips(var, 2) == _published_strips(var, 1)
