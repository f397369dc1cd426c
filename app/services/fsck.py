"""``srg fsck``: is every stored byte what the database says it is, and can what is not be
recomputed?

The scan hashes every registered artifact (:meth:`ArtifactStore.get_bytes` moves a file
that fails aside), lists rows without files and, on SQLite, runs the file's own
``PRAGMA integrity_check``. A repair recomputes what is a function of stored state
(docs/runtime.md, "Artifacts verified on read"):

- a clip's bundle or an expansion's recorded clip: simulated again from the state it
  started from, which is its predecessor's end state when still kept, else recomputed
  back along the chain of clips to the start vertex; stored only when the recomputed
  bytes hash to the digest the database holds, which proves them;
- an animation strip a clip or an edge of a graph shows: rendered again from its clip's
  frames (a BLEND edge's: from eq. 8's blend), after the clips, whose bundles it reads;
  stored only when the new bytes hash to its digest. Rendering is deterministic on one
  machine; where it is not, the strip is left aside and the next publish gives the graph
  a new one (:func:`~app.services.animations.forget_unreadable_strips`), while the
  publications before it, frozen, keep showing the old digest;
- a STATERANK warm start: forgotten (it only speeds up the next ranking).

Anything else (a strip only older publications show, a checkpoint's arrays, a trace) is
reported, not guessed.
"""

from __future__ import annotations

import hashlib
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field

import numpy as np
from sqlalchemy.orm import Session

from app.config import Settings
from app.core.graph.dynamics import Dynamics
from app.core.graph.graph_entry import GraphEntry
from app.db.sessions import database_sessions, transaction
from app.render.animation import STRIP_MEDIA_TYPE
from app.services.animations import rendered_again
from app.services.clips import ClipJob, finish_clip, planned_clip, simulate_job
from app.services.loading import artifact_store, graph_dynamics
from app.store.animations import animation_media_type
from app.store.array_codec import ARRAYS_MEDIA_TYPE, encode_arrays
from app.store.artifacts import ArtifactCorrupt, ArtifactNotFound, ArtifactStore
from app.store.fsck import (
    artifact_rows,
    clip_start,
    clip_with_bundle,
    count_artifacts,
    drop_warm_starts,
    expansion_clip_with,
    sqlite_integrity,
)
from app.store.graph_catalogue import clip_bundle_digest, graph_entry


@dataclass
class FsckResult:
    #: ``PRAGMA integrity_check``'s lines on SQLite (``["ok"]``), else why not run
    database: list[str]
    artifacts: int = 0
    verified: int = 0
    #: digests whose bytes did not match (their files are now under ``corrupt/``)
    corrupt: list[str] = field(default_factory=list)
    #: digests registered without a file
    missing: list[str] = field(default_factory=list)
    repaired: list[str] = field(default_factory=list)
    #: digest -> why it was not repaired
    unrepaired: dict[str, str] = field(default_factory=dict)

    @property
    def sound(self) -> bool:
        """Whether nothing found is left unrepaired."""
        broken = set(self.corrupt) | set(self.missing)
        return self.database == ["ok"] and broken <= set(self.repaired)


def count_to_scan(settings: Settings) -> int:
    """Artifacts :func:`fsck` hashes (for a progress bar)."""
    with database_sessions(settings)() as session:
        return count_artifacts(session)


def fsck(
    settings: Settings, *, repair: bool = False, progress: Callable[[int], None] | None = None
) -> FsckResult:
    """Check the database and every artifact; with ``repair``, recompute what can be.

    ``progress(1)`` is called per artifact hashed. Reads run outside any write
    transaction, so growth and play go on while it scans.
    """
    store = artifact_store(settings)
    with database_sessions(settings)() as session:
        result = FsckResult(database=_database_check(session))
        for digest, _ in artifact_rows(session):
            result.artifacts += 1
            try:
                store.get_bytes(digest)
                result.verified += 1
            except ArtifactCorrupt:
                result.corrupt.append(digest)
            except ArtifactNotFound:
                result.missing.append(digest)
            if progress is not None:
                progress(1)
    if repair:
        broken = [*result.corrupt, *result.missing]
        strips = _strips(settings, broken)
        # clips first: a strip is rendered from its clips' bundles
        for digest in sorted(broken, key=lambda digest: digest in strips):
            repair_one = _repair_strip if digest in strips else _repair
            why = repair_one(settings, store, digest)
            if why is None:
                result.repaired.append(digest)
            else:
                result.unrepaired[digest] = why
    return result


