"""Clips simulated in batches (`srg bench sph --batch 1,3,12`): clip-frames per second.

An expansion simulates one clip per control from one state, an epoch several expansions;
a batch runs them in one launch sequence (docs/sph.md, "Clips in batches"). The clips
here are those of a few expansions: start states a frame apart in a tilting tank, each
under every control. Each batch size runs the first clips of that list; every clip is
also run alone, which gives the rate of a batch of one and the identity check.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from app.core.liquid.scene import tilt_tank
from app.kernels.pcisph import PcisphSolver


def expansion_clips(sim: PcisphSolver, rest: np.ndarray, count: int) -> list[tuple[Any, int]]:
    """``count`` (start state, control) pairs: states one frame of tilt apart, each
    under every control in turn, as successive expansions ask."""
    controls = len(sim.scene.gravity)
    states = [rest]
    while len(states) * controls < count:
        states.append(sim.run(states[-1], 1, 1)[1])
    return [(states[j // controls], j % controls) for j in range(count)]


def bench_batch(preset: str, fluid: str, sizes: list[int], device: str) -> dict[str, Any]:
    """Wall and process CPU seconds of whole clips per batch size, clip-frames per
    second of each (on a GPU the wall is the device's), and whether every clip of every
    batch equals its solo run bit for bit."""
    scene = tilt_tank(preset, fluid)
    solo = PcisphSolver(scene, device=device)
    rest = solo.settle(seconds=1.0, damped_seconds=0.5)
    clips = expansion_clips(solo, rest, max(sizes))
    frames = scene.frames_per_clip
    solo.run(rest, 0, 1)  # kernels built, buffers touched

    def timed(run: Any, *args: Any) -> tuple[Any, float, float]:
        wall, cpu = time.perf_counter(), time.process_time()
        out = run(*args)
        return out, time.perf_counter() - wall, time.process_time() - cpu

    alone, wall, cpu = timed(lambda: [solo.run(s, c, frames) for s, c in clips])
    rows = [_row(1, len(clips), frames, wall, cpu, identical=True)]
    for size in sorted(set(sizes) - {1}):
        sim = PcisphSolver(scene, device=device, batch=size)
        states, controls = zip(*clips[:size], strict=True)
        sim.run_batch(states, controls, 1)
        (positions, ends), wall, cpu = timed(sim.run_batch, states, controls, frames)
        same = all(
            np.array_equal(positions[c], alone[c][0]) and np.array_equal(ends[c], alone[c][1])
            for c in range(size)
        )
        rows.append(_row(size, size, frames, wall, cpu, identical=same))
    base = rows[0]["clip_frames_per_s"]
    for row in rows:
        row["speedup"] = row["clip_frames_per_s"] / base
    return {
        "preset": preset,
        "fluid": fluid,
        "particles": solo.n,
        "frames_per_clip": frames,
        "device": solo.kernels.queue.device.name.strip(),
        "batches": rows,
        "identical": all(row["identical"] for row in rows),
    }


def _row(
    size: int, clips: int, frames: int, wall: float, cpu: float, *, identical: bool
) -> dict[str, Any]:
    return {
        "batch": size,
        "clips_timed": clips,
        "wall_s": wall,
        "cpu_s": cpu,
        "clip_frames_per_s": clips * frames / wall,
        "clip_frames_per_cpu_s": clips * frames / cpu if cpu else 0.0,
        "identical": identical,
    }
