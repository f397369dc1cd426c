"""``srg bench clip``: seconds per clip of each stage of a liquid edge, and its bytes.

The clips run from a briefly settled tank under a tilt (a splash: the surface is at its
most complex), then the opposite tilt, so meshing and rendering see a typical hard case;
the rendered clip's near-black pixels are reported as ``srg bench look`` reports a graph's
(per-frame share, percentiles; and the count inside the water's silhouette).
Bytes are those of what an edge keeps, per frame and by kind: its clip bundle in the
artifacts' format (``app.store.array_codec``: the end state on the particle lattice, kept
for the vertex it reaches, and the int8 SDF frames; the occupancy and descriptor are
derived from the frames when read, so they cost no stored bytes) and its animation strip
as the render layer encodes it. The poster is made
from the strip when it is served, so it is reported apart and not counted as stored.

Each stage is timed in wall seconds and in the CPU seconds of this process (every thread
of it: PoCL's and Dr.Jit's included), so ``per_expansion`` can say what a simulated clip
costs a growing graph in CPU time, renders included, and the frames that buys per
CPU-hour: the figure to compare across thread counts (``POCL_MAX_PTHREAD_COUNT``) and
machines, where wall seconds depend on how many cores a stage kept busy.

For the large presets a whole measurement takes long: ``settle`` shortens the settling
and ``frames`` simulates only that many frames of each clip; the simulation's seconds
are then scaled to a clip of k frames, and the other stages run on a full clip made of
the simulated frames repeated (their cost is per frame). A preset without a stored
calibration is timed with placeholder constants (they change no timing).
"""

from __future__ import annotations

import hashlib
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TypeVar

import numpy as np

from app.core.graph.dynamics import ClipFeatures, SimClip
from app.core.liquid.particle_lattice import snap_state
from app.core.liquid.silhouette import silhouette_projector, silhouettes, tank_camera
from app.core.liquid.surface import dequantise_sdf
from app.kernels.pcisph import PcisphSolver
from app.liquid.adapter import LiquidCalibration, LiquidDynamics, MissingCalibration
from app.liquid.devices import LiquidDevices
from app.render.animation import encode_poster, encode_strip
from app.render.look import dark_fractions, dark_inside, fraction_percentiles
from app.store.array_codec import decode_arrays, encode_arrays, member_sizes

#: constants for timing a preset that has no calibration yet: no stage's cost depends on them
PLACEHOLDER_CALIBRATION = LiquidCalibration(
    rest_kinetic=0.05, energy_weight=1.0, crowd_radius=1.0, high_error_threshold=1.0
)

T = TypeVar("T")


@dataclass(frozen=True)
class Spent:
    """Wall and CPU seconds of one stage (CPU: this process, all its threads)."""

    wall: float
    cpu: float

    def scaled(self, factor: float) -> Spent:
        return Spent(self.wall * factor, self.cpu * factor)


def _spent(fn: Callable[[], T]) -> tuple[T, Spent]:
    wall, cpu = time.perf_counter(), time.process_time()
    result = fn()
    return result, Spent(time.perf_counter() - wall, time.process_time() - cpu)


#: stages an expanded clip passes once, and the ones it passes twice: its own strip and
#: the strip of the blend edge that ends in it (docs/runtime.md, "Clip cost at the paper
#: preset")
ONCE = ("simulate", "sdf", "features", "dist", "blend")
TWICE = ("render", "encode")


def per_expansion(stages: dict[str, Spent], frames_per_clip: int) -> dict[str, float]:
    """What one simulated clip costs a growing graph, renders included, and the simulated
    frames that buys per CPU-hour."""
    wall = sum(stages[s].wall for s in ONCE) + 2 * sum(stages[s].wall for s in TWICE)
    cpu = sum(stages[s].cpu for s in ONCE) + 2 * sum(stages[s].cpu for s in TWICE)
    return {
        "wall_seconds_per_clip": wall,
        "cpu_seconds_per_clip": cpu,
        "busy_cores": cpu / wall if wall > 0 else 0.0,
        "frames_per_cpu_hour": frames_per_clip * 3600.0 / cpu if cpu > 0 else 0.0,
    }


def _dynamics(preset: str, fluid: str, devices: LiquidDevices) -> tuple[LiquidDynamics, str]:
    try:
        return LiquidDynamics(preset, fluid, devices=devices), "stored"
    except MissingCalibration:
        dyn = LiquidDynamics(preset, fluid, PLACEHOLDER_CALIBRATION, devices=devices)
        return dyn, "placeholder"


def _median_seconds(fn: Callable[[], object], repeats: int = 21) -> float:
    times = [_spent(fn)[1].wall for _ in range(repeats)]
    return float(np.median(times))


def _writer_seconds(
    dyn: LiquidDynamics, a: ClipFeatures, b: ClipFeatures, bundle: dict[str, np.ndarray]
) -> dict[str, float]:
    """What one new clip costs the integrating step (the graph's single writer), medians.

    ``dist``: one comparison of a best-target search (it makes up to prefilter_k + 1 per
    new clip); ``occupancy_read``: a search's feature-cache miss, reading a stored
    bundle's frames and deriving the occupancy and descriptor; ``bundle_write``:
    encoding, hashing and writing the clip's bundle as ``save_graph`` does;
    ``clip_read``: reading it back whole, as the step reads the recorded clip.
    """

    def write(path: Path) -> None:
        data = encode_arrays(bundle)
        hashlib.sha256(data).hexdigest()
        path.write_bytes(data)

    def read(path: Path, names: tuple[str, ...]) -> int:
        return sum(array.nbytes for array in decode_arrays(path.read_bytes(), names).values())

    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "bundle"
        write(path)
        return {
            "dist": _median_seconds(lambda: dyn.dist(a, b, 2)),
            "occupancy_read": _median_seconds(
                lambda: dyn.shape(decode_arrays(path.read_bytes(), ("frames",))["frames"])
            ),
            "bundle_write": _median_seconds(lambda: write(path), 5),
            "clip_read": _median_seconds(lambda: read(path, tuple(bundle)), 5),
        }


