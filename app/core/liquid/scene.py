"""Liquid scenes: a box tank, a fluid block, gravity controls and a target region.

A scene is data (docs/design.md, "Vocabulary"): a frozen dataclass that round-trips through a JSON
dict, so a graph stores the scene it was grown with. Coordinates are metres with y up;
the viewing axis is z, so tilting the tank rotates gravity in the x-y plane.

A liquid **state** is one float32 array of shape (n, 6): columns 0-2 are positions and
3-5 velocities of the fluid particles, in a fixed particle order (particle i of a state
is particle i of every frame simulated from it).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field, replace
from typing import Any

import numpy as np

from app.core.errors import InvalidInput
from app.core.liquid.defaults import DEFAULT_FLUID

GRAVITY = 9.81
#: tilt of the controls about the viewing axis, degrees (index 0 = level)
TILT_DEGREES = (0.0, -30.0, 30.0)


@dataclass(frozen=True)
class Box:
    """Axis-aligned box ``[lo, hi]`` in metres."""

    lo: tuple[float, float, float]
    hi: tuple[float, float, float]

    def contains(self, points: np.ndarray) -> np.ndarray:
        """Boolean mask of the (m, 3) ``points`` inside the box (closed)."""
        lo, hi = np.asarray(self.lo), np.asarray(self.hi)
        return np.all((points >= lo) & (points <= hi), axis=1)


@dataclass(frozen=True)
class Scene:
    """A tank of liquid and the gravity controls a player switches between.

    Attributes
    ----------
    name : str
        Preset name, e.g. ``tilt-tank/small``.
    tank : Box
        Inner walls of the tank; the origin is its lower-left-back corner.
    fluid : Box
        The fluid block of the initial state (filled with a cubic lattice of spacing
        ``spacing``).
    gravity : tuple of (gx, gy, gz)
        One gravity vector per control.
    target : Box
        Region whose fluid volume is the clip score.
    spacing : float
        Particle spacing dx; the kernel support radius is ``2 * spacing``.
    substeps : int
        Fixed time steps per frame, chosen from the CFL condition by the preset.
    viscosity_steps : int
        Explicit viscosity steps per substep, at the substep's positions; the last is
        folded into the substep's non-pressure acceleration (docs/sph.md, "Viscosity in
        steps of its own").
    frames_per_clip, fps : int
        A clip is ``frames_per_clip`` frames at ``fps``.
    rest_density, viscosity : float
        Liquid parameters (kg/m^3, artificial kinematic viscosity m^2/s).
    wall_viscosity : float
        Kinematic viscosity (m^2/s) of the liquid against the walls (friction).
    eta : float
        PCISPH tolerance on the max relative density error.
    min_iterations, max_iterations : int
        Bounds on the PCISPH pressure iterations per substep.
    rest_kinetic : float
        T0, the residual kinetic energy (J) of the settled tank, measured by
        ``app.liquid.validation.measure_rest_kinetic`` and stored with the preset.
    solver : str
        The liquid solver that moves the particles (:mod:`app.core.liquid.solver`); part
        of the scene, so a clip's simulation key and a calibration name it.
    """

    name: str
    tank: Box
    fluid: Box
    gravity: tuple[tuple[float, float, float], ...]
    target: Box
    spacing: float
    substeps: int
    viscosity_steps: int = 1
    frames_per_clip: int = 10
    fps: int = 30
    rest_density: float = 1000.0
    viscosity: float = 1e-3
    wall_viscosity: float = 5e-4
    eta: float = 0.01
    min_iterations: int = 3
    max_iterations: int = 50
    rest_kinetic: float = 0.0
    solver: str = "pcisph"
    extra: dict[str, float] = field(default_factory=dict)

    @property
    def n_controls(self) -> int:
        return len(self.gravity)

    @property
    def support(self) -> float:
        """Kernel support radius h = 2 dx."""
        return 2.0 * self.spacing

    @property
    def particle_mass(self) -> float:
        return self.rest_density * self.spacing**3

    @property
    def dt(self) -> float:
        """Substep length in seconds."""
        return 1.0 / (self.fps * self.substeps)

    def to_dict(self) -> dict[str, Any]:
        """JSON-able dict (tuples become lists)."""
        return asdict(self)

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> Scene:
        """Inverse of :meth:`to_dict`."""
        d = dict(data)
        for key in ("tank", "fluid", "target"):
            d[key] = Box(lo=tuple(d[key]["lo"]), hi=tuple(d[key]["hi"]))
        d["gravity"] = tuple(tuple(float(x) for x in g) for g in d["gravity"])
        d["extra"] = dict(d.get("extra", {}))
        return cls(**d)


def tilted_gravity(degrees: float) -> tuple[float, float, float]:
    """Gravity rotated by ``degrees`` about z (positive = counter-clockwise seen from +z)."""
    a = math.radians(degrees)
    return (GRAVITY * math.sin(a), -GRAVITY * math.cos(a), 0.0)


def cfl_substeps(spacing: float, max_speed: float, fps: int, courant: float = 0.4) -> int:
    """Substeps per frame so that ``dt <= courant * dx / max_speed`` (CFL condition)."""
    return math.ceil(max_speed / (courant * spacing * fps))


#: dt <= VISCOUS_STEP dx^2 / nu keeps the explicit viscosity term well inside its
#: stability region (measured, see :func:`viscous_substeps`)
VISCOUS_STEP = 0.036


def viscous_substeps(spacing: float, viscosity: float, fps: int) -> int:
    """Explicit viscosity steps per frame so that each is ``<= VISCOUS_STEP * dx^2 / nu``
    long (a scene takes them inside its substeps: ``Scene.viscosity_steps``).

    The viscosity of ``app.core.liquid.pcisph`` is an explicit SPH Laplacian. Its largest
    eigenvalue on the settled lattice is about ``-14 nu / dx^2`` (power iteration on
    the NumPy twin, tiny and small presets alike), so an explicit step is stable for
    ``dt < 0.144 dx^2 / nu``; the pressure solve stayed converged up to half of that
    (dt |lambda| <= 0.5) and lost convergence at 0.7 when the viscous step was the whole
    substep, hence 0.036. In terms of the support h = 2 dx this is
    ``dt <= 0.009 h^2 / nu``: the usual ``0.125 h^2 / nu`` is stated for the smoothing
    length (about dx here), not the support.
    """
    return math.ceil(viscosity / (VISCOUS_STEP * spacing**2 * fps))


#: inner size of the tilt tank (m): x across, y up, z the viewing depth
TILT_TANK_SIZE = (0.6, 0.4, 0.16)


@dataclass(frozen=True)
class FluidProperties:
    """What differs between the liquids of the tilt tank.

    The viscosities are kinematic (m^2/s). The target is per fluid because a game needs a
    goal its liquid can reach: rocked, water splashes into the upper middle of the tank;
    a thick liquid never crosses the middle high up, it only runs up the lowered wall.
    """

    viscosity: float
    wall_viscosity: float
    target: Box


#: the two fluids of the paper's study (section 7): today's liquid and a thick one, ten
#: times as viscous, with the same wall-to-fluid viscosity ratio. The thick one's target
#: is the top 60 mm of the tank across its whole width, which the crest of its run-up
#: reaches when a tilt starts: goal-directed players then score on it about as much as
#: on water's (docs/liquid.md, "A goal for each fluid")
FLUIDS = {
    "low": FluidProperties(
        viscosity=1e-3,
        wall_viscosity=5e-4,
        target=Box((0.2, 0.25, 0.0), (0.4, 0.4, TILT_TANK_SIZE[2])),
    ),
    "high": FluidProperties(
        viscosity=1e-2,
        wall_viscosity=5e-3,
        target=Box((0.0, 0.34, 0.0), TILT_TANK_SIZE),
    ),
}


#: particle spacing of the tilt-tank presets (particle counts 1920, 8064, 43824)
TILT_TANK_SPACINGS = {"tiny": 0.02, "small": 0.0125, "paper": 0.0072}
#: height of the fluid block of the tilt tank (m)
FILL_HEIGHT = 0.175
#: T0 measured per preset (J): max kinetic energy over the last second of a 3 s settle
#: (`srg validate` re-measures it and reports the value)
TILT_TANK_REST_KINETIC = {"tiny": 0.0, "small": 0.0, "paper": 0.0}


def tilt_tank(preset: str, fluid: str = DEFAULT_FLUID) -> Scene:
    """The game's scene: a 0.6 x 0.4 x 0.16 m tank filled to 0.175 m, tilted by +/- 30 degrees.

    The fastest plausible flow is a free fall over the tank height, ``sqrt(2 g H)``,
    which fixes the substeps through the CFL condition for both fluids; where the
    explicit viscosity needs shorter steps (:func:`viscous_substeps`; only ``high``),
    it takes them inside each substep (``viscosity_steps``).
    ``fluid`` picks a row of :data:`FLUIDS` (viscosities and target); the scene of
    ``low`` is named ``tilt-tank/<preset>``, any other ``tilt-tank/<preset>-<fluid>``.
    """
    if preset not in TILT_TANK_SPACINGS:
        raise InvalidInput(f"unknown preset {preset!r}; one of {sorted(TILT_TANK_SPACINGS)}")
    if fluid not in FLUIDS:
        raise InvalidInput(f"unknown fluid {fluid!r}; one of {list(FLUIDS)}")
    liquid = FLUIDS[fluid]
    dx = TILT_TANK_SPACINGS[preset]
    size = TILT_TANK_SIZE
    counts = [math.floor(x / dx + 1e-6) for x in (size[0], FILL_HEIGHT, size[2])]
    fluid_hi = (counts[0] * dx, counts[1] * dx, counts[2] * dx)
    fps = 30
    substeps = cfl_substeps(dx, math.sqrt(2 * GRAVITY * size[1]), fps)
    return Scene(
        name=f"tilt-tank/{preset}" if fluid == DEFAULT_FLUID else f"tilt-tank/{preset}-{fluid}",
        tank=Box((0.0, 0.0, 0.0), size),
        fluid=Box((0.0, 0.0, 0.0), fluid_hi),
        gravity=tuple(tilted_gravity(a) for a in TILT_DEGREES),
        target=liquid.target,
        spacing=dx,
        substeps=substeps,
        viscosity_steps=math.ceil(viscous_substeps(dx, liquid.viscosity, fps) / substeps),
        fps=fps,
        viscosity=liquid.viscosity,
        wall_viscosity=liquid.wall_viscosity,
        rest_kinetic=TILT_TANK_REST_KINETIC[preset],
    )


def dam_break(column_width: float = 0.1, cells_per_width: int = 20, depth_cells: int = 10) -> Scene:
    """Martin and Moyce's (1952) collapsing column: width a, height 2a, in a long tank.

    Only control 0 (plain gravity) is used. The tank is 5a long, so the surge front
    (at 3a by T = 2.5) never reaches the far wall during the comparison.
    """
    a = column_width
    dx = a / cells_per_width
    depth = depth_cells * dx
    base = replace(
        tilt_tank("tiny"),
        name=f"dam-break/{cells_per_width}",
        tank=Box((0.0, 0.0, 0.0), (5 * a, 2.5 * a, depth)),
        fluid=Box((0.0, 0.0, 0.0), (a, 2 * a, depth)),
        gravity=((0.0, -GRAVITY, 0.0),),
        target=Box((0.0, 0.0, 0.0), (5 * a, 2.5 * a, depth)),
        spacing=dx,
        substeps=cfl_substeps(dx, math.sqrt(2 * GRAVITY * 2 * a), 30),
        rest_kinetic=0.0,
    )
    return replace(base, extra={"column_width": a})


#: how far a world seed moves each particle of the initial lattice, per axis, at most
#: (a fraction of the spacing: the block stays a block, its particles no closer than
#: 0.6 spacings, yet every world's settled tank differs)
WORLD_JITTER = 0.2


def initial_particles(scene: Scene, world: int | None = None) -> np.ndarray:
    """State (n, 6) float32 of the fluid block as a cubic lattice at rest.

    With a ``world`` seed every particle is displaced by an offset drawn uniformly from
    ``[-WORLD_JITTER, WORLD_JITTER]`` spacings per axis (``np.random.default_rng(world)``):
    the start of one world of an experiment (docs/experiment.md, "World seeds"). None is
    the plain lattice.
    """
    dx = scene.spacing
    lo, hi = np.asarray(scene.fluid.lo), np.asarray(scene.fluid.hi)
    counts = np.floor((hi - lo) / dx + 1e-6).astype(int)
    axes = [lo[i] + dx * (np.arange(counts[i]) + 0.5) for i in range(3)]
    z, y, x = np.meshgrid(axes[2], axes[1], axes[0], indexing="ij")
    positions = np.stack([x.ravel(), y.ravel(), z.ravel()], axis=1)
    if world is not None:
        rng = np.random.default_rng(world)
        positions = positions + rng.uniform(-WORLD_JITTER, WORLD_JITTER, positions.shape) * dx
    state = np.zeros((x.size, 6), dtype=np.float32)
    state[:, :3] = positions
    return state


def kinetic_energy(scene: Scene, state: np.ndarray) -> float:
    """T = sum m |v|^2 / 2 (J), accumulated in float64."""
    v = state[:, 3:6].astype(np.float64)
    return float(0.5 * scene.particle_mass * np.sum(v * v))


def potential_energies(scene: Scene, state: np.ndarray) -> np.ndarray:
    """V_c = -sum m g_c . (x - x_ref) for every control c (J).

    The reference x_ref is the tank's bottom centre for every control and every clip, so
    energies of different clips under the same control are comparable.
    """
    lo, hi = np.asarray(scene.tank.lo), np.asarray(scene.tank.hi)
    ref = np.array([(lo[0] + hi[0]) / 2, lo[1], (lo[2] + hi[2]) / 2])
    rel_sum = np.sum(state[:, 0:3].astype(np.float64) - ref, axis=0)
    g = np.asarray(scene.gravity, dtype=np.float64)
    return -scene.particle_mass * (g @ rel_sum)
