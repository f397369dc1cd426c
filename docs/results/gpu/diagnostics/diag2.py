"""Reruns and budget slack on the GPU."""
import json
import os
import sys
import time

import app.kernels.sph as sph
from app.bench.sph_batch import bench_batch
from app.core.liquid.scene import tilt_tank
from app.kernels.sph import SphSimulator

dev = os.environ.get("SRG_OPENCL_DEVICE", "NVIDIA")
P, Q = (sys.argv[1], sys.argv[2]) if len(sys.argv) > 2 else ("paper", "small")
calls = {"careful": 0}
orig_substep = SphSimulator.substep
def counting(self, *a, **kw):
    calls["careful"] += 1
    return orig_substep(self, *a, **kw)
SphSimulator.substep = counting

out = {}
scene = tilt_tank(P, "high")
base = SphSimulator(scene, device=dev)
rest = base.settle(seconds=0.3, damped_seconds=0.2)
for slack in (4, 2, 8, 12):
    sph.BUDGET_SLACK = slack
    sim = SphSimulator(scene, device=dev)
    sim.run(rest, 1, 1)
    calls["careful"] = 0
    t0 = time.perf_counter()
    frames, end = sim.run(rest, 1, 10)
    t = time.perf_counter() - t0
    out[f"high_slack{slack}"] = {"s_per_frame": t / 10, "careful_substeps": calls["careful"],
        "budget": sim.budget, "mean_it": sim.stats.mean_iterations,
        "max_it": max(sim.stats.iteration_counts), "hash": hash(frames.tobytes())}
    print(slack, out[f"high_slack{slack}"], flush=True)
for slack in (4, 8):
    sph.BUDGET_SLACK = slack
    calls["careful"] = 0
    b = bench_batch(Q, "low", [1, 12], dev)
    out[f"batch_slack{slack}"] = {"speedup": b["batches"][-1]["speedup"],
        "rates": [r["clip_frames_per_s"] for r in b["batches"]], "identical": b["identical"],
        "careful_substeps": calls["careful"]}
    print(slack, out[f"batch_slack{slack}"], flush=True)
print(json.dumps(out))
