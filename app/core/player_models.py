"""Player models P(c|v), the control a player takes at each vertex (paper section 4): row v
of a dense (V, N) array. The heuristic one bootstraps a graph; the crowd ones learn from traces."""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Sequence
from enum import StrEnum

import numpy as np
import scipy.sparse as sp
from scipy.spatial import cKDTree

from app.core.choices import parse_choice
from app.core.graph import edge_index
from app.core.model_checks import check_counts, check_distributions

#: One step of a trace: the vertex the player was at and the control they took there.
Trace = Sequence[tuple[int, int]] | np.ndarray


class PlayerModelKind(StrEnum):
    """The crowd model sr-crowd learns (docs/player-models.md)."""

    #: the paper's kernel density estimate, with its eps prior (:func:`crowd_player_model`)
    EQ2 = "eq2"
    #: eq. 2's kernel counts under a logit prior over goal features (app.core.choice_model)
    LOGIT = "logit"
    #: eq. 2, its radius the k-th nearest visited vertex's distance (app.core.neighbour_model)
    KNN = "knn"
    #: eq. 2's kernel counts over the heuristic model as a prior (app.core.shrunk_model)
    SHRUNK = "shrunk"
    #: ``shrunk``'s P(c|v) with heuristic players mixed in (app.core.strategies.mixed_weights)
    MIXED = "mixed"
    #: ``mixed``, radius and prior weight scored on the latest publication (shrunk_model)
    MIXED_FORWARD = "mixed-forward"
    #: ``mixed``, steps counted less where the graph has changed since (fresh_evidence)
    MIXED_FRESH = "mixed-fresh"
    #: ``mixed``, its share of heuristic players chosen where players met error (error_share)
    MIXED_ERROR = "mixed-error"
    #: ``mixed``'s two kinds of player, each ranking its own share of growth (strategies)
    MIXED_SPLIT = "mixed-split"
    #: ``mixed-error``, its share applied once the one chosen before held (error_share)
    MIXED_HELD = "mixed-held"


def parse_player_model(name: str) -> PlayerModelKind:
    """The player model called ``name``; :class:`InvalidInput` naming the known ones otherwise."""
    return parse_choice(PlayerModelKind, name, what="player model")


def heuristic_player_model(vertex_control: np.ndarray, n_controls: int, alpha: float) -> np.ndarray:
    r"""Bootstrap model: keep the current control, otherwise pick any (paper eq. 1).

    .. math:: P_h(c|v) = \alpha [c = c_v] + (1 - \alpha) / N

    where :math:`c_v` is the control of the clip that produced :math:`v`. This is the
    form docs/design.md ("Graph algorithms") fixes: the "otherwise" branch picks
    uniformly among all N controls, so each row sums to 1 exactly (eq. 1 as printed does not).

    Parameters
    ----------
    vertex_control : ndarray of int, shape (V,)
        :math:`c_v` of every vertex.
    n_controls : int
        Number of controls N.
    alpha : float
        Probability in [0, 1] of deliberately keeping the current control.

    Returns
    -------
    ndarray, shape (V, N)
    """
    vertex_control = _validated_controls(vertex_control, n_controls)
    if not 0.0 <= alpha <= 1.0:
        raise ValueError(f"alpha must lie in [0, 1], got {alpha}")
    model = np.full((vertex_control.size, n_controls), (1.0 - alpha) / n_controls)
    model[np.arange(vertex_control.size), vertex_control] += alpha
    return model


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
        How often control c was taken at vertex v (:func:`observed_control_counts`).
    radius : float
        Kernel radius r > 0 in descriptor space.
    eps : float
        Prior weight :math:`\epsilon \ge 0`.
    fallback : ndarray, shape (V, N)
        Model for rows without support, typically :func:`heuristic_player_model`.

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
    vertex_control = _validated_controls(vertex_control, n_controls)
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


def control_groups(
    vertex_control: np.ndarray, visited: np.ndarray, n_groups: int
) -> Iterator[tuple[np.ndarray, np.ndarray]]:
    """Per control group (eq. 2 compares a vertex only with vertices reached by the same
    control): the group's vertices, and those of them that were visited."""
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


def observed_player_model(control_counts: np.ndarray, *, fallback: np.ndarray) -> np.ndarray:
    r""":math:`P_{obs}(c|v)` at every visited vertex, ``fallback[v]`` elsewhere.

    Fitted to the very traces it is judged on, this is the best a model that gives each
    vertex one control distribution can do on them: it already holds whatever players
    do at each vertex, including what a per-vertex model cannot explain (a reaction delay
    makes the control at a vertex depend on the vertex before it). Its STATERANK
    prediction bounds how close the learned model's can get (docs/design.md, "Evaluation").

    Parameters
    ----------
    control_counts : ndarray, shape (V, N)
        :func:`observed_control_counts` of the traces.
    fallback : ndarray, shape (V, N)
        Model for vertices no trace visited (a trace's last destination, typically).
    """
    counts = np.asarray(control_counts, dtype=np.float64)
    fallback = np.asarray(fallback, dtype=np.float64)
    if counts.ndim != 2 or fallback.shape != counts.shape:
        raise ValueError(
            f"control_counts {counts.shape} and fallback {fallback.shape} must be one (V, N)"
        )
    check_counts(counts)
    visits = counts.sum(axis=1)
    visited = visits > 0.0
    model = fallback.copy()
    model[visited] = counts[visited] / visits[visited, None]
    return model


