"""A cheap sloshing tank: the toy dynamics for studying the algorithms without a liquid.

A 1D shallow-water height field in a tank that the player tilts (N = 3 gravity
directions, like the liquid). Heights ``h`` live at cell centres, velocities ``u`` at the
interior faces (walls have ``u = 0``); a symplectic-Euler step with an upwinded mass flux
conserves the water exactly and keeps heights positive. The state is ``[h, u]``: a
continuous space of dimension ``2M - 1``, far larger than what goal-directed players
visit, who must rock the tank in rhythm to lift water into a target window in the upper
middle.

Its metrics mirror the liquid's (paper eq. 3-8) on the height field: the shape term is
the exact area of the symmetric difference of two water profiles, the energy term has
``c_gain >> c_loss`` around ``T0`` and the ``norm_e`` normalisation, the descriptor is a
6 x 6 occupancy grid averaged over the clip, and blends combine the two profiles and
their union (``max`` of heights).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from app.core.graph.dynamics import ClipFeatures, SimClip


@dataclass(frozen=True)
class ToyDynamics:
    name: str = "toy"
    n_controls: int = 3
    frames_per_clip: int = 10
    cells: int = 16
    length: float = 1.0
    depth: float = 0.3
    tank_height: float = 1.0
    gravity: float = 9.81
    tilt_degrees: float = 20.0
    fps: float = 30.0
    substeps: int = 3
    damping: float = 0.3
    target_cells: tuple[int, int] = (6, 10)
    target_height: float = 0.42
    rest_kinetic: float = 1e-4
    c_gain: float = 10.0
    c_loss: float = 1.0
    energy_weight: float = 1.0
    #: eq. 2's kernel radius in descriptor space. The crowd visits new vertices mostly
    #: (sr-crowd grows where it plays), whose nearest visited neighbour lies ~0.3 away:
    #: at 0.15 two thirds of the predicted play fell outside every kernel; 0.5 reaches
    #: all but a few per cent (measured with `srg experiment --quick`, 6 seeds)
    crowd_radius: float = 0.5
    high_error_threshold: float = 0.5
    blend_overlap: float = 0.1
    #: a world seed's largest change of a start height, as a fraction of the depth
    world_perturbation: float = 0.1

    # ---- physics -----------------------------------------------------------------
    @property
    def dx(self) -> float:
        return self.length / self.cells

    @property
    def x(self) -> np.ndarray:
        return (np.arange(self.cells) + 0.5) * self.dx - 0.5 * self.length

    def gravity_components(self, control: int) -> tuple[float, float]:
        """(along the tank, into the bottom) components of gravity under a control."""
        angle = np.radians((0.0, -self.tilt_degrees, self.tilt_degrees)[control])
        return self.gravity * float(np.sin(angle)), self.gravity * float(np.cos(angle))

    def initial_state(self, world: int | None = None) -> np.ndarray:
        """Still water of ``depth``; a ``world`` seed adds to each height a uniform draw
        of amplitude ``world_perturbation`` x depth, less the draws' mean, so that the
        tank holds the same water."""
        heights = np.full(self.cells, self.depth)
        if world is not None:
            bumps = np.random.default_rng(world).uniform(-1.0, 1.0, self.cells)
            heights += self.world_perturbation * self.depth * (bumps - bumps.mean())
        return np.concatenate([heights, np.zeros(self.cells - 1)])

    def simulate_many(self, states: Sequence[np.ndarray], controls: Sequence[int]) -> list[SimClip]:
        """One clip after another: a toy clip costs microseconds."""
        return [self.simulate(s, c) for s, c in zip(states, controls, strict=True)]

    def simulate(self, state: np.ndarray, control: int) -> SimClip:
        h = state[: self.cells].copy()
        u = state[self.cells :].copy()
        g_x, g_z = self.gravity_components(control)
        dt = 1.0 / (self.fps * self.substeps)
        courant = dt / self.dx
        decay = float(np.exp(-self.damping * dt))
        # |u| dt/dx <= 0.45 keeps every height positive: no cell drains in one step
        u_max = 0.45 / courant
        frames = np.empty((self.frames_per_clip, self.cells))
        for f in range(self.frames_per_clip):
            for _ in range(self.substeps):
                u += dt * g_x - (g_z * courant) * (h[1:] - h[:-1])
                u *= decay
                np.clip(u, -u_max, u_max, out=u)
                flux = courant * u * np.where(u > 0, h[:-1], h[1:])
                h[:-1] -= flux
                h[1:] += flux
            frames[f] = h
        return SimClip(control=control, frames=frames, end_state=np.concatenate([h, u]))

    def kinetic_energy(self, state: np.ndarray) -> float:
        h, u = state[: self.cells], state[self.cells :]
        h_face = 0.5 * (h[:-1] + h[1:])
        return float(0.5 * np.sum(h_face * u * u) * self.dx)

    def potential_energy(self, heights: np.ndarray, control: int) -> float:
        """Potential energy of the water columns under a control's gravity, from the tank floor
        centre: columns of mass h dx with centroid (x, h/2) in tank coordinates."""
        g_x, g_z = self.gravity_components(control)
        return float(np.sum(heights * self.dx * (g_z * heights / 2 - g_x * self.x)))

    # ---- features ----------------------------------------------------------------
    def occupancy(self, frames: np.ndarray) -> np.ndarray:
        return frames.copy()

    def descriptor(self, frames: np.ndarray) -> np.ndarray:
        """6 x 6 occupancy grid (columns x height bands) averaged over the clip."""
        columns = (
            frames.reshape(len(frames), 6, -1).mean(axis=2)
            if self.cells % 6 == 0
            else (
                np.stack(
                    [
                        np.interp(np.linspace(0, self.cells - 1, 6), np.arange(self.cells), f)
                        for f in frames
                    ]
                )
            )
        )
        bands = np.linspace(0.0, self.tank_height, 7)
        fill = np.clip((columns[:, :, None] - bands[None, None, :-1]) / np.diff(bands), 0.0, 1.0)
        return fill.mean(axis=0).ravel()

    def shape(self, frames: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return self.occupancy(frames), self.descriptor(frames)

    def score(self, frames: np.ndarray) -> float:
        lo, hi = self.target_cells
        return float(np.sum(np.maximum(frames[:, lo:hi] - self.target_height, 0.0)) * self.dx)

    def features(self, clip: SimClip) -> ClipFeatures:
        heights = clip.end_state[: self.cells]
        occupancy, descriptor = self.shape(clip.frames)
        return ClipFeatures(
            control=clip.control,
            kinetic=self.kinetic_energy(clip.end_state),
            potential=np.array([self.potential_energy(heights, c) for c in range(self.n_controls)]),
            occupancy=occupancy,
            descriptor=descriptor,
            score=self.score(clip.frames),
        )

    # ---- metrics (eq. 3-7 on the height field) -------------------------------------
    def shape_distance(self, a: ClipFeatures, b: ClipFeatures) -> float:
        return float(np.sum(np.abs(a.occupancy - b.occupancy)) * self.dx)

    def energy_distance(self, a: ClipFeatures, b: ClipFeatures, control: int) -> float:
        """Blending ``a`` into a more energetic ``b`` creates energy: that costs ``c_gain``."""
        gain = b.energy(control) - a.energy(control)
        return (self.c_gain if gain > self.rest_kinetic else self.c_loss) * abs(gain)

    def energy_normalisation(self, a: ClipFeatures, b: ClipFeatures) -> float:
        mean_kinetic = 0.5 * (a.kinetic + b.kinetic)
        if mean_kinetic < self.rest_kinetic and a.control == b.control:
            return 0.0
        return 1.0 / np.sqrt(mean_kinetic + self.rest_kinetic)

    def dist(self, a: ClipFeatures, b: ClipFeatures, control: int) -> float:
        norm = self.energy_normalisation(a, b)
        if norm == 0.0:
            return 0.0
        shape = self.shape_distance(a, b)
        return float(norm * (shape + self.energy_weight * self.energy_distance(a, b, control)))

    def pdist(self, a: ClipFeatures, b: ClipFeatures) -> float:
        return float(np.linalg.norm(a.descriptor - b.descriptor))

    # ---- blend and render --------------------------------------------------------------
    def blend(self, src: np.ndarray, dst: np.ndarray) -> np.ndarray:
        """Eq. 8 on water heights: the union of two profiles is their pointwise max."""
        t = np.linspace(0.0, 1.0, len(src))[:, None]
        ell = self.blend_overlap
        w_s = np.clip((1 + ell - 2 * t) / (1 + ell), 0.0, 1.0)
        w_d = np.clip((2 * t + ell - 1) / (1 + ell), 0.0, 1.0)
        return w_s * src + w_d * dst + (1 - w_s - w_d) * np.maximum(src, dst)

    def render(self, frames: np.ndarray) -> np.ndarray:
        """Small RGB images: sky, water columns and the target window outlined."""
        height, scale = 48, 4
        width = self.cells * scale
        images = np.empty((len(frames), height, width, 3), dtype=np.uint8)
        rows = (np.arange(height)[::-1, None] + 0.5) / height * self.tank_height
        lo, hi = self.target_cells
        target = np.zeros((height, width), dtype=bool)
        row_top = int(height * (1 - self.target_height / self.tank_height))
        target[: row_top + 1, lo * scale] = target[: row_top + 1, hi * scale - 1] = True
        target[row_top, lo * scale : hi * scale] = True
        for f, heights in enumerate(frames):
            water = rows < np.repeat(heights, scale)[None, :]
            img = np.where(water[..., None], (40, 110, 200), (235, 240, 245)).astype(np.uint8)
            img[target] = (220, 60, 40)
            images[f] = img
        return images
