"""Triangle meshes of SDF frames (marching cubes, scikit-image)."""

from __future__ import annotations

import numpy as np
from skimage.measure import marching_cubes

from app.core.surface import SurfaceGrid


def surface_mesh(grid: SurfaceGrid, phi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Zero level set of one (X, Y, Z) SDF frame in world coordinates (m).

    The field is padded with one layer of its far (outside) value so that liquid touching
    the tank walls still gives a closed surface, which a dielectric needs to refract.

    Returns
    -------
    vertices : (m, 3) float32
    faces : (f, 3) uint32
        Both empty when the frame holds no liquid.
    """
    padded = np.pad(np.asarray(phi, dtype=np.float32), 1, constant_values=grid.far_value)
    if padded.min() >= 0.0:
        return np.zeros((0, 3), np.float32), np.zeros((0, 3), np.uint32)
    # scikit-image's default "descent" winds faces outwards from the low (liquid) side,
    # which the dielectric needs to know its inside
    vertices, faces, _, _ = marching_cubes(padded, 0.0, spacing=(grid.voxel,) * 3)
    # padded index 0 is the centre of a voxel half a voxel before the grid's origin
    vertices += np.asarray(grid.origin) - 0.5 * grid.voxel
    return vertices.astype(np.float32), faces.astype(np.uint32)
