"""Eq. 2 with a nearest-neighbour bandwidth chosen by cross-validation (docs/player-models.md).

Eq. 2's triangular kernel with one radius r answers for a vertex only where a visited
vertex lies within r. On the liquid, the states growth adds lie far from every state the
crowd visited (tens of radii), so eq. 2 answers there with its eps prior alone: the
control frequencies of the whole control group, whatever the state.

Here each vertex gets its own radius, set by the crowd's data around it: the distance to
its k-th nearest visited vertex of the same control group, doubled, so the k nearest
count with weights from 1 (the vertex itself) down to 1/2 (the k-th)::

    K[v, c] = sum over the k nearest visited u (c_u = c_v) of (1 - d(u, v) / r_v) n(u, c),
    r_v = 2 d_k(v)

Where players went often, the k nearest are the vertex and its close neighbours; where
nobody went, they are the nearest states anybody played, however far. k is chosen by the
held-out log-likelihood of whole sessions' controls (K-fold over sessions); the eps prior
of eq. 2 stays, for a group that no session visited. Pure numpy/scipy.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
from scipy.spatial import cKDTree

from app.core.crowd_play import PlayCounts
from app.core.player_models import (
    control_groups,
    crowd_player_model,
    visited_groups,
    with_group_prior,
)
from app.core.session_folds import FOLDS, SessionFolds

#: the neighbour counts cross-validation chooses from
NEIGHBOURS = (1, 2, 4, 8, 16, 32, 64)
#: r_v over the k-th neighbour's distance: that neighbour weighs 1 - 1/2
BANDWIDTH_OVER_KTH = 2.0


def neighbour_counts(
    descriptors: np.ndarray, vertex_control: np.ndarray, control_counts: np.ndarray, neighbours: int
) -> np.ndarray:
    r"""Kernel-weighted control counts with a per-vertex radius, shape (V, N).

    For every vertex v: :math:`\sum_u (1 - d(u, v) / r_v)\, n(u, c)` over the
    ``neighbours`` nearest visited vertices u of v's control group, with
    :math:`r_v = 2 d_k(v)`, the doubled distance to the farthest of them (all weigh 1
    where they coincide with v). A group with fewer visited vertices uses all of them; a
    group with none gives rows of zeros.
    """
    if neighbours < 1:
        raise ValueError(f"neighbours must be at least 1, got {neighbours}")
    descriptors = np.asarray(descriptors, dtype=np.float64)
    counts = np.asarray(control_counts, dtype=np.float64)
    vertex_control = np.asarray(vertex_control)
    scores = np.zeros_like(counts)
    for members, sources in visited_groups(vertex_control, counts):
        if sources.size == 0 or members.size == 0:
            continue
        k = min(neighbours, sources.size)
        distance, nearest = cKDTree(descriptors[sources]).query(descriptors[members], k=k)
        distance, nearest = distance.reshape(members.size, k), nearest.reshape(members.size, k)
        radius = BANDWIDTH_OVER_KTH * distance[:, -1:]
        weight = np.where(radius > 0.0, 1.0 - distance / np.where(radius > 0.0, radius, 1.0), 1.0)
        scores[members] = np.einsum("mk,mkn->mn", weight, counts[sources][nearest])
    return scores


def neighbour_player_model(
    descriptors: np.ndarray,
    vertex_control: np.ndarray,
    control_counts: np.ndarray,
    neighbours: int,
    eps: float,
    *,
    fallback: np.ndarray,
) -> np.ndarray:
    """P(c|v) for every vertex: :func:`neighbour_counts` plus eq. 2's eps prior (the
    group's control counts), normalised; ``fallback[v]`` where a row has no support."""
    vertex_control = np.asarray(vertex_control)
    scores = neighbour_counts(descriptors, vertex_control, control_counts, neighbours)
    return with_group_prior(scores, vertex_control, control_counts, eps, fallback=fallback)


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


@dataclass(frozen=True)
class NeighbourFit:
    """The neighbour count chosen, and the held-out log-likelihood per step of each
    candidate; ``reference_score`` is eq. 2's with its fixed radius on the same folds."""

    neighbours: int
    cv_scores: dict[int, float] = field(default_factory=dict)
    reference_score: float | None = None


def choose_neighbours(
    descriptors: np.ndarray,
    vertex_control: np.ndarray,
    play: PlayCounts,
    n_controls: int,
    eps: float,
    *,
    reference_radius: float | None = None,
    candidates: Sequence[int] = NEIGHBOURS,
    folds: int = FOLDS,
) -> NeighbourFit:
    """The neighbour count whose model best predicts held-out sessions' controls
    (``play``: the sessions' summed counts).

    Sessions are dealt to ``folds`` folds in turn; each fold's controls are scored by
    the model learned from the other folds (mean log-likelihood per step over all
    folds). Ties go to the smaller count. With ``reference_radius``, eq. 2 with that
    fixed radius is scored on the same folds, for comparison. Raises ValueError when no
    trace has a step.
    """
    descriptors = np.asarray(descriptors, dtype=np.float64)
    vertex_control = np.asarray(vertex_control)
    n_vertices = descriptors.shape[0]
    folded = SessionFolds.of(play, n_vertices, n_controls, folds)
    uniform = np.full((n_vertices, n_controls), 1.0 / n_controls)

    def neighbours_model(k: int) -> Callable[[np.ndarray], np.ndarray]:
        return lambda counts: neighbour_player_model(
            descriptors, vertex_control, counts, k, eps, fallback=uniform
        )

    scores = {int(n): folded.score(neighbours_model(int(n))) for n in candidates}
    reference = None
    if reference_radius is not None:
        reference = folded.score(
            lambda counts: crowd_player_model(
                descriptors, vertex_control, counts, reference_radius, eps, fallback=uniform
            )
        )
    best = max(scores, key=lambda n: (scores[n], -n))
    return NeighbourFit(best, scores, reference)
