"""``LiquidDynamics``: the tilt-tank liquid as a :class:`~app.core.graph.dynamics.Dynamics`.

It composes the solver its scene names (``app.kernels.solvers``), the Zhu-Bridson SDF kernel
(``app.kernels.sdf``), the paper's metrics and blend (``app.core.liquid.liquid_metrics``) and
the Mitsuba renderer (``app.render``). A clip's ``frames`` are its SDFs quantised to
int8 (``app.core.liquid.surface.quantise_sdf``): the store keeps them as they are, and blends
return the same kind. Occupancy in the features is uint8 for the same reason. End states
are snapped onto the preset's particle lattice (``app.core.liquid.particle_lattice``) before a
clip is returned, so the state the store keeps is the state a continuation starts from.

The constants the paper measures (T0, w_e) and the defaults of the crowd radius and the
high-error threshold come from the preset's stored calibration
(``app/data/calibration/<preset>.json`` for the low-viscosity fluid,
``<preset>-<fluid>.json`` for another, written by ``app.liquid.calibration``).
"""

from __future__ import annotations

import functools
import hashlib
import json
from collections.abc import Sequence
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from app.core.errors import NotFound
from app.core.graph.dynamics import ClipFeatures, SimClip
from app.core.liquid.liquid_metrics import (
    LiquidMetricParams,
    blend_sdf,
    clip_distance,
    descriptor_distance,
)
from app.core.liquid.particle_lattice import ParticleLattice, particle_lattice, snap_state
from app.core.liquid.scene import Scene, kinetic_energy, potential_energies, tilt_tank
from app.core.liquid.solver import LiquidSolver
from app.core.liquid.surface import (
    SurfaceGrid,
    clip_descriptor,
    clip_score,
    dequantise_sdf,
    occupancy,
    quantise_occupancy,
    quantise_sdf,
    surface_grid,
)
from app.kernels.context import runtime
from app.kernels.sdf import SdfKernel
from app.kernels.solvers import make_solver
from app.liquid.devices import LiquidDevices
from app.render.mitsuba_scene import LiquidRenderer, RenderQuality, pick_variant

CALIBRATION_DIR = Path(__file__).resolve().parents[1] / "data" / "calibration"
#: the packages whose code makes a clip's bytes: the pure core, the kernels, this one
CLIP_CODE = ("core", "kernels", "liquid")


@functools.cache
def clip_code_digest() -> str:
    """sha256 of the sources that turn a start state into a clip (:data:`CLIP_CODE`).

    Part of a clip's simulation key (``simulation_identity``): a clip remembered by an
    earlier version of the code is simulated again, not reused.
    """
    app = Path(__file__).resolve().parents[1]
    digest = hashlib.sha256()
    for package in CLIP_CODE:
        for path in sorted((app / package).rglob("*")):
            if path.suffix in (".py", ".cl"):
                digest.update(str(path.relative_to(app)).encode() + b"\0" + path.read_bytes())
    return digest.hexdigest()


class MissingCalibration(NotFound):
    """The preset has no stored calibration: run ``srg calibrate --preset <preset>``."""


def calibration_path(preset: str, fluid: str = "low", directory: Path = CALIBRATION_DIR) -> Path:
    """Where the calibration of ``preset`` and ``fluid`` is stored (low: ``<preset>.json``)."""
    return directory / (f"{preset}.json" if fluid == "low" else f"{preset}-{fluid}.json")


@dataclass(frozen=True)
class LiquidCalibration:
    """Measured constants of a preset (see ``app.liquid.calibration``)."""

    rest_kinetic: float
    energy_weight: float
    crowd_radius: float
    high_error_threshold: float


def stepping(scene: Scene) -> dict[str, int]:
    """How a scene advances a frame: what a calibration's frames were simulated with."""
    return {"substeps": scene.substeps, "viscosity_steps": scene.viscosity_steps}


def _described(steps: dict[str, int] | None) -> str:
    if not steps:
        return "an unrecorded stepping"
    return f"{steps['substeps']} substeps a frame, {steps['viscosity_steps']} viscosity steps each"


