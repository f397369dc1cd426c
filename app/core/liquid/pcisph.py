"""NumPy reference (twin) of the PCISPH kernels in ``app/kernels/pcisph.cl``.

Pure and slow on purpose: pair lists from a k-d tree, float64 sums. Tests hold each
OpenCL kernel to its twin here. The method (Solenthaler and Pajarola 2009, PCISPH; walls
after Akinci et al. 2012), one substep of length dt:

1. non-pressure acceleration a_np = g + viscosity at x(t); where the viscosity needs
   shorter steps than the substep (``scene.viscosity_steps`` > 1), the velocities first
   take all but the last of them explicitly at x(t) (:func:`diffuse_velocity`), and a_np
   carries the last one's share;
2. from the pressures p (warm-started from the previous substep, zero at a clip's start)
   the pressure acceleration a_p and the predicted v* = v + dt (a_np + a_p),
   x* = x + dt v*;
3. the predicted density rho* at x* and p <- max(0, p + delta (rho* - rho0));
   repeat 2-3 until max(rho* - rho0) / rho0 < eta (within min/max iteration counts);
4. x(t + dt) = x*, v(t + dt) = v* from the last pressures.

Kernel: cubic spline with support h = 2 dx, W(r) = 8 / (pi h^3) w(r / h). Pressure
forces use rho0 in the denominators (as PCISPH's delta assumes), so
a_p,i = -m / rho0^2 sum_j (p_i + p_j) grad W_ij - sum_b psi_b p_i / rho0^2 grad W_ib
(Akinci's wall force; the mirrored form with 2 p_i made the solve unstable at walls).
Viscosity is the SPH Laplacian
10 nu m / rho0 sum_j (v_ij . x_ij) / (|x_ij|^2 + 0.01 h^2) grad W_ij, walls included.
Positions are kept inside the tank by a final clamp at a quarter spacing from the walls
that also stops the velocity component into the wall (a safety net: the wall particles
normally stop particles earlier).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from app.core.liquid.scene import Scene

#: the clamp keeps particles this many spacings inside the walls
WALL_MARGIN = 0.25
#: relative softening of the viscosity term, eps = 0.01 h^2
VISCOSITY_EPS = 0.01


def cubic_kernel(r: np.ndarray, h: float) -> np.ndarray:
    """Cubic spline W(r) of support h (Monaghan 1992), normalised in 3D."""
    q = np.asarray(r, dtype=np.float64) / h
    sigma = 8.0 / (np.pi * h**3)
    inner = 6.0 * (q**3 - q**2) + 1.0
    outer = 2.0 * np.clip(1.0 - q, 0.0, None) ** 3
    return sigma * np.where(q <= 0.5, inner, outer)


def cubic_kernel_gradient(d: np.ndarray, r: np.ndarray, h: float) -> np.ndarray:
    """grad W at offsets d (m, 3) of length r (m,); zero at r = 0 and beyond h."""
    q = np.asarray(r, dtype=np.float64) / h
    sigma = 8.0 / (np.pi * h**3)
    f = np.where(q <= 0.5, q * (3.0 * q - 2.0), -(np.clip(1.0 - q, 0.0, None) ** 2))
    with np.errstate(divide="ignore", invalid="ignore"):
        scale = np.where((r > 1e-9 * h) & (q < 1.0), 6.0 * sigma * f / (h * r), 0.0)
    return np.asarray(d, dtype=np.float64) * scale[:, None]


@dataclass(frozen=True)
class Neighbours:
    """Ordered fluid pairs (i, j), i != j, and fluid-wall pairs (i, b) closer than h."""

    fluid: np.ndarray
    wall: np.ndarray


def find_neighbours(pos: np.ndarray, walls: np.ndarray, h: float) -> Neighbours:
    """All pairs within the support h (strictly), found with k-d trees."""
    p = pos[:, :3].astype(np.float64)
    pairs = cKDTree(p).query_pairs(h * (1 - 1e-6), output_type="ndarray")
    fluid = np.concatenate([pairs, pairs[:, ::-1]]) if len(pairs) else np.zeros((0, 2), int)
    found = cKDTree(walls.astype(np.float64)).query_ball_point(p, r=h * (1 - 1e-6))
    wall = np.array([(i, b) for i, bs in enumerate(found) for b in bs], dtype=np.int64)
    return Neighbours(fluid=fluid, wall=wall.reshape(-1, 2))


def _pair_geometry(a: np.ndarray, b: np.ndarray, pairs: np.ndarray) -> tuple[np.ndarray, ...]:
    d = a[pairs[:, 0], :3].astype(np.float64) - b[pairs[:, 1], :3].astype(np.float64)
    return d, np.linalg.norm(d, axis=1)


def _sum_rows(values: np.ndarray, rows: np.ndarray, n: int) -> np.ndarray:
    out = np.zeros((n,) + values.shape[1:])
    np.add.at(out, rows, values)
    return out


def density(
    pos: np.ndarray, nb: Neighbours, walls: np.ndarray, psi: np.ndarray, scene: Scene
) -> np.ndarray:
    """rho_i = m (W(0) + sum_j W_ij) + sum_b psi_b W_ib."""
    h, m, n = scene.support, scene.particle_mass, len(pos)
    _, r = _pair_geometry(pos, pos, nb.fluid)
    _, rb = _pair_geometry(pos, walls, nb.wall)
    rho = m * (cubic_kernel(np.zeros(1), h)[0] + _sum_rows(cubic_kernel(r, h), nb.fluid[:, 0], n))
    return rho + _sum_rows(psi[nb.wall[:, 1]] * cubic_kernel(rb, h), nb.wall[:, 0], n)


def viscous_accel(
    pos: np.ndarray,
    vel: np.ndarray,
    nb: Neighbours,
    walls: np.ndarray,
    psi: np.ndarray,
    scene: Scene,
) -> np.ndarray:
    """10 nu sum_j (m / rho0) (v_ij . x_ij) / (r^2 + 0.01 h^2) grad W_ij + walls.

    The walls are at rest, weighted by psi_b / rho0 in place of m / rho0 and use
    ``scene.wall_viscosity``: friction
    with the tank, which slows the dam-break front as the experiment's floor did.
    """
    h, n = scene.support, len(pos)
    eps = VISCOSITY_EPS * h * h
    d, r = _pair_geometry(pos, pos, nb.fluid)
    vij = vel[nb.fluid[:, 0], :3].astype(np.float64) - vel[nb.fluid[:, 1], :3]
    coef = scene.particle_mass * np.sum(vij * d, axis=1) / (r * r + eps)
    lap = _sum_rows(coef[:, None] * cubic_kernel_gradient(d, r, h), nb.fluid[:, 0], n)
    db, rb = _pair_geometry(pos, walls, nb.wall)
    vi = vel[nb.wall[:, 0], :3].astype(np.float64)
    coef_b = psi[nb.wall[:, 1]] * np.sum(vi * db, axis=1) / (rb * rb + eps)
    visc = 10.0 * scene.viscosity
    lap_b = _sum_rows(coef_b[:, None] * cubic_kernel_gradient(db, rb, h), nb.wall[:, 0], n)
    wall = 10.0 * scene.wall_viscosity * lap_b
    return (visc * lap + wall) / scene.rest_density


def nonpressure_accel(
    pos: np.ndarray,
    vel: np.ndarray,
    nb: Neighbours,
    walls: np.ndarray,
    psi: np.ndarray,
    gravity: np.ndarray,
    scene: Scene,
) -> np.ndarray:
    """a_np = g + the last viscous step's share of :func:`viscous_accel`."""
    g = np.asarray(gravity, dtype=np.float64)[None, :3]
    return g + viscous_accel(pos, vel, nb, walls, psi, scene) / scene.viscosity_steps


