"""``srg fsck`` as a service (app.services.fsck): every registered artifact hashed, a
flipped bit found and moved aside, and a repair that stores only what recomputes to the
digest the database holds, forgets a lost warm start and reports the rest.

tests/cli/test_cli_fsck.py drives the command on SQLite (strips, exit codes); here the
service runs on both backends, without renders.
"""

from __future__ import annotations

import hashlib
from collections.abc import Iterator
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from artifact_helpers import flip_in_place
from service_settings import BACKENDS, committed_settings
from sqlalchemy import select

from app.config import Settings
from app.db.sessions import transaction
from app.models import Clip, Edge, ExpansionClip, GrowthEpoch
from app.services.creation import init_graph
from app.services.fsck import FsckResult, count_to_scan, fsck
from app.services.growing import grow_graph
from app.services.loading import artifact_store

NOT_RECOMPUTABLE = "not recomputable (a checkpoint's arrays or a trace)"


@pytest.fixture(params=BACKENDS)
def settings(request: pytest.FixtureRequest, tmp_path: Path) -> Iterator[Settings]:
    """A toy graph grown by an sr-crowd epoch: clip bundles, an expansion's recorded
    clips and a STATERANK warm start."""
    for settings in committed_settings(request.param, tmp_path):
        with transaction(settings) as session:
            init_graph(session, settings, name="tank")
        grow_graph(partial(transaction, settings), settings, name="tank", expansions=4)
        yield settings


def column(settings: Settings, what: Any) -> list[str]:
    """The digests a column of artifact references holds."""
    with transaction(settings) as session:
        return [digest for digest in session.scalars(select(what)) if digest is not None]


def edge_errors(settings: Settings) -> list[float]:
    with transaction(settings) as session:
        return list(session.scalars(select(Edge.err).order_by(Edge.vertex, Edge.control)))


def sound_on_disk(settings: Settings, digest: str) -> bool:
    path = artifact_store(settings).path_for(digest)
    return path.is_file() and hashlib.sha256(path.read_bytes()).hexdigest() == digest


@pytest.mark.parametrize(
    ("result", "sound"),
    [
        (FsckResult(["ok"], artifacts=3, verified=3), True),
        (FsckResult(["*** in database main ***", "Page 7 is never used"]), False),
        (FsckResult(["ok"], corrupt=["a"], missing=["b"]), False),
        (FsckResult(["ok"], corrupt=["a"], missing=["b"], repaired=["a"]), False),
        (FsckResult(["ok"], corrupt=["a"], missing=["b"], repaired=["b", "a"]), True),
        (FsckResult(["damaged"], corrupt=["a"], repaired=["a"]), False),
    ],
    ids=["clean", "database", "broken", "half-repaired", "repaired", "repaired-bad-database"],
)
def test_a_result_is_sound_when_nothing_found_is_left_unrepaired(
    result: FsckResult, sound: bool
) -> None:
    assert result.sound is sound


def test_a_sound_store_passes_and_every_artifact_is_hashed(settings: Settings) -> None:
    calls: list[int] = []
    result = fsck(settings, progress=calls.append)
    assert result.database == ["ok"]
    assert result.artifacts == result.verified == count_to_scan(settings) == len(calls) > 0
    assert calls == [1] * result.artifacts
    assert (result.corrupt, result.missing, result.repaired, result.unrepaired) == ([], [], [], {})
    assert result.sound


def test_flipped_clips_are_found_moved_aside_and_recomputed_with_their_hash(
    settings: Settings,
) -> None:
    """Every clip's bundle and every recorded expansion clip rotted, so a repair must
    walk back along the clips to the start state."""
    store = artifact_store(settings)
    errors = edge_errors(settings)
    rotted = set(column(settings, Clip.bundle)) | set(column(settings, ExpansionClip.clip))
    for digest in rotted:
        flip_in_place(store.path_for(digest), at=-20)

    found = fsck(settings)
    assert set(found.corrupt) == rotted and found.missing == [] and not found.sound
    assert found.verified == found.artifacts - len(rotted)
    for digest in rotted:  # never used again where it lay
        assert not store.path_for(digest).exists() and store.corrupt_path(digest).is_file()

    repaired = fsck(settings, repair=True)
    assert set(repaired.repaired) == rotted and repaired.unrepaired == {}
    assert repaired.sound
    assert all(sound_on_disk(settings, digest) for digest in rotted)
    again = fsck(settings)
    assert again.verified == again.artifacts and again.sound
    assert edge_errors(settings) == errors


def test_a_lost_warm_start_is_forgotten(settings: Settings) -> None:
    (warm,) = column(settings, GrowthEpoch.warm_start)
    artifact_store(settings).path_for(warm).unlink()
    before = count_to_scan(settings)

    checked = fsck(settings)  # a check alone writes nothing
    assert checked.missing == [warm] and not checked.sound
    assert column(settings, GrowthEpoch.warm_start) == [warm]

    repaired = fsck(settings, repair=True)
    assert (repaired.missing, repaired.repaired, repaired.unrepaired) == ([warm], [warm], {})
    assert repaired.sound
    assert column(settings, GrowthEpoch.warm_start) == []
    assert count_to_scan(settings) == before - 1  # its row went with it
    assert fsck(settings).sound
    grow_graph(partial(transaction, settings), settings, name="tank", expansions=1)  # ranks cold


def test_what_cannot_be_recomputed_is_reported_and_left_as_found(settings: Settings) -> None:
    store = artifact_store(settings)
    with transaction(settings) as session:
        lost = store.put_bytes(b"an upload nobody can simulate", media_type="x/y", session=session)
        rotted = store.put_arrays({"x": np.arange(5)}, session=session)
    store.path_for(lost).unlink()
    flip_in_place(store.path_for(rotted), at=-3)

    result = fsck(settings, repair=True)
    assert (result.missing, result.corrupt) == ([lost], [rotted])
    assert result.repaired == []
    assert result.unrepaired == {lost: NOT_RECOMPUTABLE, rotted: NOT_RECOMPUTABLE}
    assert not result.sound
    assert not store.path_for(lost).exists() and not store.path_for(rotted).exists()
    again = fsck(settings, repair=True)  # still reported, never guessed
    assert set(again.unrepaired) == {lost, rotted} and not again.sound
