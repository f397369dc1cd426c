"""A :class:`~app.core.graph.clipbank.ClipBank` backed by the artifact store.

Each saved clip has one arrays bundle: its frames, and its end state while its edge is
a blend. A blend edge's clip is expanded from its end state; once the edge is a
simulation, no step reads that state again (an edge never turns back into a blend), so
the store rewrites the bundle without it (docs/liquid.md, "Bytes"). The small feature
columns (control, energies, score) come from the loaded graph; the occupancy and the
descriptor are a function of the frames (``Dynamics.shape``), so they are derived from
the frames when read rather than stored (docs/liquid.md, "Bytes"). Both reads go through
LRU caches because best-target searches compare the same popular clips again and again.
The shape cache is bounded in bytes, not entries: an occupancy grid is 48 KB on ``tiny``
and about 1 MB on ``paper``, so a count bound would let a 200k-frame graph's worker hold
gigabytes.
Clips put since the last save stay in memory until :func:`app.store.graph_persistence.save_graph`
writes their bundles and calls :meth:`StoredClipBank.mark_saved`.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from functools import lru_cache
from typing import Protocol

import numpy as np

from app.core.graph.clipbank import ClipBank
from app.core.graph.dynamics import ClipFeatures, SimClip
from app.core.graph.state_graph import StateGraph
from app.store.artifacts import ArtifactStore

#: default budget of the shape (occupancy, descriptor) cache, and its least entries
SHAPE_CACHE_BYTES = 256 * 2**20
MIN_SHAPE_ENTRIES = 128
BUNDLE_CACHE_SIZE = 64


class ShapeCache(Protocol):
    """A shared cache of (occupancy, descriptor) by bundle digest (content-addressed)."""

    def get(self, digest: str) -> tuple[np.ndarray, np.ndarray] | None: ...

    def put(self, digest: str, occupancy: np.ndarray, descriptor: np.ndarray) -> None: ...


#: a clip's (occupancy, descriptor) from its frames: the dynamics' ``shape``
ShapeOf = Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]


class EndStateDropped(LookupError):
    """The clip ends a simulated edge: its end state is no longer kept."""


def clip_bundle(bank: ClipBank, clip: int, *, keep_state: bool) -> dict[str, np.ndarray]:
    """The arrays of a clip's bundle artifact, from any bank holding the clip; its end
    state only if ``keep_state`` (the clip's edge is a blend, still to be expanded)."""
    bundle = {"frames": np.asarray(bank.frames(clip))}
    if keep_state:
        bundle["end_state"] = np.asarray(bank.end_state(clip))
    return bundle


class StoredClipBank:
    def __init__(
        self,
        graph: StateGraph,
        artifacts: ArtifactStore,
        bundles: Mapping[int, str],
        shape_of: ShapeOf,
        shape_cache_bytes: int = SHAPE_CACHE_BYTES,
    ) -> None:
        self._graph = graph
        self._artifacts = artifacts
        self._shape_of = shape_of
        self._bundles = dict(bundles)
        self._pending: dict[int, tuple[SimClip, ClipFeatures]] = {}
        self._shape_cache: ShapeCache | None = None
        self._shape_cache_bytes = shape_cache_bytes
        self._shape_members: Callable[[int], tuple[np.ndarray, np.ndarray]] | None = None
        self._frames = lru_cache(maxsize=BUNDLE_CACHE_SIZE)(self._read_frames)

    def features(self, clip: int) -> ClipFeatures:
        if clip in self._pending:
            return self._pending[clip][1]
        occupancy, descriptor = self._shapes(clip)
        graph = self._graph
        return ClipFeatures(
            control=graph.clip_control[clip],
            kinetic=graph.clip_kinetic[clip],
            potential=graph.clip_potential[clip],
            occupancy=occupancy,
            descriptor=descriptor,
            score=graph.clip_score[clip],
        )

    def end_state(self, clip: int) -> np.ndarray:
        if clip in self._pending:
            return self._pending[clip][0].end_state
        digest = self._bundles[clip]
        try:  # read once per expansion, so not cached
            return self._artifacts.get_arrays(digest, ("end_state",))["end_state"]
        except KeyError:
            raise EndStateDropped(
                f"clip {clip} ends a simulated edge; its end state is no longer kept"
            ) from None

    def frames(self, clip: int) -> np.ndarray:
        if clip in self._pending:
            return self._pending[clip][0].frames
        return self._frames(clip)

    def put(self, clip: int, sim: SimClip, features: ClipFeatures) -> None:
        self._pending[clip] = (sim, features)

    def mark_saved(self, bundles: Mapping[int, str]) -> None:
        """Record that these clips' bundles are stored; their arrays leave memory."""
        for clip, digest in bundles.items():
            self._bundles[clip] = digest
            self._pending.pop(clip, None)

    def use_shape_cache(self, cache: ShapeCache) -> None:
        """Read occupancy grids through ``cache`` (Redis: the paper's animation cache)."""
        self._shape_cache = cache

    def _shapes(self, clip: int) -> tuple[np.ndarray, np.ndarray]:
        """Through the LRU cache, sized from the first grid read to fit the byte budget."""
        if self._shape_members is None:
            occupancy, descriptor = self._read_shape(clip)
            entries = self._shape_cache_bytes // max(occupancy.nbytes + descriptor.nbytes, 1)
            self._shape_members = lru_cache(maxsize=max(MIN_SHAPE_ENTRIES, entries))(
                self._read_shape
            )
        return self._shape_members(clip)

    def _read_shape(self, clip: int) -> tuple[np.ndarray, np.ndarray]:
        digest = self._bundles[clip]
        if self._shape_cache is not None and (hit := self._shape_cache.get(digest)) is not None:
            return hit
        occupancy, descriptor = self._shape_of(
            self._artifacts.get_arrays(digest, ("frames",))["frames"]
        )
        if self._shape_cache is not None:
            self._shape_cache.put(digest, occupancy, descriptor)
        return occupancy, descriptor

    def _read_frames(self, clip: int) -> np.ndarray:
        return self._artifacts.get_arrays(self._bundles[clip], ("frames",))["frames"]
