"""Smoothing the liquid's triangle mesh for rendering, without swelling or shrinking it.

Marching cubes on a grid of about one voxel per particle gives a faceted surface: thin
sheets and drops read as crumpled foil, not water. Taubin's two-step smoothing (a
Laplacian step that shrinks, then a negative one that grows back) removes the facets and
keeps the enclosed volume within a fraction of a percent, where plain Laplacian
smoothing would shrink every drop (docs/render.md, "Smooth water"). Only what is
rendered changes: the SDF frames that growth compares and blends are untouched.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

#: Taubin's shrinking and growing factors (pass band about 0.1 of the mesh's frequencies)
TAUBIN_SHRINK, TAUBIN_GROW = 0.5, -0.53
#: smoothing steps per frame (each one shrink and one grow)
SMOOTHING_STEPS = 10


def _neighbour_mean(faces: np.ndarray, n_vertices: int) -> sp.csr_matrix:
    """The sparse operator taking each vertex to the mean of its edge neighbours."""
    f = np.asarray(faces, dtype=np.int64)
    rows = np.concatenate([f[:, 0], f[:, 1], f[:, 2], f[:, 1], f[:, 2], f[:, 0]])
    cols = np.concatenate([f[:, 1], f[:, 2], f[:, 0], f[:, 0], f[:, 1], f[:, 2]])
    adjacency = sp.csr_matrix((np.ones(len(rows)), (rows, cols)), shape=(n_vertices, n_vertices))
    adjacency.data[:] = 1.0  # an edge shared by two faces counts once
    degree = np.asarray(adjacency.sum(axis=1)).ravel()
    return sp.csr_matrix(sp.diags(1.0 / np.maximum(degree, 1.0)) @ adjacency)


def taubin_smooth(
    vertices: np.ndarray,
    faces: np.ndarray,
    steps: int = SMOOTHING_STEPS,
    held: np.ndarray | None = None,
) -> np.ndarray:
    """(m, 3) float32 vertices after ``steps`` Taubin steps.

    ``held`` is an (m, 3) bool mask of coordinates that keep their value (the liquid's
    contact with a tank wall stays on the wall, and slides along it).
    """
    v = np.asarray(vertices, dtype=np.float64)
    if steps <= 0 or len(faces) == 0:
        return v.astype(np.float32)
    fixed = v.copy()
    mean = _neighbour_mean(faces, len(v))
    for _ in range(steps):
        for factor in (TAUBIN_SHRINK, TAUBIN_GROW):
            v = v + factor * (mean @ v - v)
            if held is not None:
                v[held] = fixed[held]
    return v.astype(np.float32)


def vertex_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """(m, 3) float32 unit normals, each the area-weighted mean of its faces' normals.

    A vertex of faces without area only (marching cubes makes a few where the field is
    exactly zero) is never hit by a ray; it gets +y, so that no normal is undefined.
    """
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    face_normals = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    normals = np.zeros_like(v)
    for corner in range(3):
        np.add.at(normals, f[:, corner], face_normals)
    length = np.linalg.norm(normals, axis=1, keepdims=True)
    flat = length[:, 0] == 0.0
    normals[flat], length[flat] = (0.0, 1.0, 0.0), 1.0
    return (normals / length).astype(np.float32)


def mesh_volume(vertices: np.ndarray, faces: np.ndarray) -> float:
    """Volume enclosed by a closed, outward-wound triangle mesh (divergence theorem)."""
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    a, b, c = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
    return float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0)
