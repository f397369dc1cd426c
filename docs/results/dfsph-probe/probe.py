"""DFSPH (Bender and Koschier 2017) in NumPy beside the OpenCL PCISPH: iterations a substep
and the actual density errors, on the same tilt from the same settled tank
(docs/sph.md, "DFSPH, probed in NumPy"). Not part of srg: a measurement's script.

    python docs/results/dfsph-probe/probe.py PRESET SUBSTEP_FACTOR ETA_D ETA_V FRAMES

ETA_D > 0 stops the density solve on the mean compression of the linear prediction,
ETA_D < 0 on its maximum (|ETA_D|); ETA_V is the divergence solve's mean bound.
Pressures are kappa = p / rho0^2, as the PCISPH twin's forces use rho0.
"""
import sys
import time

import numpy as np

from app.core.liquid import sph as tw
from app.core.liquid.scene import tilt_tank
from app.core.liquid.sph_grid import wall_particles, wall_volumes
from app.kernels.sph import SphSimulator

preset = sys.argv[1] if len(sys.argv) > 1 else "tiny"
sub_factor = float(sys.argv[2]) if len(sys.argv) > 2 else 1.0
eta_d = float(sys.argv[3]) if len(sys.argv) > 3 else 0.001   # mean compression
eta_v = float(sys.argv[4]) if len(sys.argv) > 4 else 0.001
frames = int(sys.argv[5]) if len(sys.argv) > 5 else 20
scene = tilt_tank(preset)
sim = SphSimulator(scene)
rest = sim.settle(seconds=1.5, damped_seconds=0.7)
walls = wall_particles(scene)
psi = wall_volumes(walls, scene)
h, m, rho0 = scene.support, scene.particle_mass, scene.rest_density
substeps = max(1, round(scene.substeps * sub_factor))
dt = 1.0 / scene.fps / substeps
g = np.asarray(scene.gravity[1], float)
margin = tw.WALL_MARGIN * scene.spacing
lo = np.asarray(scene.tank.lo) + margin; hi = np.asarray(scene.tank.hi) - margin

def rows(vals, idx, n):
    out = np.zeros((n,) + vals.shape[1:]); np.add.at(out, idx, vals); return out

pos = rest[:, :3].astype(float); vel = rest[:, 3:].astype(float); n = len(pos)
kd = np.zeros(n); kv = np.zeros(n)
its_v, its_d, errs_max, errs_avg = [], [], [], []
t0 = time.time()
for step in range(frames * substeps):
    nb = tw.find_neighbours(pos, walls, h)
    i, j = nb.fluid.T; ib, b = nb.wall.T
    d = pos[i] - pos[j]; r = np.linalg.norm(d, axis=1)
    gW = m * tw.cubic_kernel_gradient(d, r, h)
    db = pos[ib] - walls[b]; rb = np.linalg.norm(db, axis=1)
    gB = psi[b][:, None] * tw.cubic_kernel_gradient(db, rb, h)
    rho = tw.density(pos, nb, walls, psi, scene)
    G = rows(gW, i, n) + rows(gB, ib, n)
    S = rows((gW * gW).sum(1), i, n)
    den = (G * G).sum(1) + S
    f = np.where(den > 1e-9 * den.max(), 1.0 / np.maximum(den, 1e-30), 0.0)
    count = np.bincount(i, minlength=n) + np.bincount(ib, minlength=n)
    def drho(v):
        return rows(((v[i] - v[j]) * gW).sum(1), i, n) + rows((v[ib] * gB).sum(1), ib, n)
    def apply(v, k):
        return v - dt * (rows((k[i] + k[j])[:, None] * gW, i, n) + rows(k[ib][:, None] * gB, ib, n))
    # divergence-free solve on v(t)
    v = apply(vel, 0.5 * kv); kv = 0.5 * kv
    for it in range(100):
        dd = drho(v); dd = np.where((dd > 0) & (count >= 20), dd, 0.0)
        if it >= 1 and dd.mean() * dt / rho0 < eta_v: break
        k = dd * f / dt; v = apply(v, k); kv = kv + k
    its_v.append(it)
    a = g[None, :] + tw.viscous_accel(pos, v, nb, walls, psi, scene)
    v = v + dt * a
    v = apply(v, 0.5 * kd); kd = 0.5 * kd
    for it in range(100):
        e = np.maximum(rho + dt * drho(v) - rho0, 0.0)
        if it >= 2 and ((e.mean() if eta_d > 0 else e.max()) / rho0 < abs(eta_d)): break
        k = e * f / dt**2; v = apply(v, k); kd = kd + k
    its_d.append(it)
    x = pos + dt * v
    v = np.where((x < lo) & (v < 0), 0.0, v); v = np.where((x > hi) & (v > 0), 0.0, v)
    pos = np.clip(x, lo, hi); vel = v
    if step % 3 == 0:
        nb2 = tw.find_neighbours(pos, walls, h)
        rr = tw.density(pos, nb2, walls, psi, scene)
        errs_max.append(max(0, (rr.max() - rho0) / rho0)); errs_avg.append(np.maximum(rr - rho0, 0).mean() / rho0)
print(f"{preset} substeps/frame {substeps} eta_d {eta_d} eta_v {eta_v}: div its {np.mean(its_v):.2f}, density its {np.mean(its_d):.2f}, "
      f"actual max compression median {np.median(errs_max)*100:.2f}% p95 {np.percentile(errs_max,95)*100:.2f}% max {np.max(errs_max)*100:.2f}%, mean {np.mean(errs_avg)*100:.3f}%  ({time.time()-t0:.0f}s)")
# PCISPH on the same frames, for the iteration count and its errors
sim.stats.iteration_counts.clear(); sim.stats.substeps = 0; sim.stats.iterations = 0
sim.run(rest, 1, frames)
print(f"PCISPH {scene.substeps}/frame: iterations {sim.stats.mean_iterations:.2f}, max error {sim.stats.max_error*100:.2f}%")
