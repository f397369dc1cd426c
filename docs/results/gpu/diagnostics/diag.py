"""GPU diagnostics: host enqueue vs device time for paper high frames."""
import json
import os
import sys
import time

import numpy as np
import pyopencl as cl

import app.kernels.launcher as launcher
from app.core.liquid.scene import tilt_tank
from app.kernels.sph import SphSimulator

dev = os.environ.get("SRG_OPENCL_DEVICE", "NVIDIA")
P, Q = (sys.argv[1], sys.argv[2]) if len(sys.argv) > 2 else ("paper", "small")
out = {}
scene = tilt_tank(P, "high")
sim = SphSimulator(scene, device=dev)
rest = sim.settle(seconds=0.3, damped_seconds=0.2)
sim.run(rest, 1, 1)
k = sim.kernels
g = [scene.gravity[1]]

def frame_split(sim):
    k = sim.kernels
    t0 = time.perf_counter()
    sim.frame(g)  # includes final read
    t1 = time.perf_counter()
    return t1 - t0

# 1. frame time and host enqueue share: replicate frame's loop without the read
k.load(np.ascontiguousarray(rest[None], dtype=np.float32)); k.queue.finish()
times = [frame_split(sim) for _ in range(3)]
out["frame_s"] = times
out["budget"] = sim.budget
s = scene
lo = max(s.min_iterations, 1)
budget = sim.budget
k.queue.finish()
t0 = time.perf_counter()
k.keep_state(); k.reset_errors(s.substeps * budget)
for j in range(s.substeps):
    sim._forces(g, 0.0)
    first = j * budget
    for m in range(first, first + budget):
        k.density_pressure(m, check_from=first + lo)
        k.pressure_predict(0.0, m, check_from=first + lo)
    k.advance()
t1 = time.perf_counter()
k.queue.finish()
t2 = time.perf_counter()
out["enqueue_s"] = t1 - t0
out["enqueue_plus_finish_s"] = t2 - t0
k.restore_state(); k.queue.finish()

# 2. no-op launch: host and device cost
k.reset_errors(8); k.queue.finish()
N = int(os.environ.get("N", 2000))
t0 = time.perf_counter()
for _ in range(N):
    k.density_pressure(5, check_from=1)
t1 = time.perf_counter()
k.queue.finish()
t2 = time.perf_counter()
out["noop_host_us"] = (t1 - t0) / N * 1e6
out["noop_total_us"] = (t2 - t0) / N * 1e6

# 3. raw enqueue of a preset kernel (no _run overhead)
kern = k.kernels["density_pressure"]
shape = (sim.n,)
local = launcher.work_group(sim.n)
t0 = time.perf_counter()
for _ in range(N):
    cl.enqueue_nd_range_kernel(k.queue, kern, shape, local)
t1 = time.perf_counter()
k.queue.finish()
t2 = time.perf_counter()
out["raw_host_us"] = (t1 - t0) / N * 1e6
out["raw_total_us"] = (t2 - t0) / N * 1e6
out["local"] = local

# 4. frame time with the driver's local size
orig = launcher.work_group
for name, fn in [("none", lambda n: None), ("orig", orig)]:
    launcher.work_group = fn
    sim2 = SphSimulator(scene, device=dev)
    sim2.run(rest, 1, 1)
    sim2.kernels.load(np.ascontiguousarray(rest[None], dtype=np.float32))
    t = [frame_split(sim2) for _ in range(3)]
    frames_a, _ = sim2.run(rest, 1, 2)
    out[f"frame_s_local_{name}"] = t
    out[f"hash_{name}"] = hash(frames_a.tobytes())
launcher.work_group = orig

# 5. batch small: enqueue vs total for batch 12
sc = tilt_tank(Q, "low")
sb = SphSimulator(sc, device=dev)
r = sb.settle(seconds=0.5, damped_seconds=0.2)
for b in (1, 12):
    sim3 = SphSimulator(sc, device=dev, batch=b)
    sim3.run_batch([r] * b, [1] * b, 1)
    t0 = time.perf_counter(); sim3.run_batch([r] * b, [1] * b, 10); t1 = time.perf_counter()
    out[f"small_b{b}_10frames_s"] = t1 - t0
    out[f"small_b{b}_budget"] = sim3.budget
    out[f"small_b{b}_iters"] = sim3.stats.mean_iterations
out["small_substeps"] = sc.substeps
print(json.dumps(out, indent=1))