def load_calibration(
    preset: str, fluid: str = "low", directory: Path = CALIBRATION_DIR
) -> LiquidCalibration:
    """The stored constants, if they were measured on frames made as the scene makes them
    now: by the same solver, stepped the same way.

    Constants measured on other frames (another solver, docs/sph.md "Solvers"; another
    stepping, "Viscosity in steps of its own") would blend and judge today's clips by
    yesterday's liquid, so such a file is refused like a missing one, with the command
    that measures it again.
    """
    path = calibration_path(preset, fluid, directory)
    option = "" if fluid == "low" else f" --fluid {fluid}"
    again = f"run srg calibrate --preset {preset}{option}"
    if not path.exists():
        raise MissingCalibration(f"no calibration for preset {preset!r}; {again}")
    data = json.loads(path.read_text())
    scene = tilt_tank(preset, fluid)
    if data.get("solver") != scene.solver:
        measured = data.get("solver") or "an unrecorded solver"
        raise MissingCalibration(
            f"the calibration of preset {preset!r} was measured with {measured}, "
            f"the scene now takes {scene.solver}; {again}"
        )
    now = stepping(scene)
    if data.get("stepping") != now:
        raise MissingCalibration(
            f"the calibration of preset {preset!r} was measured on "
            f"{_described(data.get('stepping'))}, the scene now takes {_described(now)}; "
            f"{again}"
        )
    return LiquidCalibration(**{k: float(data[k]) for k in LiquidCalibration.__annotations__})


def calibration_json(
    preset: str, calibration: LiquidCalibration, details: dict, fluid: str = "low"
) -> str:
    """The stored form: the four constants, the solver and stepping they were measured
    on, and how."""
    scene = tilt_tank(preset, fluid)
    head = {"preset": preset, "fluid": fluid, "solver": scene.solver, "stepping": stepping(scene)}
    return json.dumps({**head, **asdict(calibration), **details}, indent=2) + "\n"


