"""Collecting orphaned artifacts: what an interrupted grow left goes, everything used stays."""

from __future__ import annotations

import os
import time
from datetime import UTC, datetime, timedelta
from pathlib import Path

import numpy as np
import pytest
from sqlalchemy import select, update
from sqlalchemy.orm import Session

from app.bench.ingest import build_toy_graph
from app.core.graph.toy import ToyDynamics
from app.models import Artifact, Clip
from app.store.artifact_gc import (
    artifact_references,
    collect_orphaned_artifacts,
    remove_collected_files,
    scan_artifact_files,
)
from app.store.artifacts import ArtifactStore
from app.store.graph_persistence import load_graph

HOUR = 3600.0
TWO_HOURS_AGO = datetime.now(UTC) - timedelta(hours=2)


def age(session: Session, artifacts: ArtifactStore, digests: list[str]) -> None:
    """Back-date rows and files, as if written two hours ago."""
    session.execute(
        update(Artifact).where(Artifact.hash.in_(digests)).values(created_at=TWO_HOURS_AGO)
    )
    for digest in digests:
        age_file(artifacts.path_for(digest))


def age_file(path: Path) -> None:
    past = TWO_HOURS_AGO.timestamp()
    os.utime(path, (past, past))


def rows(session: Session) -> set[str]:
    return set(session.scalars(select(Artifact.hash)))


def interrupted_put(session: Session, artifacts: ArtifactStore, data: bytes) -> str:
    """A step that wrote its file and registered it, then rolled back (Ctrl-C mid-grow)."""
    savepoint = session.begin_nested()
    digest = artifacts.put_bytes(data, media_type="application/octet-stream", session=session)
    savepoint.rollback()
    return digest


def collect(
    session: Session, artifacts: ArtifactStore, *, dry_run: bool = False
) -> tuple[int, int, int]:
    scan = scan_artifact_files(artifacts, older_than=HOUR)
    collection = remove_collected_files(collect_orphaned_artifacts(session, scan, dry_run=dry_run))
    return collection.rows, collection.files_removed, collection.bytes_freed


def test_every_column_referencing_artifacts_is_checked() -> None:
    names = {f"{column.table.name}.{column.name}" for column in artifact_references()}
    assert names >= {
        "clips.bundle",
        "clips.animation",
        "edges.animation",
        "growth_epochs.warm_start",
        "expansion_clips.clip",
        "expansion_clips.animation",
        "publication_edges.animation",
        "experiment_checkpoints.arrays",
    }


def test_orphans_of_an_interrupted_grow_are_collected_and_nothing_used_is(
    session: Session, artifacts: ArtifactStore
) -> None:
    toy = build_toy_graph(session, artifacts, name="gc-toy", expansions=2)
    used = sorted(rows(session))
    assert used  # clip bundles
    age(session, artifacts, used)
    # orphans two hours old: a file whose row rolled back, a row nothing references,
    # a half-written temporary file
    no_row = interrupted_put(session, artifacts, b"rolled back")
    age_file(artifacts.path_for(no_row))
    unreferenced = artifacts.put_bytes(b"never referenced", media_type="x/y", session=session)
    age(session, artifacts, [unreferenced])
    temporary = artifacts.path_for(no_row).parent / ".tmp-interrupted"
    temporary.write_bytes(b"half")
    age_file(temporary)
    # fresh orphans: a running step may be about to reference them
    fresh_file = interrupted_put(session, artifacts, b"a running step's file")
    fresh_row = artifacts.put_bytes(b"a running step's row", media_type="x/y", session=session)
    # an old orphan that a running step has just stored again: touched, so kept
    reused = artifacts.put_bytes(b"stored again", media_type="x/y", session=session)
    age(session, artifacts, [reused])
    ArtifactStore(artifacts.root).put_bytes(b"stored again", media_type="x/y", session=session)
    stray = artifacts.root / "README"  # not a name the store writes: never touched
    stray.write_bytes(b"mine")
    age_file(stray)

    expected_bytes = len(b"rolled back") + len(b"never referenced") + len(b"half")
    before = rows(session)
    assert collect(session, artifacts, dry_run=True) == (1, 3, expected_bytes)
    assert rows(session) == before and temporary.exists()
    assert artifacts.path_for(no_row).exists() and artifacts.path_for(unreferenced).exists()

    assert collect(session, artifacts) == (1, 3, expected_bytes)
    assert rows(session) == before - {unreferenced}
    for gone in (no_row, unreferenced):
        assert not artifacts.path_for(gone).exists()
    assert not temporary.exists()
    for kept in (*used, fresh_file, fresh_row, reused):
        assert artifacts.path_for(kept).exists()
    assert stray.exists()
    graph, bank = load_graph(
        session, toy.graph_id, artifacts, ToyDynamics().shape
    )  # every bundle still there
    assert graph.n_vertices == toy.graph.n_vertices
    clip = session.scalars(select(Clip.bundle).limit(1)).one()
    assert np.asarray(list(artifacts.get_arrays(clip).values())[0]).size > 0
    assert collect(session, artifacts) == (0, 0, 0)  # nothing left to collect


def test_with_no_grace_period_fresh_orphans_go_too(
    session: Session, artifacts: ArtifactStore
) -> None:
    orphan = interrupted_put(session, artifacts, b"orphan")
    time.sleep(0.01)
    scan = scan_artifact_files(artifacts, older_than=0)
    collection = remove_collected_files(collect_orphaned_artifacts(session, scan))
    assert collection.files_removed == 1 and not artifacts.path_for(orphan).exists()


@pytest.mark.parametrize("dry_run", [True, False])
def test_an_empty_or_missing_store_collects_nothing(
    session: Session, tmp_path: Path, dry_run: bool
) -> None:
    store = ArtifactStore(tmp_path / "nowhere")
    scan = scan_artifact_files(store, older_than=HOUR)
    collection = collect_orphaned_artifacts(session, scan, dry_run=dry_run)
    assert (collection.rows, collection.files_removed, collection.bytes_freed) == (0, 0, 0)
