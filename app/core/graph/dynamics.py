"""The ``Dynamics`` protocol: the one thing the graph core knows about a game.

A dynamics simulates clips of ``frames_per_clip`` frames from a state under one of
``n_controls`` controls, summarises a clip into :class:`ClipFeatures` (what the graph
compares), and blends and renders frames. The graph core never looks inside states or
frames; it only passes them back to the dynamics that made them.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np


@dataclass(frozen=True)
class SimClip:
    """A simulated clip: ``frames`` (k, ...) to show and the ``end_state`` to go on from."""

    control: int
    frames: np.ndarray
    end_state: np.ndarray


@dataclass(frozen=True)
class ClipFeatures:
    """What the graph needs to compare clips without their frames or states.

    ``potential[c]`` is the potential energy of the end state under control ``c``'s
    gravity, so the energy of the end state as seen by control ``c`` is
    ``kinetic + potential[c]`` (the paper's E(v, c)).
    """

    control: int
    kinetic: float
    potential: np.ndarray
    occupancy: np.ndarray
    descriptor: np.ndarray
    score: float

    def energy(self, control: int) -> float:
        return float(self.kinetic + self.potential[control])


@runtime_checkable
class Dynamics(Protocol):
    """A pluggable system to precompute into a state graph (docs/design.md, "Vocabulary")."""

    @property
    def name(self) -> str: ...

    @property
    def n_controls(self) -> int: ...

    @property
    def frames_per_clip(self) -> int: ...

    @property
    def fps(self) -> float:
        """Frames per second the clips play at (the client's clock)."""
        ...

    @property
    def rest_kinetic(self) -> float:
        """Kinetic energy below which the system is visually at rest (T0)."""
        ...

    @property
    def crowd_radius(self) -> float:
        """Default kernel radius of the crowd player model in descriptor space."""
        ...

    @property
    def high_error_threshold(self) -> float:
        """Default error above which a step counts as high-error (Fig. 6)."""
        ...

    def initial_state(self, world: int | None = None) -> np.ndarray:
        """The start state of a world seed (docs/experiment.md, "World seeds").

        None is the dynamics' one canonical start (what calibrations and graphs made
        before world seeds use); an int a seeded variation of it, the same on every call
        on one device, another for every other seed.
        """
        ...

    def simulate(self, state: np.ndarray, control: int) -> SimClip: ...

    def simulate_many(self, states: Sequence[np.ndarray], controls: Sequence[int]) -> list[SimClip]:
        """The clips of several (state, control) pairs, each exactly the one
        :meth:`simulate` gives: a dynamics may run them together (the liquid runs an
        expansion's clips in one batch, docs/sph.md "Clips in batches")."""
        ...

    def features(self, clip: SimClip) -> ClipFeatures: ...

    def shape(self, frames: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The (occupancy, descriptor) of :meth:`features`, from a clip's frames alone.

        They are a function of the frames, so the store keeps only frames and end state
        and derives these when it reads a clip (docs/liquid.md, "Bytes").
        """
        ...

    def dist(self, a: ClipFeatures, b: ClipFeatures, control: int) -> float:
        """Perceptual error of showing clip ``a`` blended into clip ``b`` (eq. 3)."""
        ...

    def pdist(self, a: ClipFeatures, b: ClipFeatures) -> float:
        """Cheap distance of the player model (eq. 7): L2 between descriptors."""
        ...

    def blend(self, src: np.ndarray, dst: np.ndarray) -> np.ndarray:
        """Frames that start as ``src`` and end as ``dst`` (eq. 8)."""
        ...

    def render(self, frames: np.ndarray) -> np.ndarray:
        """RGB images (k, H, W, 3) uint8 of the frames; encoding is the shell's job."""
        ...