def diffuse_velocity(vel: np.ndarray, viscous: np.ndarray, scene: Scene) -> np.ndarray:
    """One explicit viscous step, dt / viscosity_steps long, at frozen positions, from
    the velocities' :func:`viscous_accel`."""
    return vel[:, :3] + scene.dt / scene.viscosity_steps * viscous


def pressure_accel(
    pos: np.ndarray,
    p: np.ndarray,
    nb: Neighbours,
    walls: np.ndarray,
    psi: np.ndarray,
    scene: Scene,
) -> np.ndarray:
    """Symmetric pressure acceleration at x(t) plus Akinci's wall term."""
    h, n = scene.support, len(pos)
    inv = 1.0 / scene.rest_density**2
    d, r = _pair_geometry(pos, pos, nb.fluid)
    pij = (p[nb.fluid[:, 0]].astype(np.float64) + p[nb.fluid[:, 1]]) * scene.particle_mass * inv
    acc = -_sum_rows(pij[:, None] * cubic_kernel_gradient(d, r, h), nb.fluid[:, 0], n)
    db, rb = _pair_geometry(pos, walls, nb.wall)
    pb = psi[nb.wall[:, 1]] * p[nb.wall[:, 0]].astype(np.float64) * inv
    return acc - _sum_rows(pb[:, None] * cubic_kernel_gradient(db, rb, h), nb.wall[:, 0], n)


