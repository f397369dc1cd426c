"""Collecting orphaned artifacts: files and ``artifacts`` rows that nothing references.

An interrupted step (Ctrl-C mid-grow, a killed worker, a rolled-back transaction) leaves
artifact files whose row was never committed, and rows that no clip, edge, epoch or
checkpoint references. Collection runs in three calls so that nothing live is lost:

1. :func:`scan_artifact_files` walks the store outside any transaction and sorts the
   files into those last modified before the cutoff (``now - older_than``) and the rest;
2. :func:`collect_orphaned_artifacts`, in the caller's transaction, deletes the rows
   created before the cutoff that no column referencing ``artifacts.hash`` names and whose
   file is not recent (with ``DELETE``s that re-check the references) and lists the files
   to remove: those of the deleted rows and the old files that have no row;
3. after the caller commits, :func:`remove_collected_files` unlinks them, checking each
   file's modification time once more just before.

**The grace period** (``older_than``, an hour by default in ``srg gc``) is what protects a
running step: a step writes its files, registers their rows and only then references
them, possibly in a later transaction or, with Celery, in another task. Anything written
or registered within the grace period is kept, and :class:`ArtifactStore` touches an
existing file when a step stores the same content again, so an old orphan that a step is
about to reuse counts as fresh. Set it longer than any step or epoch takes.

The artifact directory must belong to one database: files referenced only by another
database sharing the directory would be collected.
"""

from __future__ import annotations

import os
import re
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from datetime import UTC, datetime, timedelta
from pathlib import Path

from sqlalchemy import Column, delete, select, union
from sqlalchemy.exc import IntegrityError
from sqlalchemy.orm import Session

from app.core.errors import Conflict
from app.models import Artifact, Base
from app.store.artifacts import ArtifactStore

#: rows deleted per statement: well under SQLite's bound-parameter limit
DELETE_BATCH = 500
_DIGEST = re.compile(r"[0-9a-f]{64}")
#: prefix of the store's temporary files (a write interrupted before its rename)
TEMPORARY_PREFIX = ".tmp-"


@dataclass(frozen=True)
class StaleFile:
    """A file of the store last modified before the cutoff."""

    path: Path
    #: the content hash, or None for an interrupted write's temporary file
    digest: str | None
    size: int


@dataclass(frozen=True)
class FileScan:
    cutoff: datetime
    stale: list[StaleFile]
    #: digests of the files modified since the cutoff: their rows are kept too
    recent: set[str]


@dataclass
class ArtifactCollection:
    """What one collection found, deleted (unless ``dry_run``) and has left to unlink."""

    dry_run: bool
    cutoff: datetime
    rows: int = 0
    #: files to unlink once the rows' deletion is committed
    files: list[StaleFile] = field(default_factory=list)
    files_removed: int = 0
    bytes_freed: int = 0


def artifact_references() -> list[Column[str]]:
    """Every column of every model with a foreign key to ``artifacts.hash``."""
    return [
        column
        for table in Base.metadata.sorted_tables
        for column in table.columns
        if any(fk.column.table.name == Artifact.__tablename__ for fk in column.foreign_keys)
    ]


def scan_artifact_files(
    store: ArtifactStore,
    *,
    older_than: float,
    now: datetime | None = None,
    progress: Callable[[int], None] | None = None,
) -> FileScan:
    """The store's files (``ab/cd/<sha256>`` and temporary files) older than the cutoff.

    ``progress(1)`` is called per fan-out directory walked (at most 65,536). Files whose
    names the store would not write are ignored, never collected.
    """
    cutoff = (now or datetime.now(UTC)) - timedelta(seconds=older_than)
    limit = cutoff.timestamp()
    stale: list[StaleFile] = []
    recent: set[str] = set()
    for directory in _fanout_directories(store.root):
        for entry in os.scandir(directory):
            name = entry.name
            is_digest = _DIGEST.fullmatch(name) is not None and name[:2] == directory.parent.name
            is_digest = is_digest and name[2:4] == directory.name
            if not (is_digest or name.startswith(TEMPORARY_PREFIX)) or not entry.is_file():
                continue
            stat = entry.stat()
            digest = name if is_digest else None
            if stat.st_mtime < limit:
                stale.append(StaleFile(Path(entry.path), digest, stat.st_size))
            elif digest is not None:
                recent.add(digest)
        if progress is not None:
            progress(1)
    return FileScan(cutoff=cutoff, stale=stale, recent=recent)


