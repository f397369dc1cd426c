"""Liquid surfaces from particles: SDF grids, occupancy, the clip descriptor and score.

Each frame of a clip becomes a signed distance field on a uniform voxel grid over the
tank, after Zhu and Bridson (2005), "Animating sand as a fluid", section 6:

.. math::

    \\phi(x) = |x - \\bar x| - \\bar r, \\qquad
    \\bar x = \\frac{\\sum_i w_i x_i}{\\sum_i w_i}, \\qquad
    w_i = k(|x - x_i| / R), \\quad k(s) = \\max(0, 1 - s^2)^3,

with every particle of radius r (so :math:`\\bar r = r`) and neighbours within the
search radius R. Far from every particle (no neighbour) the field is the largest value
it takes near one, ``R - r``: the SDF is a narrow band, which is all that occupancy,
blending and meshing need. This module is the NumPy twin of ``app/kernels/sdf.cl``.

Occupancy, the 6 x 6 x 6 descriptor (paper section 5.2) and the score only need the
field, so they live here too, with the uint8 / int8 quantisation the artifact store keeps
(an edge's frames are what dominates its bytes).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from app.core.liquid.scene import Box, Scene

#: voxel edge (m) of the SDF grid per tilt-tank preset: about the particle spacing, so
#: a voxel holds about one particle (tiny 30x20x8, small 48x32x13, paper 80x54x22)
SURFACE_VOXEL = {"tiny": 0.02, "small": 0.0125, "paper": 0.0075}
#: particle radius and neighbour search radius, in particle spacings. The radius makes
#: the zero level set enclose the fluid's own volume n dx^3 (measured on the initial
#: lattice / the settled tank: tiny 1.00 / 1.02, small 1.02 / 1.01; 0.6 loses 4-6 %,
#: 0.8 gains 3-5 %); R = 2 dx is Zhu and Bridson's choice.
PARTICLE_RADIUS = 0.7
SEARCH_RADIUS = 2.0
#: cells per axis of the descriptor grid (paper section 5.2)
DESCRIPTOR_CELLS = 6
#: quantisation levels of the stored fields
_SDF_LEVELS = 127
OCCUPANCY_LEVELS = 255


@dataclass(frozen=True)
class SurfaceGrid:
    """Voxel grid of the SDF: ``shape`` voxels of edge ``voxel`` from ``origin``.

    Voxel (i, j, l) has its centre at ``origin + (i + 0.5, j + 0.5, l + 0.5) * voxel``;
    arrays are indexed [x, y, z] (C order, z fastest).
    """

    origin: tuple[float, float, float]
    voxel: float
    shape: tuple[int, int, int]
    particle_radius: float
    search_radius: float

    @property
    def voxel_volume(self) -> float:
        return self.voxel**3

    @property
    def far_value(self) -> float:
        """Field value where no particle is within the search radius (band edge)."""
        return self.search_radius - self.particle_radius

    def axis_centres(self, axis: int) -> np.ndarray:
        return self.origin[axis] + (np.arange(self.shape[axis]) + 0.5) * self.voxel

    def centres(self) -> np.ndarray:
        """(X*Y*Z, 3) float64 voxel centres in C order."""
        axes = [self.axis_centres(a) for a in range(3)]
        return np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)


def surface_grid(scene: Scene, voxel: float | None = None) -> SurfaceGrid:
    """The SDF grid of a scene: voxels of the preset's size covering its tank.

    The preset is the part of ``scene.name`` after ``/``; ``voxel`` overrides it.
    """
    if voxel is None:
        preset = scene.name.split("/")[-1]
        voxel = SURFACE_VOXEL.get(preset, scene.spacing)
    lo, hi = np.asarray(scene.tank.lo), np.asarray(scene.tank.hi)
    shape = tuple(int(math.ceil((hi[a] - lo[a]) / voxel - 1e-6)) for a in range(3))
    return SurfaceGrid(
        origin=(float(lo[0]), float(lo[1]), float(lo[2])),
        voxel=float(voxel),
        shape=(shape[0], shape[1], shape[2]),
        particle_radius=PARTICLE_RADIUS * scene.spacing,
        search_radius=SEARCH_RADIUS * scene.spacing,
    )


def zhu_bridson_sdf(grid: SurfaceGrid, positions: np.ndarray) -> np.ndarray:
    """Signed distance (m) of the particle surface at every voxel centre.

    Parameters
    ----------
    grid : SurfaceGrid
    positions : (n, 3) array
        Particle positions of one frame.

    Returns
    -------
    (X, Y, Z) float32 array, negative inside the liquid, in ``[-r, R - r]``.
    """
    centres = grid.centres()
    big_r = grid.search_radius
    phi = np.full(len(centres), grid.far_value, dtype=np.float64)
    if len(positions):
        pos = np.asarray(positions, dtype=np.float64)[:, :3]
        pairs = cKDTree(centres).sparse_distance_matrix(
            cKDTree(pos), big_r, output_type="coo_matrix"
        )
        d2 = np.sum((centres[pairs.row] - pos[pairs.col]) ** 2, axis=1)
        w = np.maximum(1.0 - d2 / big_r**2, 0.0) ** 3
        sw = np.bincount(pairs.row, weights=w, minlength=len(centres))
        mean = np.stack(
            [
                np.bincount(pairs.row, weights=w * pos[pairs.col, a], minlength=len(centres))
                for a in range(3)
            ],
            axis=1,
        )
        near = sw > 0
        centroid = mean[near] / sw[near, None]
        phi[near] = np.linalg.norm(centres[near] - centroid, axis=1) - grid.particle_radius
    return phi.reshape(grid.shape).astype(np.float32)


def occupancy(grid: SurfaceGrid, phi: np.ndarray) -> np.ndarray:
    """Occupied fraction of each voxel, ``clip(0.5 - phi / voxel, 0, 1)``.

    A linear ramp of one voxel across the surface: a plane through a voxel's centre
    fills half of it, and the total is the enclosed volume to first order.
    """
    return np.clip(0.5 - np.asarray(phi, dtype=np.float32) / grid.voxel, 0.0, 1.0)


def _axis_overlap(grid: SurfaceGrid, axis: int, edges: np.ndarray) -> np.ndarray:
    """(len(edges) - 1, n_axis) fraction of each voxel of an axis inside each interval."""
    lo = grid.origin[axis] + np.arange(grid.shape[axis]) * grid.voxel
    hi = lo + grid.voxel
    inter = np.minimum(hi[None, :], edges[1:, None]) - np.maximum(lo[None, :], edges[:-1, None])
    return np.clip(inter, 0.0, None) / grid.voxel


def region_volumes(grid: SurfaceGrid, occupancy_frames: np.ndarray, box: Box) -> np.ndarray:
    """Liquid volume (m^3) inside ``box`` of each frame of (k, X, Y, Z) occupancy."""
    w = [_axis_overlap(grid, a, np.array([box.lo[a], box.hi[a]]))[0] for a in range(3)]
    occ = np.asarray(occupancy_frames, dtype=np.float64)
    return np.einsum("kxyz,x,y,z->k", occ, w[0], w[1], w[2]) * grid.voxel_volume


def liquid_volumes(grid: SurfaceGrid, occupancy_frames: np.ndarray) -> np.ndarray:
    """Liquid volume (m^3) of each frame of (k, X, Y, Z) occupancy."""
    occ = np.asarray(occupancy_frames, dtype=np.float64)
    return occ.reshape(len(occ), -1).sum(axis=1) * grid.voxel_volume


def clip_descriptor(grid: SurfaceGrid, tank: Box, occupancy_frames: np.ndarray) -> np.ndarray:
    """The paper's 6 x 6 x 6 shape descriptor, flattened to (216,).

    Each coarse cell of a 6^3 split of the tank gets its occupied fraction averaged over
    the clip's frames; voxels straddling coarse cells count by their overlap, so any
    voxel resolution gives the same descriptor of the same liquid.
    """
    n = DESCRIPTOR_CELLS
    w = [_axis_overlap(grid, a, np.linspace(tank.lo[a], tank.hi[a], n + 1)) for a in range(3)]
    coarse_volume = np.prod([(tank.hi[a] - tank.lo[a]) / n for a in range(3)])
    occ = np.asarray(occupancy_frames, dtype=np.float64).mean(axis=0)
    # contracted one axis at a time (optimize): 4 ms a clip on tiny without a path, 0.06 with
    filled = np.einsum("xyz,ix,jy,lz->ijl", occ, w[0], w[1], w[2], optimize=True)
    filled = filled * grid.voxel_volume
    return (filled / coarse_volume).ravel()


def clip_score(grid: SurfaceGrid, target: Box, occupancy_frames: np.ndarray) -> float:
    """Liquid volume (m^3) inside the target region summed over the clip's frames."""
    return float(region_volumes(grid, occupancy_frames, target).sum())


