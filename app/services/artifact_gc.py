"""Collecting orphaned artifacts: the one service ``srg gc`` and beat's task both call.

See :mod:`app.store.artifact_gc` for what is collected and why the grace period
(``older_than``) keeps what a running step is about to reference.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

from app.config import Settings
from app.core.errors import InvalidInput
from app.db.sessions import transaction
from app.services.loading import artifact_store
from app.store.artifact_gc import (
    collect_orphaned_artifacts,
    remove_collected_files,
    scan_artifact_files,
)
from app.store.artifact_gc import count_fanout_directories as _count_fanout_directories


@dataclass(frozen=True)
class ArtifactGcResult:
    dry_run: bool
    older_than_s: float
    #: ``artifacts`` rows deleted (or, dry, that would be)
    rows: int
    #: files removed (or, dry, that would be)
    files: int
    bytes_freed: int


def count_fanout_directories(settings: Settings) -> int:
    """The directories a collection walks: the total of its progress bar."""
    return _count_fanout_directories(artifact_store(settings))


#: the longest grace period, in seconds (a century)
MAX_GRACE = 100 * 365.25 * 24 * 3600


def grace_seconds(settings: Settings, older_than: float | None) -> float:
    """The grace period a collection keeps: ``older_than``, else the configured one. At
    most a century: a cutoff further back than that leaves the calendar (and keeps every
    file anyway)."""
    grace = settings.runtime.artifact_gc_grace if older_than is None else older_than
    if not 0 <= grace < math.inf:
        raise InvalidInput(f"--older-than must be a finite number of seconds >= 0, not {grace}")
    if grace > MAX_GRACE:
        raise InvalidInput(
            f"--older-than must be at most {MAX_GRACE:.0f} s (a century), not {grace:g}"
        )
    return grace


def collect_artifacts(
    settings: Settings,
    *,
    older_than: float | None = None,
    dry_run: bool = False,
    progress: Callable[[int], None] | None = None,
) -> ArtifactGcResult:
    """Scan the store, delete the orphaned rows in one transaction, then their files.

    ``older_than`` defaults to ``settings.runtime.artifact_gc_grace``; ``progress(1)`` is called
    per fan-out directory scanned (:func:`~app.store.artifact_gc.count_fanout_directories`).
    """
    grace = grace_seconds(settings, older_than)
    scan = scan_artifact_files(artifact_store(settings), older_than=grace, progress=progress)
    with transaction(settings) as session:
        collection = collect_orphaned_artifacts(session, scan, dry_run=dry_run)
    remove_collected_files(collection)  # only once the rows' deletion is committed
    return ArtifactGcResult(
        dry_run=dry_run,
        older_than_s=grace,
        rows=collection.rows,
        files=collection.files_removed,
        bytes_freed=collection.bytes_freed,
    )