def kernel_support(
    descriptors: np.ndarray, vertex_control: np.ndarray, visited: np.ndarray, radius: float
) -> np.ndarray:
    """Whether eq. 2's kernel reaches each vertex: a visited u with c_u = c_v nearer than r.

    A vertex without support gets the control frequencies of its whole control group
    (the eps prior of :func:`crowd_player_model`) whatever its state, so the share of
    predicted play on such vertices says how much of a prediction is the prior's guess.

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


def trace_edges(traces: Iterable[Trace], n_vertices: int, n_controls: int) -> np.ndarray:
    """Edge id ``v * N + c`` of every step of every trace, in order, as one int64 array.

    Raises ValueError if a step names a vertex or control outside the graph.
    """
    parts = [np.asarray(trace, dtype=np.int64).reshape(-1, 2) for trace in traces]
    steps = np.concatenate(parts) if parts else np.empty((0, 2), dtype=np.int64)
    vertex, control = steps[:, 0], steps[:, 1]
    if steps.size and not (vertex.min() >= 0 and vertex.max() < n_vertices):
        raise ValueError(f"a trace visits a vertex outside 0..{n_vertices - 1}")
    if steps.size and not (control.min() >= 0 and control.max() < n_controls):
        raise ValueError(f"a trace takes a control outside 0..{n_controls - 1}")
    return np.asarray(edge_index(vertex, control, n_controls))


def observed_control_counts(
    traces: Iterable[Trace], n_vertices: int, n_controls: int
) -> np.ndarray:
    """How often each control was taken at each vertex: int64 array of shape (V, N).

    Row sums are the visit counts of the vertices, so this array carries both
    :math:`P_{obs}(c|v)` and :math:`P_{obs}(v)` of eq. 2.
    """
    edges = trace_edges(traces, n_vertices, n_controls)
    return np.bincount(edges, minlength=n_vertices * n_controls).reshape(n_vertices, n_controls)


def mean_session_length(traces: Iterable[Trace]) -> float:
    """Mean number of steps per session, L, of traces already vetted (the evaluation's).

    Growth does not restart with it: a single long trace moves the mean anywhere, so
    growth takes :func:`robust_session_length`. Empty traces are not sessions and are
    skipped. Raises ValueError when no trace has a step.
    """
    lengths = [len(trace) for trace in traces if len(trace) > 0]
    if not lengths:
        raise ValueError("no trace has a step; the mean session length is undefined")
    return float(np.mean(lengths))


#: the shortest session length L a restart rate is estimated at: rho = 1/L is at most 1/2
MIN_SESSION_STEPS = 2.0


def robust_session_length(
    traces: Iterable[Trace], *, default: float, ceiling: float, floor: float = MIN_SESSION_STEPS
) -> float:
    r"""Session length L for STATERANK's restart rate :math:`\rho = 1/L`, robust to outliers.

    STATERANK ends a session with probability :math:`\rho` at every step, so under its own
    model session lengths are geometric (on 1, 2, ...) with mean :math:`L = 1/\rho`. The
    geometric distribution whose median is :math:`m` has

    .. math:: \rho = 1 - 2^{-1/m}, \qquad L = 1 / (1 - 2^{-1/m}) \approx m / \ln 2 + 1/2,

    and that is the estimate, with :math:`m` the median length of the non-empty traces.
    It estimates the mean of geometric sessions (the bots' and, to first order, players')
    like the sample mean does, but a median moves by at most one rank per added trace,
    while the mean follows a single huge trace anywhere: one player's two 85,000-step
    traces set :math:`L` to 85,000, and STATERANK, whose cold start needs about
    :math:`L \ln(1/tol)` iterations, then missed convergence on every epoch.

    The result is clamped to ``[floor, ceiling]``, so the restart rate always lies in
    ``[1/ceiling, 1/floor]`` whatever the traces (or ``default``) say: ``ceiling`` bounds
    STATERANK's cost (900 steps: about 21,000 iterations at ``tol`` 1e-10), ``floor``
    keeps a session longer than the single step from the start vertex.

    Parameters
    ----------
    traces : iterable of (n, 2) traces
        Played sessions; empty ones are not sessions and are skipped.
    default : float
        L before any trace has a step (the configured mean session length).
    ceiling : float
        Largest L returned (the smallest restart rate).
    floor : float
        Smallest L returned, at least 1.

    Returns
    -------
    float
        L, in steps.
    """
    lengths = [len(trace) for trace in traces if len(trace) > 0]
    median = float(np.median(lengths)) if lengths else None
    return session_length_of_median(median, default=default, ceiling=ceiling, floor=floor)


def session_length_of_median(
    median: float | None, *, default: float, ceiling: float, floor: float = MIN_SESSION_STEPS
) -> float:
    """:func:`robust_session_length` of sessions whose median length is ``median`` (None:
    no session), for callers that hold the sessions' lengths summed, not the sessions."""
    if not 1.0 <= floor <= ceiling:
        raise ValueError(f"need 1 <= floor <= ceiling, got floor {floor} and ceiling {ceiling}")
    # 1 / (1 - 2^(-1/m)), without cancellation
    estimate = default if median is None else 1.0 / -np.expm1(-np.log(2.0) / median)
    return float(np.clip(estimate, floor, ceiling))


def _validated_controls(vertex_control: np.ndarray, n_controls: int) -> np.ndarray:
    if n_controls < 1:
        raise ValueError(f"n_controls must be at least 1, got {n_controls}")
    vertex_control = np.asarray(vertex_control)
    if vertex_control.ndim != 1:
        raise ValueError(f"vertex_control must be 1-D, got shape {vertex_control.shape}")
    if vertex_control.size and not np.issubdtype(vertex_control.dtype, np.integer):
        raise ValueError(f"vertex_control must hold integers, got dtype {vertex_control.dtype}")
    if vertex_control.size and not 0 <= vertex_control.min() <= vertex_control.max() < n_controls:
        raise ValueError(f"vertex_control holds controls outside 0..{n_controls - 1}")
    return vertex_control.astype(np.int64, copy=False)