def wall_gradient_sum(
    pos: np.ndarray, wall_pairs: np.ndarray, walls: np.ndarray, psi: np.ndarray, scene: Scene
) -> np.ndarray:
    """sum_b psi_b grad W_ib per fluid particle, (n, 3).

    The wall factor of the pressure acceleration at x(t) (a_p,i gets -p_i / rho0^2 times
    it, see :func:`pressure_accel`); the kernels compute it once per substep, before the
    pressure loop (twin of the ``wall_grad`` buffer of ``nonpressure_accel``).
    """
    db, rb = _pair_geometry(pos, walls, wall_pairs)
    terms = psi[wall_pairs[:, 1], None] * cubic_kernel_gradient(db, rb, scene.support)
    return _sum_rows(terms, wall_pairs[:, 0], len(pos))


def predict(
    pos: np.ndarray,
    vel: np.ndarray,
    accel: np.ndarray,
    scene: Scene,
    damping: float = 0.0,
) -> tuple[np.ndarray, np.ndarray]:
    """v* = (1 - damping) (v + dt a), x* = x + dt v*, then the wall clamp."""
    dt = scene.dt
    v = (vel[:, :3].astype(np.float64) + dt * accel) * (1.0 - damping)
    x = pos[:, :3].astype(np.float64) + dt * v
    margin = WALL_MARGIN * scene.spacing
    lo = np.asarray(scene.tank.lo) + margin
    hi = np.asarray(scene.tank.hi) - margin
    v = np.where(x < lo, np.maximum(v, 0.0), v)
    v = np.where(x > hi, np.minimum(v, 0.0), v)
    return np.clip(x, lo, hi), v


def update_pressure(
    rho_pred: np.ndarray, p: np.ndarray, delta: float, scene: Scene
) -> tuple[np.ndarray, float]:
    """p <- max(0, p + delta (rho* - rho0)); also the max relative compression."""
    err = rho_pred - scene.rest_density
    p_new = np.maximum(p + delta * err, 0.0)
    return p_new, float(max(0.0, np.max(err) / scene.rest_density))


def wall_pressure_forces(
    pos: np.ndarray,
    p: np.ndarray,
    wall_pairs: np.ndarray,
    walls: np.ndarray,
    psi: np.ndarray,
    scene: Scene,
) -> np.ndarray:
    """Force (N) of the fluid on each boundary particle through Akinci's pressure term.

    The solver accelerates fluid particle i by -psi_b p_i / rho0^2 grad W_ib for each
    boundary particle b (see :func:`pressure_accel`); by Newton's third law b feels
    F_b = sum_i m psi_b p_i / rho0^2 grad W_ib. Summed over a patch of the floor and
    divided by its area this is the pressure a gauge in the floor would read, which is
    what a hydrostatic test should compare with rho0 g H (the particle pressures
    themselves are iteration-accumulated corrections, not a clean measure).

    Parameters
    ----------
    pos, p : (n, 3), (n,) arrays
        Fluid positions and the pressures the solver used at them.
    wall_pairs : (k, 2) int array
        (fluid i, boundary b) pairs closer than h (e.g. ``Neighbours.wall``).
    walls, psi : (m, 3), (m,) arrays
        Boundary particles and their Akinci weights.

    Returns
    -------
    (m, 3) float64 array of forces on the boundary particles.
    """
    db, rb = _pair_geometry(pos, walls, wall_pairs)
    coef = scene.particle_mass * psi[wall_pairs[:, 1]].astype(np.float64) * p[wall_pairs[:, 0]]
    forces = (coef / scene.rest_density**2)[:, None] * cubic_kernel_gradient(db, rb, scene.support)
    return _sum_rows(forces, wall_pairs[:, 1], len(walls))
