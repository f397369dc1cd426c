"""The seam between the liquid game and the method that moves its particles.

Growth, calibration and validation ask a solver for three things only: the settled tank, a
clip from a state under a control, and a batch of clips at once. Anything that does
these, bit-identically for one state, control and device, can make srg's clips; the scene
names the one that does (:attr:`~app.core.liquid.scene.Scene.solver`), so a clip's
simulation key and a preset's calibration say which solver made them (docs/sph.md,
"Solvers").
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Protocol

import numpy as np

from app.core.liquid.scene import Scene


class LiquidSolver(Protocol):
    """A particle solver of one scene on one device.

    A state is an (n, 6) float32 array, positions then velocities, in the scene's fixed
    particle order. Each clip starts from its state alone, so the same state, control and
    device give the same frames whether simulated alone or in a batch.
    """

    scene: Scene

    def settle(
        self,
        seconds: float = 3.0,
        damped_seconds: float = 1.5,
        damping: float = 0.02,
        world: int | None = None,
    ) -> np.ndarray:
        """The rest state of the scene's fluid block (jittered by a ``world`` seed)."""
        ...

    def simulate_clip(self, state: np.ndarray, control: int) -> tuple[np.ndarray, np.ndarray]:
        """One clip: positions (k, n, 3) at the end of each frame, and the end state."""
        ...

    def run_batch(
        self,
        states: Sequence[np.ndarray],
        controls: Sequence[int],
        frames: int,
        damping: float = 0.0,
    ) -> tuple[np.ndarray, np.ndarray]:
        """``frames`` frames of each (state, control): positions (clips, frames, n, 3) and
        end states (clips, n, 6)."""
        ...
