"""Where the bulky per-clip data lives while the graph algorithms need it.

The graph keeps only small columns; full distances need occupancy (features), expansions
need end states, blends need frames. A :class:`ClipBank` hands those out by clip index.
The in-memory bank serves experiments and tests; the store provides one backed by the
artifact files (and a Redis cache: the paper's animation cache).
"""

from __future__ import annotations

from typing import Protocol

import numpy as np

from app.core.graph.dynamics import ClipFeatures, SimClip


class ClipBank(Protocol):
    def features(self, clip: int) -> ClipFeatures: ...

    def end_state(self, clip: int) -> np.ndarray: ...

    def frames(self, clip: int) -> np.ndarray: ...

    def put(self, clip: int, sim: SimClip, features: ClipFeatures) -> None: ...


class MemoryClipBank:
    def __init__(self) -> None:
        self._features: dict[int, ClipFeatures] = {}
        self._sims: dict[int, SimClip] = {}

    def features(self, clip: int) -> ClipFeatures:
        return self._features[clip]

    def end_state(self, clip: int) -> np.ndarray:
        return self._sims[clip].end_state

    def frames(self, clip: int) -> np.ndarray:
        return self._sims[clip].frames

    def put(self, clip: int, sim: SimClip, features: ClipFeatures) -> None:
        self._features[clip] = features
        self._sims[clip] = sim
