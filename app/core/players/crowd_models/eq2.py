"""``eq2``: the paper's kernel density estimate of P(c|v), with its eps prior
(docs/player-models.md, "`eq2`"). It chooses nothing: its radius is the dynamics', its
prior weight ``SRG_CROWD_EPS``. Pure numpy/scipy.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from app.core.players.crowd_models.estimator import CrowdGraph, CrowdPlay
from app.core.players.crowd_models.kernel import kernel_counts
from app.core.players.kinds import PlayerModelKind
from app.core.players.model_checks import check_counts, check_distributions, checked_controls


def crowd_player_model(
    descriptors: np.ndarray,
    vertex_control: np.ndarray,
    control_counts: np.ndarray,
    radius: float,
    eps: float,
    *,
    fallback: np.ndarray,
) -> np.ndarray:
    r"""Player model learned from traces by kernel density estimation (paper eq. 2).

    .. math::

        P(c|v) \propto \sum_{u \in V,\ c_u = c_v} w_u\, P_{obs}(c|u)\, P_{obs}(u),
        \qquad w_u = k_{tri}(r, \lVert d_u - d_v \rVert_2) + \epsilon,
        \qquad k_{tri}(r, x) = \max(0, 1 - x/r).

    :math:`P_{obs}(c|u)` normalises the control counts at :math:`u` and :math:`P_{obs}(u)`
    is :math:`u`'s share of all visits, so their product is ``counts[u, c] / total`` and
    only visited vertices contribute. Players are assumed to act alike in states that look
    alike (descriptor distance, eq. 7), separately for each control :math:`c_v` they were
    holding; the :math:`\epsilon` term is a prior that lets the model answer for vertices
    far from every visited one, by the control frequencies of their whole control group.

    Evaluated for all vertices at once: per control group, one KD-tree ball query (its
    vertices against its visited ones) gives the kernel part, one sum of its counts the prior.

    Parameters
    ----------
    descriptors : ndarray, shape (V, D)
        Shape descriptor :math:`d_v` of every vertex.
    vertex_control : ndarray of int, shape (V,)
        :math:`c_v` of every vertex.
    control_counts : ndarray, shape (V, N)
        How often control c was taken at vertex v
        (:func:`~app.core.players.player_models.observed_control_counts`).
    radius : float
        Kernel radius r > 0 in descriptor space.
    eps : float
        Prior weight :math:`\epsilon \ge 0`.
    fallback : ndarray, shape (V, N)
        Model for rows without support, typically
        :func:`~app.core.players.player_models.heuristic_player_model`.

    Returns
    -------
    ndarray, shape (V, N)
        Row v is :math:`P(\cdot|v)`. A row without support (no visited vertex shares
        :math:`c_v`, or ``eps`` is 0 and none lies within ``radius``) is ``fallback[v]``.

    References
    ----------
    M. Stanton et al. Self-refining games using player analytics. ACM Trans. Graph. 33(4),
    2014, section 4.2.
    """
    descriptors = np.asarray(descriptors, dtype=np.float64)
    counts = np.asarray(control_counts, dtype=np.float64)
    fallback = np.asarray(fallback, dtype=np.float64)
    if descriptors.ndim != 2:
        raise ValueError(f"descriptors must be 2-D (V, D), got shape {descriptors.shape}")
    n_vertices = descriptors.shape[0]
    if counts.ndim != 2 or counts.shape[0] != n_vertices:
        raise ValueError(f"control_counts must be ({n_vertices}, N), got shape {counts.shape}")
    n_controls = counts.shape[1]
    vertex_control = checked_controls(vertex_control, n_controls)
    if vertex_control.size != n_vertices:
        raise ValueError(f"vertex_control has {vertex_control.size} entries, expected {n_vertices}")
    if fallback.shape != counts.shape:
        raise ValueError(f"fallback must have shape {counts.shape}, got {fallback.shape}")
    check_distributions(fallback, "fallback")
    check_counts(counts)
    if radius <= 0.0:
        raise ValueError(f"radius must be positive, got {radius}")
    if eps < 0.0:
        raise ValueError(f"eps must be non-negative, got {eps}")

    scores = kernel_counts(descriptors, vertex_control, counts, radius)
    return with_group_prior(scores, vertex_control, counts, eps, fallback=fallback)


def with_group_prior(
    evidence: np.ndarray,
    vertex_control: np.ndarray,
    control_counts: np.ndarray,
    eps: float,
    *,
    fallback: np.ndarray,
) -> np.ndarray:
    """Kernel evidence (V, N) plus eq. 2's eps prior, the control counts of each vertex's
    whole control group, normalised per row; ``fallback[v]`` where a row has no support."""
    scores = np.array(evidence, dtype=np.float64, copy=True)
    counts = np.asarray(control_counts, dtype=np.float64)
    for group in range(counts.shape[1]):
        in_group = vertex_control == group
        group_counts = counts[in_group].sum(axis=0)
        if group_counts.sum() > 0.0:
            scores[in_group] += eps * group_counts
    totals = scores.sum(axis=1)
    supported = totals > 0.0
    model = np.array(fallback, dtype=np.float64, copy=True)
    model[supported] = scores[supported] / totals[supported, None]
    return model


class Eq2:
    """The paper's eq. 2, as it is printed: nothing to fit."""

    kind: ClassVar[PlayerModelKind] = PlayerModelKind.EQ2
    reads_publications: ClassVar[bool] = False

    def fit(self, graph: CrowdGraph, play: CrowdPlay) -> FittedEq2:
        return FittedEq2(play)


@dataclass(frozen=True)
class FittedEq2:
    """Eq. 2 over the sessions of ``play``."""

    play: CrowdPlay
    #: eq. 2 ranks for the crowd alone
    unseen_share: float | None = None

    def player_model(self, graph: CrowdGraph) -> np.ndarray:
        return crowd_player_model(
            graph.descriptors,
            graph.vertex_control,
            self.play.counts(graph),
            graph.radius,
            graph.eps,
            fallback=graph.heuristic,
        )

    def figures(self) -> None:
        return None