def _database_check(session: Session) -> list[str]:
    if session.get_bind().dialect.name != "sqlite":
        return ["ok"]  # PostgreSQL checksums its own pages; nothing cheap to ask here
    return sqlite_integrity(session)


def _strips(settings: Settings, digests: list[str]) -> set[str]:
    """Which of ``digests`` are animation strips."""
    with database_sessions(settings)() as session:
        return {digest for digest in digests if animation_media_type(session, digest)}


def _repair_strip(settings: Settings, store: ArtifactStore, digest: str) -> str | None:
    """Render the strip ``digest`` again and store it; None when done, else why not."""
    with database_sessions(settings)() as session:
        try:
            data = rendered_again(session, settings, store, digest)
        except (ArtifactCorrupt, ArtifactNotFound) as exc:
            return f"its clip is unreadable, so it cannot be rendered again: {exc}"
    if data is None:
        return "not recomputable (a strip only older publications show)"
    if hashlib.sha256(data).hexdigest() != digest:
        return (
            "rendered again from its clip, but the bytes differ from its hash: left aside "
            "(the next publish gives the graph a new strip)"
        )
    with transaction(settings) as session:
        store.put_bytes(data, media_type=STRIP_MEDIA_TYPE, session=session)
    return None


def _repair(settings: Settings, store: ArtifactStore, digest: str) -> str | None:
    """Recompute and store ``digest``; None when done, else why not."""
    arrays = _recomputed(settings, store, digest)
    if arrays is None:
        with transaction(settings) as session:
            if drop_warm_starts(session, digest):
                return None
        return "not recomputable (a checkpoint's arrays or a trace)"
    for data in _encodings(arrays):
        if hashlib.sha256(data).hexdigest() == digest:
            with transaction(settings) as session:
                store.put_bytes(data, media_type=ARRAYS_MEDIA_TYPE, session=session)
            return None
    return "recomputed, but the clip's bytes differ from its hash: left aside"


def _recomputed(
    settings: Settings, store: ArtifactStore, digest: str
) -> dict[str, np.ndarray] | None:
    """The arrays of the clip stored as ``digest``, simulated again; None if no clip is."""
    with database_sessions(settings)() as session:
        if (clip := clip_with_bundle(session, digest)) is not None:
            graph_id, idx = clip
            entry = graph_entry(session, graph_id)
            before, control = clip_start(session, graph_id, idx)
        elif (recorded := expansion_clip_with(session, digest)) is not None:
            epoch_id, position, control = recorded
            entry, before = planned_clip(session, epoch_id, position)
        else:
            return None
        return _recompute(session, store, graph_dynamics(entry, settings), entry, before, control)


def _recompute(
    session: Session,
    store: ArtifactStore,
    dynamics: Dynamics,
    entry: GraphEntry,
    before: int | None,
    control: int,
) -> dict[str, np.ndarray]:
    """The clip playing ``control`` from the end state of clip ``before`` (None: the
    start state of the graph's world), walking back along the clips whose end states
    are no longer kept."""
    graph_id = entry.id
    controls = [control]
    state: np.ndarray | None = None
    while before is not None and state is None:
        digest = clip_bundle_digest(session, graph_id, before)
        try:
            if digest is None:
                raise ArtifactNotFound(f"graph {graph_id} has no clip {before}")
            state = store.get_arrays(digest, ("end_state",))["end_state"]
        except (KeyError, ArtifactNotFound, ArtifactCorrupt):
            before, played = clip_start(session, graph_id, before)
            controls.append(played)
    if state is None:
        state = dynamics.initial_state(entry.world)
    for played in reversed(controls):
        stage = simulate_job(ClipJob(dynamics, state, played))
        arrays = finish_clip(dynamics, stage) or stage
        state = arrays["end_state"]
    return arrays


def _encodings(arrays: dict[str, np.ndarray]) -> Iterator[bytes]:
    """The byte forms a recomputed clip is stored in: an expansion's whole record, a
    graph bundle with its end state (a blend edge's) and without it."""
    yield encode_arrays(arrays)
    yield encode_arrays({"frames": arrays["frames"], "end_state": arrays["end_state"]})
    yield encode_arrays({"frames": arrays["frames"]})
