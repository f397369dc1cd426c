"""Careful loop queued `ahead` iterations ahead, on the GPU."""
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
    rest = SphSimulator(scene, device=dev).settle(seconds=0.3, damped_seconds=0.2)
    hashes = set()
    for ahead in (1, 2, 3, 4, 6):
        sim = SphSimulator(scene, device=dev, queue_frames=False)
        sim.ahead = ahead
        sim.run(rest, 1, 1)
        t0 = time.perf_counter()
        frames, end = sim.run(rest, 1, 10)
        t = time.perf_counter() - t0
        hashes.add(hash(frames.tobytes()))
        out[f"{fluid}_ahead{ahead}"] = t / 10
        print(fluid, ahead, t / 10, sim.stats.mean_iterations, flush=True)
    out[f"{fluid}_same"] = len(hashes) == 1
for ahead in (1, 2, 4):
    sph.iterations_ahead = lambda d, a=ahead: a
    sph.queues_frames = lambda d: False
    b = bench_batch(Q, "low", [1, 3, 12], dev)
    out[f"batch_ahead{ahead}"] = {"speedups": [r["speedup"] for r in b["batches"]],
        "rates": [r["clip_frames_per_s"] for r in b["batches"]], "identical": b["identical"]}
    print(ahead, out[f"batch_ahead{ahead}"], flush=True)
print(json.dumps(out))
