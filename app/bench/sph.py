"""Speed of the PCISPH simulator (`srg bench sph`), optionally against SPlisHSPlasH.

Reports particle-substeps per second, mean pressure iterations, seconds per clip and
peak resident memory. With ``pysplishsplash`` installed, its PCISPH runs in a subprocess
on the same particle count, spacing and time step (its GL library clashes with the
system one here, hence the LD_PRELOAD), at its minimum iteration count.
"""

from __future__ import annotations

import json
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from app.core.liquid.scene import Scene, tilt_tank
from app.kernels.pcisph import PcisphSolver

GL_PRELOAD = "/lib/x86_64-linux-gnu/libGLdispatch.so.0"
_UNIT_BOX = """v -0.5 -0.5 -0.5\nv 0.5 -0.5 -0.5\nv 0.5 0.5 -0.5\nv -0.5 0.5 -0.5
v -0.5 -0.5 0.5\nv 0.5 -0.5 0.5\nv 0.5 0.5 0.5\nv -0.5 0.5 0.5
f 1 3 2\nf 1 4 3\nf 5 6 7\nf 5 7 8\nf 1 2 6\nf 1 6 5\nf 4 8 7\nf 4 7 3
f 1 5 8\nf 1 8 4\nf 2 3 7\nf 2 7 6
"""


def _time_steps(sim: PcisphSolver, state: Any, steps: int) -> tuple[float, Any]:
    frames = max(1, steps // sim.scene.substeps)
    start = time.perf_counter()
    _, end = sim.run(state, 0, frames)
    return time.perf_counter() - start, end


def _ours(scene: Scene, steps: int, fixed_iterations: int | None, device: str) -> dict[str, Any]:
    sim = PcisphSolver(scene, fixed_iterations=fixed_iterations, device=device)
    rest = PcisphSolver(scene, device=device).settle(seconds=1.0, damped_seconds=0.5)
    seconds, _ = _time_steps(sim, rest, steps)
    substeps, iterations = sim.stats.substeps, sim.stats.mean_iterations
    clip_start = time.perf_counter()
    sim.simulate_clip(rest, 1)
    return {
        "particle_steps_per_s": sim.n * substeps / seconds,
        "substeps": substeps,
        "mean_iterations": iterations,
        "seconds": seconds,
        "seconds_per_clip": time.perf_counter() - clip_start,
    }


def _splishsplash(scene: Scene, steps: int, iterations: int) -> dict[str, Any]:
    exe = shutil.which("splash") or str(Path(sys.executable).parent / "splash")
    if not Path(exe).exists():
        return {"error": "pysplishsplash not installed"}
    with tempfile.TemporaryDirectory() as tmp:
        Path(tmp, "UnitBox.obj").write_text(_UNIT_BOX)
        size = [hi - lo for lo, hi in zip(scene.tank.lo, scene.tank.hi, strict=True)]
        centre = [(lo + hi) / 2 for lo, hi in zip(scene.tank.lo, scene.tank.hi, strict=True)]
        config = {
            "Configuration": {
                "particleRadius": scene.spacing / 2,
                "timeStepSize": scene.dt,
                "cflMethod": 0,
                "simulationMethod": 1,
                "maxIterations": iterations,
                "minIterations": iterations,
                "maxError": 0.01,
                "boundaryHandlingMethod": 0,
                "enableVTKExport": False,
                "enablePartioExport": False,
                "stopAt": steps * scene.dt,
            },
            "Materials": [{"id": "Fluid", "viscosityMethod": 1, "viscosity": scene.viscosity}],
            "RigidBodies": [
                {
                    "geometryFile": "UnitBox.obj",
                    "translation": centre,
                    "scale": size,
                    "isDynamic": False,
                    "isWall": True,
                    "mapInvert": True,
                    "color": [0.1, 0.4, 0.6, 1],
                }
            ],
            "FluidBlocks": [
                {
                    # its blocks leave a spacing free at the end: extend to get our count
                    "denseMode": 0,
                    "start": list(scene.fluid.lo),
                    "end": [x + 0.75 * scene.spacing for x in scene.fluid.hi],
                }
            ],
        }
        Path(tmp, "scene.json").write_text(json.dumps(config))
        # its OpenMP threads busy-wait by default, which on a shared 2-core machine costs
        # it about 3x; passive waits measure its solver, not the scheduler
        env = dict(os.environ, LD_PRELOAD=GL_PRELOAD, OMP_WAIT_POLICY="PASSIVE")
        start = time.perf_counter()
        done = subprocess.run(
            [exe, "--no-gui", "--no-cache", "--output-dir", tmp, str(Path(tmp, "scene.json"))],
            env=env,
            capture_output=True,
            text=True,
            timeout=1800,
            check=False,
        )
        seconds = time.perf_counter() - start
    if done.returncode != 0:
        return {"error": done.stderr[-500:]}
    log = done.stdout + done.stderr
    n = int(_log_value(log, "Number of fluid particles:"))
    sim_seconds = _log_value(log, "Time sum: SimStep:") / 1000.0
    return {
        "particles": n,
        "seconds_wall": seconds,
        "seconds_in_steps": sim_seconds,
        "particle_steps_per_s": n * steps / sim_seconds if sim_seconds else 0.0,
    }


def _log_value(log: str, prefix: str) -> float:
    """First number after ``prefix`` in SPlisHSPlasH's log (0 if absent)."""
    for line in log.splitlines():
        if prefix in line:
            return float(line.split(prefix, 1)[1].split()[0])
    return 0.0


def bench_sph(
    preset: str, steps: int, *, fluid: str, device: str, compare_splishsplash: bool = True
) -> dict[str, Any]:
    """Time ``steps`` substeps of the tilt tank ``preset`` with ``fluid`` (after a short settle).

    ``device`` names the OpenCL device (``app.kernels.context.select_device``).
    Returns our throughput converged to eta and at SPlisHSPlasH's iteration count
    (its PCISPH stops on the signed mean error, so it runs its minimum, 3), its
    throughput when installed, the ratios, and peak resident memory (MB).
    """
    scene = tilt_tank(preset, fluid)
    result: dict[str, Any] = {
        "preset": preset,
        "fluid": fluid,
        "particles": PcisphSolver(scene, device=device).n,
        "dt": scene.dt,
        "converged": _ours(scene, steps, None, device),
        "fixed_3_iterations": _ours(scene, steps, 3, device),
    }
    if compare_splishsplash:
        ref = _splishsplash(scene, steps, 3)
        result["splishsplash_pcisph"] = ref
        if ref.get("particle_steps_per_s"):
            for key in ("converged", "fixed_3_iterations"):
                ours = result[key]["particle_steps_per_s"]
                result[f"ratio_{key}"] = ours / ref["particle_steps_per_s"]
    result["peak_rss_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    return result
