"""The GPU check of the solver (`srg bench gpu`, or `python -m app.bench.gpu` on a machine
that has only NumPy, SciPy and PyOpenCL: `infra/gpu-bench.sh`).

One run answers what docs/sph.md "On a GPU" asks of a device: the seconds a `paper`
frame of the high fluid takes (bar 0.05 s), how much faster `small` clips run in batches
of 12 than alone (bar 10 x), whether the device's frames are the same queued a frame at
once and the careful way and in a batch and alone, and where a substep's time goes.
"""

from __future__ import annotations

import json
import logging
import os
import sys
import time
from typing import Any

import numpy as np

from app.bench.sph_batch import bench_batch
from app.bench.sph_profile import profile_sph
from app.core.liquid.scene import tilt_tank
from app.kernels.pcisph import PcisphSolver

log = logging.getLogger(__name__)

#: the bars of the issue that asked for this check
FRAME_SECONDS_BAR = 0.05
BATCH_SPEEDUP_BAR = 10.0
#: frames timed after the settle (one more first, to build and warm up)
TIMED_FRAMES = 10


def frame_seconds(preset: str, fluid: str, device: str) -> dict[str, Any]:
    """Seconds a frame of the tank tilting, after a short settle, the careful way (the
    default) and queued a frame at once; and whether the two agree bit for bit."""
    scene = tilt_tank(preset, fluid)
    rest = PcisphSolver(scene, device=device).settle(seconds=0.3, damped_seconds=0.2)

    def timed(queue_frames: bool) -> tuple[float, np.ndarray, np.ndarray, PcisphSolver]:
        sim = PcisphSolver(scene, device=device, queue_frames=queue_frames)
        sim.run(rest, 1, 1)
        start = time.perf_counter()
        frames, end = sim.run(rest, 1, TIMED_FRAMES)
        return (time.perf_counter() - start) / TIMED_FRAMES, frames, end, sim

    seconds, frames, end, sim = timed(queue_frames=False)
    queued_seconds, queued_frames, queued_end, _ = timed(queue_frames=True)
    return {
        "preset": preset,
        "fluid": fluid,
        "particles": sim.n,
        "substeps_per_frame": scene.substeps,
        "seconds_per_frame": seconds,
        "queued_seconds_per_frame": queued_seconds,
        "mean_iterations": sim.stats.mean_iterations,
        "queued_equals_careful": bool(
            np.array_equal(frames, queued_frames) and np.array_equal(end, queued_end)
        ),
    }


def bench_gpu(
    device: str,
    frame_preset: str = "paper",
    batch_preset: str = "small",
    batches: tuple[int, ...] = (1, 12),
) -> dict[str, Any]:
    """The frame time, the batches' speed-up, the identities and the profile, with the
    bars and whether each is met."""
    frame = frame_seconds(frame_preset, "high", device)
    _progress("frame", frame)
    batch = bench_batch(batch_preset, "low", list(batches), device)
    _progress("batches", batch)
    profile = profile_sph(frame_preset, "high", tilt_tank(frame_preset, "high").substeps, device)
    _progress("profile", profile)
    largest = batch["batches"][-1]
    return {
        "device": batch["device"],
        "frame": frame,
        "batches": batch,
        "profile": profile,
        "bars": {
            f"{frame_preset} high seconds a frame <= {FRAME_SECONDS_BAR}": frame[
                "seconds_per_frame"
            ]
            <= FRAME_SECONDS_BAR,
            f"{batch_preset} batch of {largest['batch']} >= {BATCH_SPEEDUP_BAR} x alone": largest[
                "speedup"
            ]
            >= BATCH_SPEEDUP_BAR,
            "identical": frame["queued_equals_careful"] and batch["identical"],
        },
    }


def _progress(part: str, result: dict[str, Any]) -> None:
    """Each part logged as it ends: a device lent for minutes may be taken back before
    the report, and what was measured by then should not be lost with it."""
    log.info("gpu-bench: %s done: %s", part, json.dumps(result))


if __name__ == "__main__":
    # the bare GPU machine has no settings library: the device comes from the same
    # variable the settings read (docs/runtime.md, "The OpenCL device"); the presets may
    # follow as arguments (frame, batch), e.g. `tiny tiny` for a quick trial of the script
    logging.basicConfig(level=logging.INFO, stream=sys.stderr, format="%(message)s")
    device = os.environ.get("SRG_OPENCL_DEVICE", "")
    frame_preset = sys.argv[1] if len(sys.argv) > 1 else "paper"
    batch_preset = sys.argv[2] if len(sys.argv) > 2 else "small"
    json.dump(bench_gpu(device, frame_preset, batch_preset), sys.stdout, indent=2)
    print()
