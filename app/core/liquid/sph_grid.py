"""Geometry of the PCISPH solver: uniform grid, cell sort, neighbours, walls.

NumPy reference (twin) of the grid kernels in ``app/kernels/pcisph.cl`` and the set-up
computations done once per scene (wall particles, their volumes, the PCISPH factor).
The kernels sort particles by cell with a counting sort whose ties are broken by the
previous array index; :func:`sort_by_cell` is that order (a stable sort by cell).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from app.core.liquid.pcisph import cubic_kernel, cubic_kernel_gradient
from app.core.liquid.scene import Scene


@dataclass(frozen=True)
class Grid:
    """Uniform grid of cell size h covering the tank plus one cell of margin.

    Cell (cx, cy, cz) has the linear index ``(cz * dims[1] + cy) * dims[0] + cx`` (x
    fastest), so the three cells of a row along x are adjacent in sorted order and the
    27-cell stencil is nine contiguous ranges.
    """

    origin: np.ndarray
    cell_size: float
    dims: tuple[int, int, int]

    @property
    def n_cells(self) -> int:
        return self.dims[0] * self.dims[1] * self.dims[2]


def make_grid(scene: Scene) -> Grid:
    h = scene.support
    lo, hi = np.asarray(scene.tank.lo), np.asarray(scene.tank.hi)
    dims = np.floor((hi - lo + 2 * h) / h).astype(int) + 1
    return Grid(
        origin=(lo - h).astype(np.float32),
        cell_size=h,
        dims=(int(dims[0]), int(dims[1]), int(dims[2])),
    )


def cell_indices(pos: np.ndarray, grid: Grid) -> np.ndarray:
    """Linear cell index of every (n, 3) position, clamped into the grid."""
    inv = np.float32(1.0 / grid.cell_size)
    c = np.floor((pos[:, :3].astype(np.float32) - grid.origin) * inv).astype(np.int64)
    c = np.clip(c, 0, np.asarray(grid.dims) - 1)
    return (c[:, 2] * grid.dims[1] + c[:, 1]) * grid.dims[0] + c[:, 0]


def sort_by_cell(pos: np.ndarray, grid: Grid) -> tuple[np.ndarray, np.ndarray]:
    """Permutation sorting particles by cell (ties by index) and the cell start offsets.

    Returns
    -------
    order : (n,) int array
        ``sorted[s] = unsorted[order[s]]``.
    cell_start : (n_cells + 1,) int array
        Particles of cell c are ``order[cell_start[c]:cell_start[c + 1]]``.
    """
    cells = cell_indices(pos, grid)
    order = np.argsort(cells, kind="stable")
    counts = np.bincount(cells, minlength=grid.n_cells)
    cell_start = np.concatenate([[0], np.cumsum(counts)])
    return order, cell_start


def neighbour_sets(pos: np.ndarray, other: np.ndarray, h: float, *, same: bool) -> list[set[int]]:
    """For each particle, the indices of ``other`` closer than h (itself excluded if ``same``)."""
    tree = cKDTree(other.astype(np.float64))
    found = tree.query_ball_point(pos.astype(np.float64), r=h * (1 - 1e-6))
    return [set(js) - ({i} if same else set()) for i, js in enumerate(found)]


def wall_particles(scene: Scene) -> np.ndarray:
    """Single layer of boundary particles around the tank, (m, 3).

    The layer lies half a spacing outside the inner walls, so the first fluid layer
    (half a spacing inside) is one spacing from it, as in the fluid lattice. Each face is
    a square lattice of spacing close to dx, edges and corners sampled once (Akinci et
    al. 2012 use one layer and compensate its sparseness through the particle volumes).
    """
    half = 0.5 * scene.spacing
    lo, hi = np.asarray(scene.tank.lo) - half, np.asarray(scene.tank.hi) + half
    n = np.maximum(np.round((hi - lo) / scene.spacing).astype(int), 1)
    axes = [np.arange(n[k] + 1) for k in range(3)]
    iz, iy, ix = np.meshgrid(axes[2], axes[1], axes[0], indexing="ij")
    idx = np.stack([ix.ravel(), iy.ravel(), iz.ravel()], axis=1)
    on_wall = np.any((idx == 0) | (idx == n), axis=1)
    return (lo + idx[on_wall] * (hi - lo) / n).astype(np.float32)


def _lattice_offsets(spacing: float, h: float) -> np.ndarray:
    k = math.ceil(h / spacing)
    rng = np.arange(-k, k + 1) * spacing
    return np.stack(np.meshgrid(rng, rng, rng, indexing="ij"), axis=-1).reshape(-1, 3)


def flat_wall_factor(scene: Scene) -> float:
    """Scale gamma of the Akinci volumes that makes a flat wall exactly fill the fluid.

    Akinci's psi_b = rho0 / sum_k W_bk over-fills the density of a lattice particle one
    spacing from a single wall layer (by about 6 % with this kernel), which pushes the
    first fluid layer into the second and keeps the pressure solve from converging. The
    factor restores rho = rho0 for that particle: gamma = (rho0 - rho_fluid) / rho_wall.
    """
    dx, h = scene.spacing, scene.support
    d = _lattice_offsets(dx, h)
    fluid = d[d[:, 1] >= 0]
    plane = d[d[:, 1] == 0]
    wall = plane - np.array([0.0, dx, 0.0])
    rho_fluid = scene.particle_mass * cubic_kernel(np.linalg.norm(fluid, axis=1), h).sum()
    plane_sum = cubic_kernel(np.linalg.norm(plane, axis=1), h).sum()
    rho_wall = scene.rest_density / plane_sum * cubic_kernel(np.linalg.norm(wall, axis=1), h).sum()
    return float((scene.rest_density - rho_fluid) / rho_wall)


def wall_volumes(walls: np.ndarray, scene: Scene) -> np.ndarray:
    """Boundary weights psi_b = gamma rho0 / sum_k W(x_b - x_k) over walls (Akinci 2012).

    A boundary particle contributes ``psi_b W`` to a fluid particle's density and
    ``psi_b`` plays the role of a mass in the pressure force; dividing by the local sum
    corrects for the denser sampling at edges and corners, gamma (see
    :func:`flat_wall_factor`) for the single layer.
    """
    h = scene.support
    tree = cKDTree(walls.astype(np.float64))
    pairs = tree.query_pairs(h * (1 - 1e-6), output_type="ndarray")
    r = np.linalg.norm(walls[pairs[:, 0]] - walls[pairs[:, 1]], axis=1)
    w = cubic_kernel(r, h)
    total = np.full(len(walls), cubic_kernel(np.zeros(1), h)[0], dtype=np.float64)
    np.add.at(total, pairs[:, 0], w)
    np.add.at(total, pairs[:, 1], w)
    return (flat_wall_factor(scene) * scene.rest_density / total).astype(np.float32)


def pcisph_delta(scene: Scene) -> float:
    """PCISPH pressure factor delta (Solenthaler and Pajarola 2009, eq. 8).

    delta = -1 / (beta (-sum grad W . sum grad W - sum grad W . grad W)),
    beta = 2 (dt m / rho0)^2, over a full neighbourhood of the prototype particle on the
    cubic lattice of spacing dx (the initial fluid sampling).
    """
    dx, h = scene.spacing, scene.support
    d = _lattice_offsets(dx, h)
    r = np.linalg.norm(d, axis=1)
    keep = (r > 0) & (r < h)
    grad = cubic_kernel_gradient(d[keep], r[keep], h)
    s = grad.sum(axis=0)
    beta = 2.0 * (scene.dt * scene.particle_mass / scene.rest_density) ** 2
    return float(1.0 / (beta * (s @ s + np.sum(grad * grad))))
