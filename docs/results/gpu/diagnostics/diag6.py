"""GPU_SCAN_BLOCK on the GPU: small batches and a paper frame."""
import os
import sys

import app.kernels.launch_shapes as ls
from app.bench.gpu import frame_seconds
from app.bench.sph_batch import bench_batch

dev = os.environ.get("SRG_OPENCL_DEVICE", "NVIDIA")
P, Q = (sys.argv[1], sys.argv[2]) if len(sys.argv) > 2 else ("paper", "small")
for rep in range(int(os.environ.get("REPS", 2))):
    for blk in [int(x) for x in os.environ.get("BLKS", "64,32,16,8").split(",")]:
        ls.GPU_SCAN_BLOCK = blk
        b = bench_batch(Q, "low", [1, 12], dev)
        f = frame_seconds(P, "high", dev)
        print(rep, blk, [round(r["clip_frames_per_s"], 1) for r in b["batches"]],
              round(b["batches"][-1]["speedup"], 2), b["identical"],
              round(f["seconds_per_frame"], 4), f["queued_equals_careful"], flush=True)