def _iterations(sim: PcisphSolver) -> tuple[int, int]:
    """Pressure iterations and substeps the simulator has run so far."""
    return sim.stats.iterations, sim.stats.substeps


def _full_clip(frames: np.ndarray, k: int) -> np.ndarray:
    """``frames`` repeated along the first axis to ``k`` frames."""
    return frames[np.arange(k) % len(frames)]


def bench_clip(
    preset: str,
    fluid: str,
    *,
    devices: LiquidDevices,
    settle: float = 1.0,
    frames: int | None = None,
) -> dict:
    """Time simulate (SPH), SDF, features, blend and render of one clip; size its data.

    Parameters
    ----------
    devices : LiquidDevices
        The OpenCL device and the Mitsuba variant timed.
    settle : float
        Seconds of settling before the clips, the first half damped.
    frames : int, optional
        Simulate this many frames per clip (default: all k) and scale to k.

    Returns
    -------
    dict
        ``seconds`` (wall) and ``cpu_seconds`` per clip by stage, ``per_expansion`` (a
        simulated clip's cost to growth and its frames per CPU-hour),
        ``bytes_per_frame`` by stored kind and in total,
        ``served_bytes_per_frame`` (made when served, not stored), and the sizes that
        explain them (particles, voxels, image size).
    """
    dyn, calibration = _dynamics(preset, fluid, devices)
    sim = dyn.solver
    assert isinstance(sim, PcisphSolver), "the pressure iterations timed are PCISPH's"
    k = dyn.frames_per_clip
    n = min(frames or k, k)
    state = sim.settle(seconds=settle, damped_seconds=settle / 2)
    sim.run(state, 0, 1)  # warm up kernels and buffers
    iterations_before, substeps_before = _iterations(sim)
    (positions, end), sph = _spent(lambda: sim.run(state, 1, n))
    end = snap_state(end, dyn.lattice)  # as the liquid returns it: the stored state
    iterations, substeps = _iterations(sim)
    mean_iterations = (iterations - iterations_before) / max(substeps - substeps_before, 1)
    positions = _full_clip(positions, k)
    frames_sdf, sdf = _spent(lambda: dyn.surface_frames(positions))
    clip = SimClip(control=1, frames=frames_sdf, end_state=end)
    features, feature = _spent(lambda: dyn.features(clip))
    other_positions, other_end = sim.run(end, 2, n)
    other = SimClip(2, dyn.surface_frames(_full_clip(other_positions, k)), other_end)
    other_features = dyn.features(other)
    _, dist = _spent(lambda: dyn.dist(features, other_features, 2))
    _, blend = _spent(lambda: dyn.blend(clip.frames, other.frames))
    dyn.renderer.frame(np.full(dyn.grid.shape, dyn.grid.far_value, np.float32))  # load scene
    images, render = _spent(lambda: dyn.render(clip.frames))
    strip, encode = _spent(lambda: encode_strip(images))
    settings = dyn.render_quality
    camera = tank_camera(dyn.scene.tank, settings.width, settings.height)
    water = silhouettes(
        silhouette_projector(camera, dyn.grid), dequantise_sdf(dyn.grid, clip.frames)
    )
    bundle = {"frames": clip.frames, "end_state": end}
    writer = _writer_seconds(dyn, features, other_features, bundle)

    stages = {
        "simulate": sph.scaled(k / n),
        "sdf": sdf,
        "features": feature,
        "dist": dist,
        "blend": blend,
        "render": render,
        "encode": encode,
    }
    encoded = encode_arrays(bundle)
    members = member_sizes(encoded)
    per_frame = {
        "end_state": members["end_state"] / k,
        "sdf": members["frames"] / k,
        "bundle_header": (len(encoded) - sum(members.values())) / k,
        "animation_strip": len(strip) / k,
    }
    per_frame["total"] = sum(per_frame.values())
    return {
        "preset": preset,
        "fluid": fluid,
        "particles": int(sim.n),
        "voxels": list(dyn.grid.shape),
        "image": [dyn.render_quality.width, dyn.render_quality.height],
        "spp": dyn.render_quality.spp,
        "frames_per_clip": k,
        "simulated_frames_per_clip": n,
        "settle_seconds": settle,
        "calibration": calibration,
        "mean_pressure_iterations": mean_iterations,
        "seconds": {stage: spent.wall for stage, spent in stages.items()},
        "cpu_seconds": {stage: spent.cpu for stage, spent in stages.items()},
        "per_expansion": per_expansion(stages, k),
        "render_seconds_per_frame": render.wall / k,
        "dark_fraction": fraction_percentiles(dark_fractions(images)),
        "dark_pixels_inside_water": int(dark_inside(images, water).sum()),
        "writer_seconds_per_new_clip": writer,
        "bytes_per_frame": {key: round(v) for key, v in per_frame.items()},
        "served_bytes_per_frame": {"poster": round(len(encode_poster(images)) / k)},
    }
