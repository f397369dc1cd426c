"""Profile of small clips alone and in a batch of 12, on the GPU."""
import json
import os
import sys
import time

from app.bench.sph_batch import expansion_clips
from app.bench.sph_profile import launch_times, summarise
from app.core.liquid.scene import tilt_tank
from app.kernels.sph import SphSimulator

dev = os.environ.get("SRG_OPENCL_DEVICE", "NVIDIA")
Q = sys.argv[1] if len(sys.argv) > 1 else "small"
scene = tilt_tank(Q, "low")
solo = SphSimulator(scene, device=dev)
rest = solo.settle(seconds=1.0, damped_seconds=0.5)
clips = expansion_clips(solo, rest, 12)
out = {}
for b in (1, 12):
    sim = SphSimulator(scene, device=dev, profile=True, batch=b)
    states, controls = zip(*clips[:b])
    sim.run_batch(states, controls, 1)
    sim.kernels.launches.clear(); sim.stats.substeps = 0; sim.stats.iterations = 0
    t0 = time.perf_counter()
    sim.run_batch(states, controls, 3)
    wall = time.perf_counter() - t0
    # stats count one substep per clip: the launch sequence's substeps are a clip's
    substeps = sim.stats.substeps // b
    r = summarise(launch_times(sim.kernels.launches), substeps)
    r["wall_ms_per_substep"] = wall * 1e3 / substeps
    r["mean_iterations_per_clip"] = sim.stats.mean_iterations
    r["kernels"] = {k: round(v["ms_per_substep"] * 1e3, 1) for k, v in r["kernels"].items()}
    out[f"batch{b}"] = r
    print(b, json.dumps(r), flush=True)
