"""Growth strategies: how much each BLEND edge matters (paper sections 3, 4 and 7).

A strategy turns a player model P(c|v) into a weight per edge; the priority of a BLEND
edge is ``weight * err``. ``max-error`` is Kim et al. 2013 (err alone); ``baseline``
scales err by the local P_h(c|v); the two STATERANK strategies use the global edge
probability P(e) = pi(v) P(c|v) under the heuristic or the learned crowd model.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import StrEnum

import numpy as np

from app.core.graph import StateGraph
from app.core.staterank import StateRankResult, staterank


class Strategy(StrEnum):
    MAX_ERROR = "max-error"
    BASELINE = "baseline"
    SR_HEURISTIC = "sr-heuristic"
    SR_CROWD = "sr-crowd"

    @property
    def uses_staterank(self) -> bool:
        return self in (Strategy.SR_HEURISTIC, Strategy.SR_CROWD)

    @property
    def learns_from_traces(self) -> bool:
        return self is Strategy.SR_CROWD


def parse_strategy(name: str) -> Strategy:
    try:
        return Strategy(name)
    except ValueError:
        known = ", ".join(s.value for s in Strategy)
        raise ValueError(f"unknown strategy {name!r} (known: {known})") from None


@dataclass(frozen=True)
class EdgeWeights:
    weights: np.ndarray
    rank: StateRankResult | None


def edge_weights(
    strategy: Strategy,
    graph: StateGraph,
    control_prob: np.ndarray,
    *,
    restart: float,
    warm_start: np.ndarray | None = None,
) -> EdgeWeights:
    """Weight of every edge under ``strategy``, given the player model ``control_prob`` (V, N).

    For ``sr-crowd`` the caller passes the crowd model (or the heuristic one while no
    traces exist); for the others the heuristic model.
    """
    if strategy is Strategy.MAX_ERROR:
        return EdgeWeights(np.ones(graph.n_edges), None)
    local = control_prob.reshape(-1)
    if strategy is Strategy.BASELINE:
        return EdgeWeights(local.copy(), None)
    src, _, dst = graph.edge_arrays()
    rank = staterank(src, dst, local, graph.n_vertices, graph.start, restart, warm_start=warm_start)
    return EdgeWeights(rank.pi[src] * local, rank)
