"""Growth strategies: how much each BLEND edge matters (paper sections 3, 4 and 7).

A strategy turns a player model P(c|v) into a weight per edge; the priority of a BLEND
edge is ``weight * err``. ``max-error`` is Kim et al. 2013 (err alone); ``baseline``
scales err by the local P_h(c|v); the two STATERANK strategies use the global edge
probability P(e) = pi(v) P(c|v) under the heuristic or the learned crowd model.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from app.core.graph.state_graph import StateGraph
from app.core.graph.staterank import (
    STATERANK_MAX_ITER,
    StateRankConvergenceError,
    StateRankResult,
    staterank,
)
from app.core.growth.kinds import Strategy


@dataclass(frozen=True)
class EdgeWeights:
    weights: np.ndarray
    rank: StateRankResult | None
    #: why the weights are not the strategy's own (STATERANK failed) and what they are
    #: instead; None when they are the strategy's
    fallback: str | None = None


def edge_weights(
    strategy: Strategy,
    graph: StateGraph,
    control_prob: np.ndarray,
    *,
    restart: float,
    warm_start: np.ndarray | None = None,
    max_iter: int = STATERANK_MAX_ITER,
) -> EdgeWeights:
    """Weight of every edge under ``strategy``, given the player model ``control_prob`` (V, N).

    For ``sr-crowd`` the caller passes the crowd model (or the heuristic one while no
    traces exist); for the others the heuristic model.

    If STATERANK misses convergence within ``max_iter`` iterations, the weights fall back
    to the ``baseline`` ordering under the same model, the local :math:`P(c|v)` without
    the visit probabilities: it needs no iteration, so growth goes on, a little less well
    aimed, instead of stopping; ``fallback`` says so. With the bounded restart rate of
    :func:`app.core.players.player_models.robust_session_length` this is not expected to happen.
    """
    if strategy is Strategy.MAX_ERROR:
        return EdgeWeights(np.ones(graph.n_edges), None)
    local = control_prob.reshape(-1)
    if strategy is Strategy.BASELINE:
        return EdgeWeights(local.copy(), None)
    src, _, dst = graph.edge_arrays()
    try:
        rank = staterank(
            src,
            dst,
            local,
            graph.n_vertices,
            graph.start,
            restart,
            warm_start=warm_start,
            max_iter=max_iter,
        )
    except StateRankConvergenceError as exc:
        reason = f"{exc} at restart rate {restart:.3g}; ranked by the baseline ordering P(c|v)"
        return EdgeWeights(local.copy(), None, fallback=reason)
    return EdgeWeights(rank.pi[src] * local, rank)


def mixed_weights(crowd: EdgeWeights, heuristic: EdgeWeights, share: float) -> EdgeWeights:
    """The edge weights of a population mixed from two: ``1 - share`` of players as the
    crowd model predicts, ``share`` as the heuristic model does.

    Each STATERANK weight pi(v) P(c|v) is a distribution over edges, the share of all
    steps that one player kind takes on each edge, so the population's is their mix.
    The result keeps the crowd's rank (its pi warm-starts the next ranking). Where either
    STATERANK fell back, the two are not distributions to mix: the crowd's weights stand,
    with the fallback's reason.
    """
    if not 0.0 <= share <= 1.0:
        raise ValueError(f"a share is in [0, 1], not {share}")
    if crowd.fallback or heuristic.fallback:
        return EdgeWeights(crowd.weights, crowd.rank, crowd.fallback or heuristic.fallback)
    return EdgeWeights((1.0 - share) * crowd.weights + share * heuristic.weights, crowd.rank)
