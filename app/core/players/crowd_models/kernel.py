"""Eq. 2's triangular kernel over shape descriptors, per control group: the evidence it
weighs, where it reaches, and how far it would have to reach (docs/player-models.md).

Eq. 2 compares a vertex only with vertices reached by the same control, and weighs a
visited one by ``k_tri(r, d) = max(0, 1 - d/r)`` of their descriptor distance. The crowd
models build on these counts; the experiment reads the reach, to say how much of a
prediction is the kernel's and how much its prior's guess. Pure numpy/scipy.
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np
import scipy.sparse as sp
from scipy.spatial import cKDTree


def control_groups(
    vertex_control: np.ndarray, visited: np.ndarray, n_groups: int
) -> Iterator[tuple[np.ndarray, np.ndarray]]:
    """Per control group: the group's vertices, and those of them that were visited."""
    for group in range(n_groups):
        in_group = vertex_control == group
        yield np.flatnonzero(in_group), np.flatnonzero(in_group & visited)


def visited_groups(
    vertex_control: np.ndarray, counts: np.ndarray
) -> Iterator[tuple[np.ndarray, np.ndarray]]:
    """:func:`control_groups` where a vertex was visited when its row of the (V, N)
    control ``counts`` is not all zero."""
    return control_groups(vertex_control, counts.sum(axis=1) > 0.0, counts.shape[1])


def kernel_counts(
    descriptors: np.ndarray, vertex_control: np.ndarray, control_counts: np.ndarray, radius: float
) -> np.ndarray:
    r"""Eq. 2's evidence without its prior: :math:`\sum_{u,\ c_u = c_v} k_{tri}(r, \lVert
    d_u - d_v \rVert) \, n(u, c)` for every vertex v and control c, shape (V, N).

    Per control group, one KD-tree ball query between the group's vertices and its visited
    vertices. A vertex's own visits count fully (distance 0); a row of zeros means no
    visited vertex of its group lies within ``radius``.
    """
    descriptors = np.asarray(descriptors, dtype=np.float64)
    counts = np.asarray(control_counts, dtype=np.float64)
    vertex_control = np.asarray(vertex_control)
    scores = np.zeros_like(counts)
    for members, sources in visited_groups(vertex_control, counts):
        if sources.size == 0:
            continue
        pairs = cKDTree(descriptors[members]).sparse_distance_matrix(
            cKDTree(descriptors[sources]), radius, output_type="ndarray"
        )
        kernel = sp.csr_array(
            (1.0 - pairs["v"] / radius, (pairs["i"], pairs["j"])),
            shape=(members.size, sources.size),
        )
        scores[members] = kernel @ counts[sources]
    return scores


def kernel_support(
    descriptors: np.ndarray, vertex_control: np.ndarray, visited: np.ndarray, radius: float
) -> np.ndarray:
    """Whether eq. 2's kernel reaches each vertex: a visited u with c_u = c_v nearer than r.

    A vertex without support gets the control frequencies of its whole control group
    (eq. 2's eps prior) whatever its state, so the share of predicted play on such
    vertices says how much of a prediction is the prior's guess.

    Returns
    -------
    ndarray of bool, shape (V,)
    """
    descriptors = np.asarray(descriptors, dtype=np.float64)
    visited = np.asarray(visited, dtype=bool)
    if descriptors.ndim != 2 or visited.shape != (descriptors.shape[0],):
        raise ValueError(
            f"descriptors {descriptors.shape} must be (V, D) and visited {visited.shape} (V,)"
        )
    if radius <= 0.0:
        raise ValueError(f"radius must be positive, got {radius}")
    vertex_control = np.asarray(vertex_control)
    if vertex_control.shape != visited.shape:
        raise ValueError(f"vertex_control {vertex_control.shape} and visited differ in shape")
    # eq. 2's evidence of one visit at every visited vertex, in every control's column;
    # the kernel max(0, 1 - x/r) is 0 at x = r, so support needs x strictly below r
    groups = int(vertex_control.max()) + 1 if vertex_control.size else 1
    one_visit = np.repeat(visited[:, None].astype(np.float64), groups, axis=1)
    return kernel_counts(descriptors, vertex_control, one_visit, radius).sum(axis=1) > 0.0


def nearest_visited_distance(
    descriptors: np.ndarray, vertex_control: np.ndarray, visited: np.ndarray
) -> np.ndarray:
    """Per vertex, the descriptor distance to the nearest visited vertex of its control
    group (0 at a visited vertex, inf in a group nobody visited): how far a kernel must
    reach to answer there from the crowd's choices."""
    descriptors = np.asarray(descriptors, dtype=np.float64)
    vertex_control = np.asarray(vertex_control)
    distance = np.full(vertex_control.size, np.inf)
    groups = int(vertex_control.max()) + 1 if vertex_control.size else 0
    for members, sources in control_groups(vertex_control, np.asarray(visited, bool), groups):
        if sources.size:
            distance[members] = cKDTree(descriptors[sources]).query(descriptors[members])[0]
    return distance