class LiquidDynamics:
    """Liquid in the tilting tank, clips as SDF frames (paper section 5).

    Parameters
    ----------
    preset : str
        ``tiny``, ``small`` or ``paper`` (``app.core.liquid.scene.tilt_tank``).
    fluid : str
        ``low`` or ``high`` viscosity (``app.core.liquid.scene.FLUIDS``).
    calibration : LiquidCalibration, optional
        Defaults to the stored one of the preset and fluid.
    render_quality : RenderQuality, optional
        Image size and samples per pixel of :meth:`render`.
    devices : LiquidDevices, optional
        The OpenCL device and the Mitsuba variant; the shells pass the configured ones.
    """

    frames_per_clip: int
    n_controls: int
    fps: float

    def __init__(
        self,
        preset: str,
        fluid: str = "low",
        calibration: LiquidCalibration | None = None,
        render_quality: RenderQuality | None = None,
        devices: LiquidDevices | None = None,
    ) -> None:
        self.preset = preset
        self.fluid = fluid
        self.scene: Scene = tilt_tank(preset, fluid)
        self.grid: SurfaceGrid = surface_grid(self.scene)
        self.lattice: ParticleLattice = particle_lattice(self.scene.spacing)
        self.calibration = calibration or load_calibration(preset, fluid)
        self.frames_per_clip = self.scene.frames_per_clip
        self.n_controls = self.scene.n_controls
        self.fps = float(self.scene.fps)
        self.render_quality = render_quality or RenderQuality()
        self.devices = devices or LiquidDevices()
        self.params = LiquidMetricParams(
            rest_kinetic=self.rest_kinetic,
            energy_weight=self.calibration.energy_weight,
            voxel_volume=self.grid.voxel_volume,
        )
        self._solver: LiquidSolver | None = None
        self._sdf: SdfKernel | None = None
        self._renderer: LiquidRenderer | None = None
        #: the settled tank of each world seed asked for (None: the plain lattice's)
        self._rest: dict[int | None, np.ndarray] = {}
        self._identity: str | None = None

    # ---- Dynamics constants --------------------------------------------------------
    @property
    def name(self) -> str:
        return "liquid"

    @property
    def rest_kinetic(self) -> float:
        """T0: the scene's measured value when it has one, else the calibration's."""
        return self.scene.rest_kinetic or self.calibration.rest_kinetic

    @property
    def crowd_radius(self) -> float:
        return self.calibration.crowd_radius

    @property
    def high_error_threshold(self) -> float:
        return self.calibration.high_error_threshold

    @property
    def simulation_identity(self) -> str:
        """What a clip's bytes depend on besides its start state and control: the scene,
        the OpenCL device and the code (the kernels are bit-reproducible on one device,
        docs/runtime.md, "Each simulation once")."""
        if self._identity is None:
            device = runtime(self.devices.opencl_device).device
            parts = [repr(self.scene), device.name, device.platform.version, clip_code_digest()]
            self._identity = hashlib.sha256("\n".join(parts).encode()).hexdigest()
        return self._identity

    # ---- engines, built on first use -------------------------------------------------
    @property
    def batch(self) -> int:
        """The most clips one launch sequence runs: an expansion's (one per control), or
        the devices' ``simulate_batch`` where that is more."""
        return max(self.n_controls, self.devices.simulate_batch)

    @property
    def solver(self) -> LiquidSolver:
        """The solver the scene names, with room for :attr:`batch` clips at once."""
        if self._solver is None:
            self._solver = make_solver(self.scene, self.devices.opencl_device, self.batch)
        return self._solver

    @property
    def sdf_kernel(self) -> SdfKernel:
        if self._sdf is None:
            self._sdf = SdfKernel(self.grid, device=self.devices.opencl_device)
        return self._sdf

    @property
    def renderer(self) -> LiquidRenderer:
        if self._renderer is None:
            variant = pick_variant(self.devices.render_variant, self.devices.llvm_path)
            self._renderer = LiquidRenderer(self.scene, self.grid, self.render_quality, variant)
        return self._renderer

    # ---- Dynamics operations ---------------------------------------------------------
    def initial_state(self, world: int | None = None) -> np.ndarray:
        """The settled tank of a ``world`` seed's fluid block (None: the plain lattice's).

        Computed once per instance and world: a few seconds of simulation.
        """
        if world not in self._rest:
            self._rest[world] = self.solver.settle(world=world)
        return self._rest[world].copy()

    def surface_frames(self, positions: np.ndarray) -> np.ndarray:
        """int8 SDF frames (k, X, Y, Z) of (k, n, 3) particle positions."""
        return quantise_sdf(self.grid, self.sdf_kernel.frames(positions))

    def simulate_particles(
        self, states: Sequence[np.ndarray], controls: Sequence[int]
    ) -> list[tuple[np.ndarray, np.ndarray]]:
        """Per clip (a start state and a control), the (k, n, 3) particle
        positions of its frames and its end state.

        The clips run in batches of up to :attr:`batch`, each bit-identical to its run
        alone (docs/sph.md, "Clips in batches"). An end state is on the lattice, its
        particles in Morton order: the frames keep the particle order of their start
        state, clips simulated from the end state its own.
        """
        sim, k = self.solver, self.scene.frames_per_clip
        out = []
        for first in range(0, len(states), self.batch):
            chunk = slice(first, first + self.batch)
            positions, ends = sim.run_batch(states[chunk], controls[chunk], k)
            out += [(p, snap_state(e, self.lattice)) for p, e in zip(positions, ends, strict=True)]
        return out

    def simulate(self, state: np.ndarray, control: int) -> SimClip:
        (clip,) = self.simulate_many([state], [control])
        return clip

    def simulate_many(self, states: Sequence[np.ndarray], controls: Sequence[int]) -> list[SimClip]:
        simulated = self.simulate_particles(states, controls)
        return [
            SimClip(control=c, frames=self.surface_frames(positions), end_state=end_state)
            for (positions, end_state), c in zip(simulated, controls, strict=True)
        ]

    def features(self, clip: SimClip) -> ClipFeatures:
        occ = self._occupancy(clip.frames)
        shape, descriptor = self._shape(occ)
        return ClipFeatures(
            control=clip.control,
            kinetic=kinetic_energy(self.scene, clip.end_state),
            potential=potential_energies(self.scene, clip.end_state),
            occupancy=shape,
            descriptor=descriptor,
            score=clip_score(self.grid, self.scene.target, occ),
        )

    def shape(self, frames: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return self._shape(self._occupancy(frames))

    def _occupancy(self, frames: np.ndarray) -> np.ndarray:
        return occupancy(self.grid, dequantise_sdf(self.grid, frames))

    def _shape(self, occ: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return quantise_occupancy(occ), clip_descriptor(self.grid, self.scene.tank, occ)

    def dist(self, a: ClipFeatures, b: ClipFeatures, control: int) -> float:
        return clip_distance(a, b, control, self.params)

    def pdist(self, a: ClipFeatures, b: ClipFeatures) -> float:
        return descriptor_distance(a, b)

    def blend(self, src: np.ndarray, dst: np.ndarray) -> np.ndarray:
        """Eq. 8 on the SDFs, returned quantised like the clips' own frames."""
        g = self.grid
        return quantise_sdf(g, blend_sdf(dequantise_sdf(g, src), dequantise_sdf(g, dst)))

    def render(self, frames: np.ndarray) -> np.ndarray:
        return self.renderer.frames(dequantise_sdf(self.grid, frames))
