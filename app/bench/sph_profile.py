"""Where a PCISPH substep goes (`srg bench sph --profile`): device time per kernel and gaps.

The simulator runs on a profiling queue of its own (``PcisphSolver(profile=True)``); every
kernel launch is kept with its event, whose device timestamps give each kernel's time.
The queue is in order, so what separates one kernel's end from the next one's start is
time the device did not compute: the host enqueuing, waiting on a read of the
convergence test, or copies. Those gaps, summed, are the host's share of a substep.
"""

from __future__ import annotations

import time
from collections import defaultdict
from typing import Any

import pyopencl as cl

from app.core.liquid.scene import tilt_tank
from app.kernels.pcisph import PcisphSolver

#: the kernels of the pressure loop (the rest run once a substep)
PRESSURE_LOOP = ("pressure_predict", "density_pressure")


def launch_times(launches: list[tuple[str, cl.Event]]) -> list[tuple[str, int, int]]:
    """(kernel, start ns, end ns) of each launch, in queue order."""
    return [(name, e.profile.start, e.profile.end) for name, e in launches]


def summarise(times: list[tuple[str, int, int]], substeps: int) -> dict[str, Any]:
    """Per-kernel device time and the gaps between launches, per substep, in ms.

    A launch that the device skipped (a pressure iteration queued after convergence)
    still counts as a launch: its cost is the launch overhead.
    """
    per: dict[str, list[float]] = defaultdict(lambda: [0, 0.0])
    gaps_ns = 0
    for k, (name, start, end) in enumerate(times):
        per[name][0] += 1
        per[name][1] += end - start
        if k:
            gaps_ns += max(0, start - times[k - 1][2])
    busy_ns = sum(total for _, total in per.values())
    span_ns = times[-1][2] - times[0][1] if times else 0

    def ms(ns: float) -> float:
        return ns / 1e6 / max(substeps, 1)

    kernels = {
        name: {
            "launches_per_substep": count / max(substeps, 1),
            "ms_per_substep": ms(total),
            "share": total / busy_ns if busy_ns else 0.0,
        }
        for name, (count, total) in sorted(per.items(), key=lambda kv: -kv[1][1])
    }
    loop = sum(per[name][1] for name in PRESSURE_LOOP if name in per)
    return {
        "kernels": kernels,
        "device_ms_per_substep": ms(busy_ns),
        "gaps_ms_per_substep": ms(gaps_ns),
        "span_ms_per_substep": ms(span_ns),
        "gap_share": gaps_ns / span_ns if span_ns else 0.0,
        "pressure_loop_share": loop / busy_ns if busy_ns else 0.0,
    }


def profile_sph(preset: str, fluid: str, steps: int, device: str) -> dict[str, Any]:
    """Profile ``steps`` substeps (whole frames) of the tilt tank after a short settle."""
    scene = tilt_tank(preset, fluid)
    rest = PcisphSolver(scene, device=device).settle(seconds=1.0, damped_seconds=0.5)
    sim = PcisphSolver(scene, device=device, profile=True)
    frames = max(1, steps // scene.substeps)
    start = time.perf_counter()
    sim.run(rest, 1, frames)
    wall = time.perf_counter() - start
    launches = sim.kernels.launches or []
    substeps = sim.stats.substeps
    return {
        "preset": preset,
        "fluid": fluid,
        "device": sim.kernels.queue.device.name,
        "particles": sim.n,
        "substeps": substeps,
        "mean_iterations": sim.stats.mean_iterations,
        "wall_ms_per_substep": wall * 1e3 / max(substeps, 1),
        **summarise(launch_times(launches), substeps),
    }
