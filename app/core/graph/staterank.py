"""STATERANK: how often players are expected to be at each vertex and on each edge.

The paper (section 3) ranks blend edges by their *expected* error P(e) err(e). P(e) comes
from the stationary distribution of the Markov chain that a player model P(c|v) induces on
the state graph; like PageRank (Page et al. 1999), the chain teleports, here back to the
start vertex at the end of a session, which makes that distribution unique.

Everything here works on plain edge arrays (``src``, ``dst``, ``prob``) so it runs on any
graph layout; :meth:`app.core.graph.state_graph.StateGraph.edge_arrays` gives them for a
state graph.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from app.core.graph.state_graph import edge_vertex_control

#: how far a vertex's outgoing probabilities may sum away from 1 (float round-off only)
ROW_SUM_ATOL = 1e-8
#: default iteration budget: a cold start at restart rate 1/L needs about L ln(1/tol)
STATERANK_MAX_ITER = 100_000


class StateRankConvergenceError(RuntimeError):
    """Power iteration did not reach ``tol`` within ``max_iter`` iterations."""

    def __init__(self, iterations: int, residual: float) -> None:
        super().__init__(
            f"STATERANK did not converge in {iterations} iterations (last L1 change {residual:.3e})"
        )
        self.iterations = iterations
        self.residual = residual


@dataclass(frozen=True)
class StateRankResult:
    """Stationary vertex distribution ``pi`` (sums to 1) and how it was reached.

    ``iterations`` counts matrix-vector products; ``residual`` is the L1 change of the last
    one, below ``tol`` on success.
    """

    pi: np.ndarray
    iterations: int
    residual: float


def staterank(
    src: np.ndarray,
    dst: np.ndarray,
    prob: np.ndarray,
    n_vertices: int,
    start: int,
    restart: float,
    *,
    warm_start: np.ndarray | None = None,
    tol: float = 1e-10,
    max_iter: int = STATERANK_MAX_ITER,
) -> StateRankResult:
    r"""Stationary distribution of the player's walk over the state graph (STATERANK).

    At each step the player at vertex :math:`v` takes edge :math:`e = (v \to w)` with
    probability ``prob[e]`` = :math:`P(c|v)`; with probability :math:`\rho` (``restart``)
    the session ends instead and the next one begins at ``start``. With
    :math:`P_{vw} = \sum_{e: v \to w} P(e|v)` (parallel edges add) the visit distribution
    is the unique solution of

    .. math:: \pi = (1 - \rho) P^T \pi + \rho\, e_{start}, \qquad \sum_v \pi_v = 1,

    the personalised PageRank of Page et al. (1999) with damping :math:`1 - \rho` and all
    teleportation to the start vertex (Stanton et al. 2014, section 3). A vertex without
    outgoing edges (a dangling vertex) ends the session: its mass also returns to
    ``start``. In a state graph every vertex has N edges, so that case does not arise there.
    Taking :math:`\rho = 1/L`, with :math:`L` the mean session length in steps, makes the
    expected session last :math:`L` steps, which is what players do.

    The solution is found by power iteration with :math:`P^T` in CSR form, built once.
    The error shrinks at least by :math:`1 - \rho` per step, so a cold start needs about
    :math:`L \ln(1/tol)` iterations; after a small graph change, starting from the previous
    ``pi`` needs far fewer.

    Parameters
    ----------
    src, dst : ndarray of int, shape (E,)
        Source and destination vertex of each edge.
    prob : ndarray of float, shape (E,)
        Probability of taking each edge from its source. For every vertex with outgoing
        edges these sum to 1.
    n_vertices : int
        Number of vertices V; vertices are ``0 .. V-1``.
    start : int
        The vertex every session starts at.
    restart : float
        Probability :math:`\rho \in (0, 1]` that a step ends the session.
    warm_start : ndarray of float, shape (V',), V' <= V, optional
        Initial guess, typically the previous ``pi`` of a graph that has since grown by
        ``V - V'`` vertices: it is padded with zeros and renormalised. Default: all mass
        at ``start``, where every session begins.
    tol : float
        Stop when the L1 change of ``pi`` in one iteration falls below ``tol``.
    max_iter : int
        Give up after this many iterations.

    Returns
    -------
    StateRankResult

    Raises
    ------
    ValueError
        If the arrays or parameters are inconsistent (shapes, indices out of range,
        negative probabilities, rows not summing to 1, ``restart`` outside (0, 1]).
    StateRankConvergenceError
        If the L1 change is still at least ``tol`` after ``max_iter`` iterations.

    References
    ----------
    L. Page, S. Brin, R. Motwani, T. Winograd. The PageRank citation ranking: bringing order
    to the web. Stanford InfoLab, 1999.
    M. Stanton, B. Humberston, B. Kase, J. F. O'Brien, K. Fatahalian, A. Treuille.
    Self-refining games using player analytics. ACM Trans. Graph. 33(4), 2014, section 3.
    """
    src, dst, prob = _validated_edges(src, dst, prob, n_vertices)
    if not 0 <= start < n_vertices:
        raise ValueError(f"start {start} is not a vertex of a graph with {n_vertices} vertices")
    if not 0.0 < restart <= 1.0:
        raise ValueError(f"restart must lie in (0, 1], got {restart}")
    if tol <= 0.0:
        raise ValueError(f"tol must be positive, got {tol}")
    if max_iter < 1:
        raise ValueError(f"max_iter must be at least 1, got {max_iter}")

    # (1 - rho) P^T, with parallel edges summed by the COO -> CSR conversion.
    walk = sp.csr_array(
        ((1.0 - restart) * prob, (dst, src)), shape=(n_vertices, n_vertices), dtype=np.float64
    )
    pi = _initial_pi(warm_start, n_vertices, start)
    residual = np.inf
    for iteration in range(1, max_iter + 1):
        new = walk @ pi
        # Whatever did not follow an edge (the restart share, dangling vertices) goes back
        # to the start; adding the shortfall also keeps round-off from drifting the sum.
        new[start] += 1.0 - new.sum()
        residual = float(np.abs(new - pi).sum())
        pi = new
        if residual < tol:
            return StateRankResult(pi=pi, iterations=iteration, residual=residual)
    raise StateRankConvergenceError(max_iter, residual)


def edge_probabilities(pi: np.ndarray, src: np.ndarray, prob: np.ndarray) -> np.ndarray:
    r"""Probability of traversing each edge on a step: :math:`P(e) = \pi(v) P(c|v)`.

    This is the weight the SR strategies multiply a blend edge's error by (paper section 3).
    """
    pi = np.asarray(pi, dtype=np.float64)
    src = np.asarray(src)
    prob = np.asarray(prob, dtype=np.float64)
    if src.shape != prob.shape or src.ndim != 1:
        raise ValueError(f"src {src.shape} and prob {prob.shape} must be 1-D of one length")
    if src.size and not (src.min() >= 0 and src.max() < pi.size):
        raise ValueError("src holds vertices outside pi")
    return pi[src] * prob


def expected_error(edge_prob: np.ndarray, err: np.ndarray) -> float:
    r"""Predicted expected error per step, :math:`\sum_e P(e)\, err(e)` (paper section 3).

    Section 7.1 of the paper compares this prediction with the mean error players observed.
    """
    edge_prob = np.asarray(edge_prob, dtype=np.float64)
    err = np.asarray(err, dtype=np.float64)
    if edge_prob.shape != err.shape:
        raise ValueError(f"edge_prob {edge_prob.shape} and err {err.shape} differ in shape")
    return float(edge_prob @ err)


def predicted_edge_probabilities(
    edge_dst: np.ndarray, model: np.ndarray, start: int, restart: float
) -> np.ndarray:
    """STATERANK's P(e) = pi(v) P(c|v) on a published graph under the player model ``model``.

    Taken on the publication players get, after pre-publish relinking: relinking moves
    blend targets, and so where play goes, as well as the errors.

    Parameters
    ----------
    edge_dst : ndarray of int, shape (V * N,)
        Destination of edge ``e = v * N + c``.
    model : ndarray, shape (V, N)
        P(c|v).
    start : int
        Where every session starts.
    restart : float
        rho = 1 / L, L the mean session length in steps.
    """
    model = np.asarray(model, dtype=np.float64)
    edge_dst = np.asarray(edge_dst, dtype=np.int64)
    if model.ndim != 2 or edge_dst.shape != (model.size,):
        raise ValueError(f"edge_dst {edge_dst.shape} must hold one entry per cell of {model.shape}")
    n_vertices, n_controls = model.shape
    src = edge_vertex_control(np.arange(edge_dst.size), n_controls)[0]
    prob = model.reshape(-1)
    rank = staterank(src, edge_dst, prob, n_vertices, start, restart)
    return edge_probabilities(rank.pi, src, prob)


def _validated_edges(
    src: np.ndarray, dst: np.ndarray, prob: np.ndarray, n_vertices: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    if n_vertices < 1:
        raise ValueError(f"n_vertices must be at least 1, got {n_vertices}")
    src = np.asarray(src)
    dst = np.asarray(dst)
    prob = np.asarray(prob, dtype=np.float64)
    if not (src.ndim == dst.ndim == prob.ndim == 1 and src.shape == dst.shape == prob.shape):
        raise ValueError(
            f"src {src.shape}, dst {dst.shape} and prob {prob.shape} must be 1-D of one length"
        )
    for name, ids in (("src", src), ("dst", dst)):
        if ids.size and not np.issubdtype(ids.dtype, np.integer):
            raise ValueError(f"{name} must hold integer vertex ids, got dtype {ids.dtype}")
        if ids.size and not (ids.min() >= 0 and ids.max() < n_vertices):
            raise ValueError(f"{name} holds vertices outside 0..{n_vertices - 1}")
    if not np.all(np.isfinite(prob)) or np.any(prob < 0.0):
        raise ValueError("prob must be finite and non-negative")
    out_degree = np.bincount(src, minlength=n_vertices)
    row_sum = np.bincount(src, weights=prob, minlength=n_vertices)
    bad = np.flatnonzero((out_degree > 0) & (np.abs(row_sum - 1.0) > ROW_SUM_ATOL))
    if bad.size:
        v = int(bad[0])
        raise ValueError(
            f"outgoing probabilities of {bad.size} vertices do not sum to 1 "
            f"(vertex {v}: {row_sum[v]!r})"
        )
    return src.astype(np.int64, copy=False), dst.astype(np.int64, copy=False), prob


def _initial_pi(warm_start: np.ndarray | None, n_vertices: int, start: int) -> np.ndarray:
    pi = np.zeros(n_vertices, dtype=np.float64)
    if warm_start is None:
        pi[start] = 1.0
        return pi
    warm = np.asarray(warm_start, dtype=np.float64)
    if warm.ndim != 1 or warm.size > n_vertices:
        raise ValueError(
            f"warm_start must be 1-D with at most {n_vertices} entries, got shape {warm.shape}"
        )
    if not np.all(np.isfinite(warm)) or np.any(warm < 0.0) or warm.sum() <= 0.0:
        raise ValueError("warm_start must be finite, non-negative and not all zero")
    pi[: warm.size] = warm
    return pi / pi.sum()
