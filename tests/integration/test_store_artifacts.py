"""The content-addressed artifact store."""

from __future__ import annotations

import hashlib
import io
import logging
import zipfile

import numpy as np
import pytest
from artifact_helpers import flip_in_place
from sqlalchemy import func, select
from sqlalchemy.orm import Session

from app.models import Artifact
from app.store.array_codec import ARRAYS_MEDIA_TYPE, MAGIC
from app.store.artifacts import ArtifactCorrupt, ArtifactNotFound, ArtifactStore


def test_bytes_are_stored_by_sha256_with_fan_out(
    artifacts: ArtifactStore, session: Session
) -> None:
    digest = artifacts.put_bytes(b"tank", media_type="text/plain", session=session)
    assert digest == hashlib.sha256(b"tank").hexdigest()
    path = artifacts.path_for(digest)
    assert path.relative_to(artifacts.root).parts == (digest[:2], digest[2:4], digest)
    assert artifacts.get_bytes(digest) == b"tank"
    row = session.get_one(Artifact, digest)
    assert (row.size, row.media_type) == (4, "text/plain")


def test_put_is_idempotent(artifacts: ArtifactStore, session: Session) -> None:
    first = artifacts.put_bytes(b"same", media_type="text/plain", session=session)
    second = ArtifactStore(artifacts.root).put_bytes(
        b"same", media_type="text/plain", session=session
    )
    assert first == second
    assert session.scalar(select(func.count()).select_from(Artifact)) == 1
    assert not [p for p in artifacts.root.rglob("*") if p.name.startswith(".tmp-")]


def test_arrays_round_trip_and_equal_arrays_share_a_hash(
    artifacts: ArtifactStore, session: Session
) -> None:
    arrays = {"frames": np.arange(12, dtype=np.float32).reshape(3, 4), "end": np.array([1.5])}
    digest = artifacts.put_arrays(arrays, session=session)
    assert artifacts.put_arrays({k: v.copy() for k, v in arrays.items()}, session=session) == digest
    loaded = artifacts.get_arrays(digest)
    assert set(loaded) == set(arrays)
    for name, array in arrays.items():
        assert loaded[name].dtype == array.dtype
        np.testing.assert_array_equal(loaded[name], array)
    assert set(artifacts.get_arrays(digest, ["end"])) == {"end"}
    assert artifacts.get_bytes(digest).startswith(MAGIC)
    assert session.get_one(Artifact, digest).media_type == ARRAYS_MEDIA_TYPE


def test_a_bundle_written_as_npz_still_loads(artifacts: ArtifactStore, session: Session) -> None:
    """Artifacts of the format before the codec: a zip of ``.npy`` members."""
    arrays = {"frames": np.arange(24, dtype=np.int8).reshape(2, 12), "end_state": np.ones((5, 6))}
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w", zipfile.ZIP_STORED) as archive:
        for name, array in arrays.items():
            with archive.open(f"{name}.npy", "w") as out:
                np.lib.format.write_array(out, array, allow_pickle=False)
    digest = artifacts.put_bytes(buffer.getvalue(), media_type="application/x-npz", session=session)
    loaded = artifacts.get_arrays(digest)
    assert set(loaded) == set(arrays)
    for name, array in arrays.items():
        assert loaded[name].dtype == array.dtype
        np.testing.assert_array_equal(loaded[name], array)
    assert set(artifacts.get_arrays(digest, ["end_state"])) == {"end_state"}


def test_missing_artifact_is_a_named_error(artifacts: ArtifactStore) -> None:
    with pytest.raises(ArtifactNotFound) as caught:
        artifacts.get_bytes("0" * 64)
    assert str(artifacts.root) not in str(caught.value)
    with pytest.raises(ArtifactNotFound):
        artifacts.get_arrays("0" * 64)


def test_object_arrays_are_refused(artifacts: ArtifactStore, session: Session) -> None:
    with pytest.raises(ValueError, match="pickle"):
        artifacts.put_arrays({"rows": np.array([{"a": 1}], dtype=object)}, session=session)


@pytest.mark.parametrize("flip", [0, 5, -1])
def test_a_flipped_bit_is_caught_on_read_and_the_file_moved_aside(
    artifacts: ArtifactStore, session: Session, flip: int, caplog: pytest.LogCaptureFixture
) -> None:
    """Read once, then rotted in place (size, inode and modification time kept): the next
    read still hashes it. The error names the digest, not the server's directories; the
    log names the file."""
    arrays = {"frames": np.arange(400, dtype=np.float32).reshape(20, 20)}
    digest = artifacts.put_arrays(arrays, session=session)
    assert artifacts.get_arrays(digest)["frames"].sum() == arrays["frames"].sum()
    path = artifacts.path_for(digest)
    data = flip_in_place(path, flip)
    with (
        caplog.at_level(logging.WARNING, logger="app.store.artifacts"),
        pytest.raises(ArtifactCorrupt, match="does not match its hash") as caught,
    ):
        artifacts.get_arrays(digest)
    assert str(artifacts.root) not in str(caught.value) and digest in str(caught.value)
    assert str(artifacts.corrupt_path(digest)) in caplog.text
    assert not path.exists() and artifacts.corrupt_path(digest).read_bytes() == data
    with pytest.raises(ArtifactCorrupt):  # a later read names the same cause
        ArtifactStore(artifacts.root).get_bytes(digest)
    # storing the true bytes again heals it
    assert artifacts.put_arrays(arrays, session=session) == digest
    np.testing.assert_array_equal(artifacts.get_arrays(digest)["frames"], arrays["frames"])


def test_a_store_that_wrote_a_file_another_moved_aside_writes_it_again(
    artifacts: ArtifactStore, session: Session
) -> None:
    """Two processes' stores: the one that wrote a strip still remembers it when the
    other's read moves the rotted file aside. Its own read of the file, gone, makes it
    forget, so its next put of the true bytes (a strip rendered again) heals the file."""
    digest = artifacts.put_bytes(b"a strip", media_type="video/x-ivf", session=session)
    flip_in_place(artifacts.path_for(digest), 2)
    with pytest.raises(ArtifactCorrupt):
        ArtifactStore(artifacts.root).get_bytes(digest)
    with pytest.raises(ArtifactCorrupt):
        artifacts.get_bytes(digest)
    assert artifacts.put_bytes(b"a strip", media_type="video/x-ivf", session=session) == digest
    assert artifacts.get_bytes(digest) == b"a strip"
