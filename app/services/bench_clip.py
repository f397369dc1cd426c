"""``srg bench clip``: seconds per clip of each stage of a liquid edge, and its bytes.

The clips run from a briefly settled tank under a tilt (a splash: the surface is at its
most complex), then the opposite tilt, so meshing and rendering see a typical hard case.
Bytes are those of what an edge keeps: its int8 SDF and uint8 occupancy frames
(compressed npz), its animation strip and poster (WebP) and its end state (float32
particles, compressed npz; kept by the vertex it reaches).
"""

from __future__ import annotations

import io
import time
from collections.abc import Callable
from typing import TypeVar

import numpy as np

from app.core.dynamics import SimClip
from app.core.surface import pack_clip_fields
from app.render.animation import encode_poster, encode_strip
from app.services.liquid import LiquidDynamics

T = TypeVar("T")


def _timed(fn: Callable[[], T]) -> tuple[T, float]:
    start = time.perf_counter()
    result = fn()
    return result, time.perf_counter() - start


def _npz_bytes(array: np.ndarray) -> int:
    buffer = io.BytesIO()
    np.savez_compressed(buffer, array)
    return len(buffer.getvalue())


def bench_clip(preset: str = "small", fluid: str = "low") -> dict:
    """Time simulate (SPH), SDF, features, blend and render of one clip; size its data.

    Returns
    -------
    dict
        ``seconds`` per clip by stage, ``bytes_per_frame`` by stored item and in total,
        and the sizes that explain them (particles, voxels, image size).
    """
    dyn = LiquidDynamics(preset, fluid)
    sim = dyn.simulator
    state = sim.settle(seconds=1.0, damped_seconds=0.5)
    sim.simulate_clip(state, 0)  # warm up kernels and buffers
    (positions, end), t_sph = _timed(lambda: sim.simulate_clip(state, 1))
    frames, t_sdf = _timed(lambda: dyn.surface_frames(positions))
    clip = SimClip(control=1, frames=frames, end_state=end)
    features, t_features = _timed(lambda: dyn.features(clip))
    other = dyn.simulate(end, 2)
    other_features = dyn.features(other)
    _, t_dist = _timed(lambda: dyn.dist(features, other_features, 2))
    _, t_blend = _timed(lambda: dyn.blend(clip.frames, other.frames))
    dyn.renderer.frame(np.full(dyn.grid.shape, dyn.grid.far_value, np.float32))  # load scene
    images, t_render = _timed(lambda: dyn.render(clip.frames))
    strip, t_encode = _timed(lambda: encode_strip(images))

    k = dyn.frames_per_clip
    per_frame = {
        "sdf_and_occupancy": len(pack_clip_fields(clip.frames, features.occupancy)) / k,
        "animation_strip": len(strip) / k,
        "poster": len(encode_poster(images)) / k,
        "end_state": _npz_bytes(end) / k,
    }
    per_frame["total"] = sum(per_frame.values())
    return {
        "preset": preset,
        "fluid": fluid,
        "particles": int(sim.n),
        "voxels": list(dyn.grid.shape),
        "image": [dyn.render_settings.width, dyn.render_settings.height],
        "spp": dyn.render_settings.spp,
        "frames_per_clip": k,
        "seconds": {
            "simulate": t_sph,
            "sdf": t_sdf,
            "features": t_features,
            "dist": t_dist,
            "blend": t_blend,
            "render": t_render,
            "encode": t_encode,
        },
        "render_seconds_per_frame": t_render / k,
        "bytes_per_frame": {key: round(v) for key, v in per_frame.items()},
    }
