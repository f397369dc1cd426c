"""Triangle meshes of SDF frames (marching cubes, scikit-image) as the renderer draws them."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from skimage.measure import marching_cubes

from app.core.liquid.surface import SurfaceGrid
from app.render.smoothing import SMOOTHING_STEPS, taubin_smooth, vertex_normals

#: how far (in voxels) liquid that touches a tank wall reaches into the wall's surface
WALL_OVERLAP = 0.05


@dataclass(frozen=True)
class LiquidMesh:
    """A closed, outward-wound triangle mesh of one frame, in world coordinates (m).

    Attributes
    ----------
    vertices : (m, 3) float32
    faces : (f, 3) uint32
    on_wall : (m, 3) bool
        The coordinates that put a vertex on a tank wall (the liquid touching it).
    normals : (m, 3) float32 or None
        Smooth shading normals, once :func:`render_mesh` has made them.
    """

    vertices: np.ndarray
    faces: np.ndarray
    on_wall: np.ndarray
    normals: np.ndarray | None = None


def surface_mesh(grid: SurfaceGrid, phi: np.ndarray) -> LiquidMesh:
    """Zero level set of one (X, Y, Z) SDF frame, the liquid meeting the tank's walls.

    The field is padded with one layer of its far (outside) value so that liquid touching
    the tank walls still gives a closed surface, which a dielectric needs to refract. The
    padding alone would close it between the last voxel centre and the wall, leaving a
    thin gap of air along every wall the liquid touches, in which rays reflect until
    the path tracer gives up (dark seams at the walls, docs/render.md). So the vertices
    the padding made are moved onto their wall, ``WALL_OVERLAP`` voxel into it: the
    water's face there is hidden inside the wall, and the wall is what a ray meets.
    Empty when the frame holds no liquid.
    """
    padded = np.pad(np.asarray(phi, dtype=np.float32), 1, constant_values=grid.far_value)
    if padded.min() >= 0.0:
        return LiquidMesh(
            np.zeros((0, 3), np.float32), np.zeros((0, 3), np.uint32), np.zeros((0, 3), bool)
        )
    # scikit-image's default "descent" winds faces outwards from the low (liquid) side,
    # which the dielectric needs to know its inside; vertices in padded voxel units
    index, faces, _, _ = marching_cubes(padded, 0.0)
    # padded index p lies at origin + (p - 0.5) voxel: the walls are p = 0.5 and shape + 0.5
    shape = np.asarray(grid.shape, dtype=np.float64)
    low, high = index < 1.0, index > shape
    index = np.where(low, 0.5 - WALL_OVERLAP, index)
    index = np.where(high, shape + 0.5 + WALL_OVERLAP, index)
    vertices = np.asarray(grid.origin) + (index - 0.5) * grid.voxel
    return LiquidMesh(vertices.astype(np.float32), faces.astype(np.uint32), low | high)


def render_mesh(grid: SurfaceGrid, phi: np.ndarray, steps: int = SMOOTHING_STEPS) -> LiquidMesh:
    """The mesh the renderer draws: smoothed (walls held) and with shading normals."""
    mesh = surface_mesh(grid, phi)
    if len(mesh.faces) == 0:
        return mesh
    vertices = taubin_smooth(mesh.vertices, mesh.faces, steps, held=mesh.on_wall)
    return LiquidMesh(vertices, mesh.faces, mesh.on_wall, vertex_normals(vertices, mesh.faces))
