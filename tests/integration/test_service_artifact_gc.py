"""Collecting orphaned artifacts as ``srg gc`` and beat call it (app.services.artifact_gc):
the grace period in force, a dry run that removes nothing, a collection committed before
its files go, and a refused grace period that touches nothing.

tests/integration/test_artifact_gc.py holds the store's rules (what is an orphan, what a
running step keeps); here the service runs them on a database it commits to.
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterator
from dataclasses import dataclass
from datetime import UTC, datetime, timedelta
from functools import partial
from pathlib import Path

import pytest
from service_settings import BACKENDS, committed_settings
from sqlalchemy import select, union, update

from app.config import Settings
from app.core.errors import InvalidInput
from app.db.sessions import database_sessions, transaction
from app.models import Artifact
from app.services.artifact_gc import (
    ArtifactGcResult,
    collect_artifacts,
    count_fanout_directories,
    grace_seconds,
)
from app.services.creation import init_graph
from app.services.growing import grow_graph
from app.services.loading import ArtifactDirectoryError, artifact_store, open_graph
from app.store.artifact_gc import artifact_references

HOUR = 3600.0
TWO_HOURS_AGO = datetime.now(UTC) - timedelta(hours=2)


@pytest.fixture(params=BACKENDS)
def settings(request: pytest.FixtureRequest, tmp_path: Path) -> Iterator[Settings]:
    yield from committed_settings(request.param, tmp_path)


@dataclass(frozen=True)
class Planted:
    """A grown graph beside what an interrupted step leaves, all two hours old."""

    #: rows nothing references (the graph's own forgotten bundles among them)
    orphan_rows: set[str]
    #: the row of a step that never referenced what it stored
    unreferenced: str
    #: a file whose row was rolled back
    orphan_file: Path
    #: an interrupted write's temporary file
    temporary: Path
    #: the files of the rows something references
    used: set[Path]
    vertices: int

    @property
    def files(self) -> int:
        return len(self.orphan_rows) + 2


def rows(settings: Settings) -> set[str]:
    with transaction(settings) as session:
        return set(session.scalars(select(Artifact.hash)))


def referenced(settings: Settings) -> set[str]:
    columns = [select(column).where(column.is_not(None)) for column in artifact_references()]
    with transaction(settings) as session:
        return set(session.scalars(union(*columns)))


def files(settings: Settings) -> set[Path]:
    return {path for path in settings.resolved_artifact_dir.rglob("*") if path.is_file()}


def back_date(settings: Settings) -> None:
    """Every row and file of the store as if written two hours ago."""
    with transaction(settings) as session:
        session.execute(update(Artifact).values(created_at=TWO_HOURS_AGO))
    past = TWO_HOURS_AGO.timestamp()
    for path in files(settings):
        os.utime(path, (past, past))


@pytest.fixture
def planted(settings: Settings) -> Planted:
    store = artifact_store(settings)
    with transaction(settings) as session:
        init_graph(session, settings, name="tank")
    grow_graph(partial(transaction, settings), settings, name="tank", expansions=2)
    with transaction(settings) as session:
        unreferenced = store.put_bytes(b"never referenced", media_type="x/y", session=session)
    with database_sessions(settings)() as session:  # a step interrupted before its commit
        rolled_back = store.put_bytes(b"rolled back", media_type="x/y", session=session)
        session.rollback()
    temporary = store.path_for(rolled_back).parent / ".tmp-interrupted"
    temporary.write_bytes(b"half")
    back_date(settings)
    used = referenced(settings)
    with transaction(settings) as session:
        vertices = open_graph(session, settings, "tank").graph.n_vertices
    return Planted(
        orphan_rows=rows(settings) - used,
        unreferenced=unreferenced,
        orphan_file=store.path_for(rolled_back),
        temporary=temporary,
        used={store.path_for(digest) for digest in used},
        vertices=vertices,
    )


def test_a_dry_run_counts_what_a_collection_removes_and_removes_nothing(
    settings: Settings, planted: Planted
) -> None:
    before_rows, before_files = rows(settings), files(settings)
    assert planted.unreferenced in planted.orphan_rows
    dry = collect_artifacts(settings, dry_run=True)
    assert dry.dry_run and dry.older_than_s == settings.runtime.artifact_gc_grace == HOUR
    assert (dry.rows, dry.files) == (len(planted.orphan_rows), planted.files)
    assert dry.bytes_freed > 0
    assert (rows(settings), files(settings)) == (before_rows, before_files)

    done = collect_artifacts(settings)
    assert not done.dry_run
    assert (done.rows, done.files, done.bytes_freed) == (dry.rows, dry.files, dry.bytes_freed)
    assert rows(settings) == before_rows - planted.orphan_rows  # committed: a new session sees it
    assert files(settings) == planted.used
    with transaction(settings) as session:  # every used bundle still there
        assert open_graph(session, settings, "tank").graph.n_vertices == planted.vertices
    again = collect_artifacts(settings)
    assert (again.rows, again.files, again.bytes_freed) == (0, 0, 0)


def test_the_configured_grace_period_keeps_younger_orphans(
    settings: Settings, planted: Planted
) -> None:
    patient = settings.replace(artifact_gc_grace=3 * HOUR)
    kept = collect_artifacts(patient)
    assert kept == ArtifactGcResult(False, 3 * HOUR, rows=0, files=0, bytes_freed=0)
    assert planted.orphan_file.exists() and planted.temporary.exists()
    told = collect_artifacts(patient, older_than=HOUR)  # the option overrides the setting
    assert (told.older_than_s, told.rows, told.files) == (
        HOUR,
        len(planted.orphan_rows),
        planted.files,
    )
    assert not planted.orphan_file.exists() and not planted.temporary.exists()


def test_progress_follows_every_fanout_directory(settings: Settings, planted: Planted) -> None:
    directories = count_fanout_directories(settings)
    assert directories == len({path.parent for path in files(settings)}) > 0
    calls: list[int] = []
    collect_artifacts(settings, dry_run=True, progress=calls.append)
    assert calls == [1] * directories


@pytest.mark.parametrize("older_than", [-1.0, math.inf, math.nan])
def test_a_grace_period_that_is_no_number_of_seconds_is_refused_and_nothing_goes(
    settings: Settings, planted: Planted, older_than: float
) -> None:
    before_rows, before_files = rows(settings), files(settings)
    with pytest.raises(InvalidInput) as refused:
        collect_artifacts(settings, older_than=older_than)
    assert str(refused.value) == (
        f"--older-than must be a finite number of seconds >= 0, not {older_than}"
    )
    assert (rows(settings), files(settings)) == (before_rows, before_files)


def test_a_grace_period_past_the_calendar_is_refused_or_keeps_everything(
    settings: Settings, planted: Planted
) -> None:
    before_rows, before_files = rows(settings), files(settings)
    try:
        result = collect_artifacts(settings, older_than=1e12)
    except InvalidInput as refused:
        assert "--older-than" in str(refused)
    else:
        assert (result.rows, result.files, result.bytes_freed) == (0, 0, 0)
    assert (rows(settings), files(settings)) == (before_rows, before_files)


def test_the_grace_period_is_the_one_given_else_the_configured_one(settings: Settings) -> None:
    assert grace_seconds(settings, None) == settings.runtime.artifact_gc_grace
    assert grace_seconds(settings.replace(artifact_gc_grace=5.0), None) == 5.0
    assert grace_seconds(settings, 0) == 0  # no grace at all is a grace period
    assert grace_seconds(settings.replace(artifact_gc_grace=5.0), 7.5) == 7.5


def test_an_empty_store_has_nothing_to_walk_or_collect(settings: Settings) -> None:
    assert count_fanout_directories(settings) == 0
    result = collect_artifacts(settings)
    assert (result.rows, result.files, result.bytes_freed) == (0, 0, 0)
    assert not settings.resolved_artifact_dir.exists()  # a collection makes no directory


def test_a_file_in_the_way_of_the_store_is_refused(settings: Settings, tmp_path: Path) -> None:
    blocker = tmp_path / "a-file"
    blocker.write_bytes(b"mine")
    blocked = settings.replace(artifact_dir=blocker / "artifacts")
    with pytest.raises(ArtifactDirectoryError, match="is not a directory"):
        count_fanout_directories(blocked)
    with pytest.raises(ArtifactDirectoryError, match="is not a directory"):
        collect_artifacts(blocked)
    assert blocker.read_bytes() == b"mine"