# ---- quantised storage ---------------------------------------------------------------
def interior_sdf_level(grid: SurfaceGrid) -> int:
    """The deepest stored level: the first at least half a voxel inside the surface."""
    return min(math.ceil(0.5 * grid.voxel * _SDF_LEVELS / grid.search_radius), _SDF_LEVELS)


def quantise_sdf(grid: SurfaceGrid, phi: np.ndarray) -> np.ndarray:
    """int8 SDF in steps of ``R / 127`` (about a sixtieth of a voxel), inside clamped.

    Deeper than half a voxel inside, the Zhu-Bridson field holds the jitter of the
    particles rather than the surface; there :func:`occupancy` is full, so clamping it
    changes no occupancy, score or distance, moves the mesh's crossings by hundredths
    of a voxel, and halves the stored SDF (docs/liquid.md, "Bytes").
    """
    scaled = np.asarray(phi, dtype=np.float32) * (_SDF_LEVELS / grid.search_radius)
    return np.clip(np.rint(scaled), -interior_sdf_level(grid), _SDF_LEVELS).astype(np.int8)


def dequantise_sdf(grid: SurfaceGrid, q: np.ndarray) -> np.ndarray:
    """float32 SDF (m) of an int8 one; float arrays pass through unchanged."""
    if np.issubdtype(q.dtype, np.floating):
        return q.astype(np.float32, copy=False)
    return q.astype(np.float32) * np.float32(grid.search_radius / _SDF_LEVELS)


def quantise_occupancy(occ: np.ndarray) -> np.ndarray:
    """uint8 occupancy in steps of 1/255."""
    return np.rint(np.clip(occ, 0.0, 1.0) * OCCUPANCY_LEVELS).astype(np.uint8)


def dequantise_occupancy(q: np.ndarray) -> np.ndarray:
    """float32 fractions of uint8 occupancy; float arrays pass through unchanged."""
    if np.issubdtype(q.dtype, np.floating):
        return q.astype(np.float32, copy=False)
    return q.astype(np.float32) / np.float32(OCCUPANCY_LEVELS)