def count_fanout_directories(store: ArtifactStore) -> int:
    """How many ``ab/cd`` directories :func:`scan_artifact_files` walks (for a progress bar)."""
    return sum(1 for _ in _fanout_directories(store.root))


def collect_orphaned_artifacts(
    session: Session, scan: FileScan, *, dry_run: bool = False
) -> ArtifactCollection:
    """Delete the unreferenced rows older than ``scan.cutoff``; list the files to unlink.

    Never commits. Files go later (:func:`remove_collected_files`, after the commit): a
    file removed before the rows' deletion is committed would leave a row naming nothing
    if the commit failed. With ``dry_run`` nothing is deleted; the counts say what would be.
    """
    collection = ArtifactCollection(dry_run=dry_run, cutoff=scan.cutoff)
    referenced = union(
        *(select(column).where(column.is_not(None)) for column in artifact_references())
    )
    orphaned = (Artifact.created_at < scan.cutoff) & Artifact.hash.not_in(referenced)
    # a row whose file was written or touched since the cutoff may be about to be used
    digests = [
        digest
        for digest in session.scalars(select(Artifact.hash).where(orphaned))
        if digest not in scan.recent
    ]
    if dry_run:
        deleted = digests
    else:
        deleted = []
        for start in range(0, len(digests), DELETE_BATCH):
            batch = digests[start : start + DELETE_BATCH]
            statement = (
                delete(Artifact)
                .where(Artifact.hash.in_(batch), orphaned)  # re-checked as it deletes
                .returning(Artifact.hash)
            )
            try:
                deleted += session.scalars(statement).all()
            except IntegrityError:  # a step referenced one of them meanwhile (PostgreSQL)
                raise Conflict(
                    "an artifact came into use while collecting; collect again"
                ) from None
    collection.rows = len(deleted)
    # a row's file, and a file with no row at all (its step never committed)
    deleted_set = set(deleted)
    stale_digests = {file.digest for file in scan.stale if file.digest is not None}
    registered = _registered(session, stale_digests - deleted_set)
    collection.files = [
        file
        for file in scan.stale
        if file.digest is None or file.digest in deleted_set or file.digest not in registered
    ]
    if dry_run:
        collection.files_removed = len(collection.files)
        collection.bytes_freed = sum(file.size for file in collection.files)
    return collection


def remove_collected_files(
    collection: ArtifactCollection, *, progress: Callable[[int], None] | None = None
) -> ArtifactCollection:
    """Unlink the collection's files that are still older than its cutoff; count them."""
    if collection.dry_run:
        return collection
    limit = collection.cutoff.timestamp()
    for file in collection.files:
        try:
            # touched since the scan: a step stored this content again, keep it
            if file.path.stat().st_mtime < limit:
                file.path.unlink()
                collection.files_removed += 1
                collection.bytes_freed += file.size
        except FileNotFoundError:
            pass  # removed meanwhile by another collection
        if progress is not None:
            progress(1)
    return collection


def _registered(session: Session, digests: set[str]) -> set[str]:
    """Which of ``digests`` have a row."""
    found: set[str] = set()
    ordered = sorted(digests)
    for start in range(0, len(ordered), DELETE_BATCH):
        batch = ordered[start : start + DELETE_BATCH]
        found.update(session.scalars(select(Artifact.hash).where(Artifact.hash.in_(batch))))
    return found


def _fanout_directories(root: Path) -> Iterator[Path]:
    """The store's ``ab/cd`` directories, in order."""
    if not root.is_dir():
        return
    for first in sorted(os.scandir(root), key=lambda entry: entry.name):
        if len(first.name) != 2 or not first.is_dir():
            continue
        for second in sorted(os.scandir(first.path), key=lambda entry: entry.name):
            if len(second.name) == 2 and second.is_dir():
                yield Path(second.path)
