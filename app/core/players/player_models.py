"""Player models P(c|v), the control a player takes at each vertex (paper section 4): row v
of a dense (V, N) array. The heuristic one bootstraps a graph; the crowd ones learn from traces."""

from __future__ import annotations

from collections.abc import Iterable, Sequence

import numpy as np

from app.core.graph.state_graph import edge_index
from app.core.players.model_checks import check_counts, checked_controls

#: One step of a trace: the vertex the player was at and the control they took there.
Trace = Sequence[tuple[int, int]] | np.ndarray


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
    vertex_control = checked_controls(vertex_control, n_controls)
    if not 0.0 <= alpha <= 1.0:
        raise ValueError(f"alpha must lie in [0, 1], got {alpha}")
    model = np.full((vertex_control.size, n_controls), (1.0 - alpha) / n_controls)
    model[np.arange(vertex_control.size), vertex_control] += alpha
    return model


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
