"""PCISPH of a liquid scene on an OpenCL device: srg's liquid solver
(``app.core.liquid.solver.LiquidSolver``; docs/sph.md, "Solvers").

The API other layers use::

    sim = PcisphSolver(tilt_tank("small"), batch=3)
    rest = sim.settle()                                # (n, 6) float32 state at rest
    frames, end = sim.simulate_clip(rest, control=1)   # (k, n, 3) positions, (n, 6)
    frames, ends = sim.run_batch([rest] * 3, [0, 1, 2], 10)  # (3, 10, n, 3), (3, n, 6)

A state is ``app.core.liquid.scene``'s (n, 6) float32 array (positions, velocities) in a fixed
particle order. Each clip starts from the state alone (pressures from zero), so the same
state, control and device always give bit-identical frames, alone or in a batch.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np
import pyopencl as cl

from app.core.liquid.scene import Scene, initial_particles
from app.kernels.pcisph_kernels import PcisphKernels


class PressureSolveError(RuntimeError):
    """Raised when a neighbour list overflowed (the liquid is far too compressed)."""


@dataclass
class SolverStats:
    """Counters of the pressure solve since the simulator was made (for benchmarks)."""

    substeps: int = 0
    iterations: int = 0
    max_error: float = 0.0
    unconverged_substeps: int = 0
    iteration_counts: list[int] = field(default_factory=list)

    @property
    def mean_iterations(self) -> float:
        return self.iterations / max(self.substeps, 1)


#: iterations a queued substep gets beyond the most the last frame's substeps needed
BUDGET_SLACK = 4

Gravity = tuple[float, float, float]


def iterations_used(errors: np.ndarray, lo: int, eta: float) -> list[int] | None:
    """Pressure iterations of each substep of a frame queued at once, or None when one
    did not converge within its budget.

    ``errors`` holds per substep (row) each queued iteration's max compression. The
    loop stops after the first iteration from the ``lo``-th on whose error is below
    ``eta``; the iterations after it were no-ops and left a zero.
    """
    below = errors[:, lo - 1 :] < eta
    if not np.all(below.any(axis=1)):
        return None
    return [lo + int(i) for i in np.argmax(below, axis=1)]


class PcisphSolver:
    """PCISPH of one scene (tank, fluid block, gravity controls) on one device.

    Parameters
    ----------
    scene : Scene
        Tank, fluid, spacing, substeps, tolerances (see ``app.core.liquid.scene``).
    fixed_iterations : int or None
        If given, every substep runs exactly this many pressure iterations instead of
        iterating to ``scene.eta`` (benchmarks at equal iteration counts).
    device : str
        Substring of the OpenCL device's name; ``''`` prefers PoCL's CPU device
        (:func:`app.kernels.context.select_device`).
    profile : bool
        Timestamp every kernel launch (``PcisphKernels.launches``; ``srg bench sph --profile``).
    queue_frames : bool
        Queue each frame's substeps at once (:meth:`frame`). The frames are the same;
        off by default, since it was slower on every device measured, a GPU's included
        (docs/sph.md, "A frame queued at once").
    batch : int
        Most clips simulated together (:meth:`run_batch`): one launch sequence runs them
        all, each as it runs alone (docs/sph.md, "Clips in batches").
    """

    #: what a scene's ``solver`` says to have its clips made by this class
    name: ClassVar[str] = "pcisph"

    def __init__(
        self,
        scene: Scene,
        fixed_iterations: int | None = None,
        device: str = "",
        profile: bool = False,
        queue_frames: bool = False,
        batch: int = 1,
    ) -> None:
        self.scene = scene
        self.n = len(initial_particles(scene))
        self.kernels = PcisphKernels(scene, self.n, device=device, profile=profile, batch=batch)
        self.fixed_iterations = fixed_iterations
        self.queue_frames = queue_frames
        self.stats = SolverStats()
        self._errors = np.zeros((max(scene.max_iterations, 1), batch), dtype=np.float32)
        #: pressure iterations queued per substep of a frame queued at once (:meth:`frame`)
        self.budget = max(scene.min_iterations, 1) + BUDGET_SLACK
        self._pending_reads: list[cl.Event] = []

    def substep(self, gravities: Sequence[Gravity], damping: float = 0.0) -> list[int]:
        """Advance the loaded clips by dt, each under its gravity; returns each clip's
        pressure iterations.

        The careful way: the host reads each iteration's errors before it queues more.
        """
        k = self.kernels
        self._forces(gravities, damping)
        k.reset_errors(self.scene.max_iterations)
        if self.fixed_iterations:
            it = self.fixed_iterations
            for m in range(it):
                k.density_pressure(m)
                k.pressure_predict(damping, m)
            counts, errors = [it] * k.batch, k.density_errors(it)[-1].tolist()
        else:
            counts, errors = self._converge(damping)
        k.advance()
        for it, err in zip(counts, errors, strict=True):
            self._count(it, err)
        return counts

    def frame(self, gravities: Sequence[Gravity], damping: float = 0.0) -> None:
        """Advance the loaded clips by one frame (``scene.substeps`` substeps).

        With ``queue_frames`` every substep is queued at once with ``budget`` pressure
        iterations, those past convergence being no-ops on the device, and the host
        reads the errors once, at the end (docs/sph.md, "A frame queued at once").
        Where a substep of a clip did not converge within its budget, the frame is put
        back and run the careful way (:meth:`substep`), so the frames are the careful
        way's either way.
        """
        k, s = self.kernels, self.scene
        lo, hi = max(s.min_iterations, 1), s.max_iterations
        budget = min(max(self.budget, lo), hi)
        if self.fixed_iterations or not self.queue_frames or lo > hi:
            for _ in range(s.substeps):
                self.substep(gravities, damping)
            return
        k.keep_state()
        k.reset_errors(s.substeps * budget)
        for j in range(s.substeps):
            self._forces(gravities, damping)
            first = j * budget
            for m in range(first, first + budget):
                k.density_pressure(m, check_from=first + lo)
                k.pressure_predict(damping, m, check_from=first + lo)
            k.advance()
        # (substep, iteration, clip) -> per clip, (substep, iteration)
        errors = k.density_errors(s.substeps * budget).reshape(s.substeps, budget, k.batch)
        used = [iterations_used(errors[:, :, c], lo, s.eta) for c in range(k.batch)]
        per_clip = [counts for counts in used if counts is not None]
        if len(per_clip) < k.batch:
            k.restore_state()
            per_substep = [self.substep(gravities, damping) for _ in range(s.substeps)]
            most = max(max(counts) for counts in per_substep)
        else:
            for j in range(s.substeps):
                for c, counts in enumerate(per_clip):
                    self._count(counts[j], float(errors[j, counts[j] - 1, c]))
            most = max(max(counts) for counts in per_clip)
        self.budget = most + BUDGET_SLACK

    def _forces(self, gravities: Sequence[Gravity], damping: float) -> None:
        """A substep up to its pressure loop: sort, neighbours, viscosity, first x*, v*."""
        k, s = self.kernels, self.scene
        k.sort()
        k.find_neighbours()
        for _ in range(s.viscosity_steps - 1):
            k.diffuse_velocity()
        k.nonpressure_accel(gravities)
        k.pressure_predict(damping)

    def _count(self, iterations: int, err: float) -> None:
        st = self.stats
        st.substeps += 1
        st.iterations += iterations
        st.iteration_counts.append(iterations)
        st.max_error = max(st.max_error, err)
        st.unconverged_substeps += int(err >= self.scene.eta)

    def _converge(self, damping: float) -> tuple[list[int], list[float]]:
        """Pressure iterations until each clip's max compression is below eta: per clip,
        (count, error).

        The host tests each iteration's errors while the next one is already queued (so
        the device never waits for the host); an iteration queued after a clip's
        convergence is a no-op for it on the device, so each clip's result is that of
        testing after every iteration, alone.
        """
        k, s = self.kernels, self.scene
        # the first test follows the first iteration at the earliest, as in a plain loop
        lo, hi = max(s.min_iterations, 1), s.max_iterations
        errors = self._errors[:, : k.batch]
        reads: dict[int, cl.Event] = {}
        for m in range(hi):
            k.density_pressure(m, check_from=lo)
            k.pressure_predict(damping, m, check_from=lo)
            if m + 1 >= lo:
                reads[m] = k.enqueue_density_error(m, errors[m])
            if m >= lo:  # iteration m is queued: test m - 1
                reads.pop(m - 1).wait()
                if np.all(errors[m - 1] < s.eta):
                    break
        else:
            m = hi
            last = reads.pop(hi - 1, None)
            if last is None:  # max_iterations < min_iterations: never tested, as before
                return [hi] * k.batch, [0.0] * k.batch
            last.wait()
        # the read of a no-op iteration may still be pending: keep its host array and
        # event alive without waiting (pyopencl waits when such an event is freed)
        self._pending_reads = list(reads.values())
        # each clip stopped at its first iteration from the lo-th on below eta
        below = errors[lo - 1 : m] < s.eta
        counts = [lo + int(np.argmax(b)) if b.any() else m for b in below.T]
        return counts, [float(errors[it - 1, c]) for c, it in enumerate(counts)]

    def run(
        self,
        state: np.ndarray,
        control: int,
        frames: int,
        damping: float = 0.0,
    ) -> tuple[np.ndarray, np.ndarray]:
        """Simulate ``frames`` frames from ``state``; positions per frame and end state."""
        positions, ends = self.run_batch([state], [control], frames, damping)
        return positions[0], ends[0]

    def run_batch(
        self,
        states: Sequence[np.ndarray],
        controls: Sequence[int],
        frames: int,
        damping: float = 0.0,
    ) -> tuple[np.ndarray, np.ndarray]:
        """Simulate ``frames`` frames of each clip (a start state and a control) in one
        launch sequence: positions (clips, frames, n, 3) and end states (clips, n, 6),
        each clip's bit-identical to its :meth:`run`."""
        if len(states) != len(controls):
            raise ValueError(f"{len(states)} states for {len(controls)} controls")
        k, b = self.kernels, len(states)
        k.load(np.ascontiguousarray(np.stack(states), dtype=np.float32))
        gravities = [self.scene.gravity[c] for c in controls]
        out = np.empty((frames, b * self.n, 4), dtype=np.float32)
        events = []
        for f in range(frames):
            self.frame(gravities, damping)
            events.append(k.enqueue_unsorted(k.pos, out[f]))
        end_pos = np.empty((b * self.n, 4), dtype=np.float32)
        end_vel = np.empty((b * self.n, 4), dtype=np.float32)
        k.enqueue_unsorted(k.pos, end_pos).wait()
        k.enqueue_unsorted(k.vel, end_vel).wait()
        for e in events:
            e.wait()
        overflow = k.overflowed()
        if overflow:
            raise PressureSolveError(f"a neighbour list overflowed ({overflow} neighbours)")
        end = np.concatenate([end_pos[:, :3], end_vel[:, :3]], axis=1).reshape(b, self.n, 6)
        positions = out[:, :, :3].reshape(frames, b, self.n, 3).transpose(1, 0, 2, 3)
        return np.ascontiguousarray(positions), end

    def particle_fields(self) -> dict[str, np.ndarray]:
        """Positions (n, 3), pressures and densities (n,) of the last substep.

        Rows are in the solver's cell-sorted order (not the state's order): for
        statistics over particles, such as the validation's pressure profile.
        """
        k = self.kernels
        return {
            "position": k.read(k.pos, np.float32, 4)[:, :3],
            "pressure": k.read(k.p, np.float32),
            "density": k.read(k.rho, np.float32),
        }

    def simulate_clip(self, state: np.ndarray, control: int) -> tuple[np.ndarray, np.ndarray]:
        """One clip of ``scene.frames_per_clip`` frames under ``control``.

        Returns
        -------
        frames : (k, n, 3) float32
            Particle positions at the end of each frame.
        end_state : (n, 6) float32
            State after the last frame.
        """
        return self.run(state, control, self.scene.frames_per_clip)

    def settle(
        self,
        seconds: float = 3.0,
        damped_seconds: float = 1.5,
        damping: float = 0.02,
        world: int | None = None,
    ) -> np.ndarray:
        """The rest state: the fluid block released from a lattice under control 0.

        The first ``damped_seconds`` remove a fraction ``damping`` of the velocity per
        substep (so the lattice relaxes without sloshing), the rest runs undamped so the
        result is a genuine rest state of the undamped solver. A ``world`` seed jitters
        the lattice first (``app.core.liquid.scene.initial_particles``); None settles the plain one.
        """
        fps = self.scene.fps
        state = initial_particles(self.scene, world)
        damped = round(damped_seconds * fps)
        _, state = self.run(state, 0, damped, damping)
        _, state = self.run(state, 0, max(round(seconds * fps) - damped, 0))
        return state
