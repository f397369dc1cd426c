"""Careful vs queued frames on the GPU."""
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
out = {}
for fluid in ("high", "low"):
    scene = tilt_tank(P, fluid)
    base = SphSimulator(scene, device=dev)
    rest = base.settle(seconds=0.3, damped_seconds=0.2)
    hashes = []
    for qf in (False, True):
        sim = SphSimulator(scene, device=dev, queue_frames=qf)
        sim.run(rest, 1, 1)
        t0 = time.perf_counter()
        frames, end = sim.run(rest, 1, 10)
        t = time.perf_counter() - t0
        hashes.append(hash(frames.tobytes()))
        out[f"{fluid}_queued{qf}"] = {"s_per_frame": t / 10, "mean_it": sim.stats.mean_iterations}
        print(fluid, qf, out[f"{fluid}_queued{qf}"], flush=True)
    out[f"{fluid}_same"] = hashes[0] == hashes[1]
for qf in (False, True):
    sph.queues_frames = lambda d, qf=qf: qf
    b = bench_batch(Q, "low", [1, 3, 12], dev)
    out[f"batch_queued{qf}"] = {"speedups": [r["speedup"] for r in b["batches"]],
        "rates": [r["clip_frames_per_s"] for r in b["batches"]], "identical": b["identical"]}
    print(qf, out[f"batch_queued{qf}"], flush=True)
print(json.dumps(out))
