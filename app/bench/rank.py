"""Benchmark of STATERANK at graph scale: cold, warm after one expansion, and networkx.

The growth loop re-ranks the graph after every batch of expansions, so what matters is the
warm-started run on a graph that changed by one vertex; the cold run and networkx's
PageRank on the same chain are the references (``srg bench rank``).
"""

from __future__ import annotations

import time

import numpy as np
import scipy.sparse as sp

from app.core.errors import InvalidInput
from app.core.graph.state_graph import edge_vertex_control
from app.core.graph.staterank import StateRankResult, staterank
from app.core.players.player_models import heuristic_player_model

#: Defaults of docs/design.md, "Graph algorithms": keep-control probability, session steps
ALPHA = 0.8
SESSION_STEPS = 90.0
TOL = 1e-10
START = 0


def bench_rank(n_edges: int = 1_000_000, n_controls: int = 3, seed: int = 0) -> dict[str, object]:
    """Time STATERANK on a random chain shaped like a grown state graph of ``n_edges`` edges.

    The chain has ``V = n_edges // n_controls`` vertices with one edge per control. It is
    grown as the real graph is: from the start vertex, each new vertex expands a random
    blend edge (which becomes the SIM edge into it), and every edge still a blend at the
    end points where a blend does, at the destination of a random SIM edge of its control.
    Control probabilities are the heuristic model (alpha = 0.8), sessions last 90 steps.

    Then one more expansion (a new vertex with N blend edges, one old blend edge redirected
    to it) is ranked again, warm started from the first ``pi``. networkx's PageRank runs on
    the first chain with the same stopping rule (its ``tol`` is per vertex, so it gets
    ``tol / V``); its time and the largest difference from our ``pi`` are ``None`` when
    networkx is not installed.

    Returns
    -------
    dict
        JSON-able: sizes, then ``cold_*``, ``warm_*`` and ``networkx_*`` seconds, iteration
        counts and residuals.
    """
    if n_controls < 1 or n_edges < 2 * n_controls:
        raise InvalidInput(f"need n_controls >= 1 and n_edges >= 2 * n_controls, got {n_edges}")
    rng = np.random.default_rng(seed)
    n_vertices = n_edges // n_controls
    restart = 1.0 / SESSION_STEPS

    dst, vertex_control, blends = _grown_chain(n_vertices, n_controls, rng)
    src = edge_vertex_control(np.arange(dst.size), n_controls)[0]
    prob = heuristic_player_model(vertex_control, n_controls, ALPHA).ravel()
    cold, cold_seconds = _timed_staterank(src, dst, prob, n_vertices, restart, None)

    # One expansion: a random blend edge becomes the SIM edge into a new vertex.
    expanded = int(rng.choice(blends))
    new_control = edge_vertex_control(expanded, n_controls)[1]
    new_dst = _blend_destinations(vertex_control, new_control, n_controls, rng)
    dst_2 = np.concatenate([dst, new_dst])
    dst_2[expanded] = n_vertices
    src_2 = edge_vertex_control(np.arange(dst_2.size), n_controls)[0]
    vertex_control_2 = np.append(vertex_control, new_control)
    prob_2 = heuristic_player_model(vertex_control_2, n_controls, ALPHA).ravel()
    warm, warm_seconds = _timed_staterank(src_2, dst_2, prob_2, n_vertices + 1, restart, cold.pi)

    networkx = _networkx_pagerank(src, dst, prob, n_vertices, restart)
    return {
        "n_edges": int(dst.size),
        "n_vertices": n_vertices,
        "n_controls": n_controls,
        "seed": seed,
        "restart": restart,
        "tol": TOL,
        "cold_seconds": cold_seconds,
        "cold_iterations": cold.iterations,
        "cold_residual": cold.residual,
        "warm_seconds": warm_seconds,
        "warm_iterations": warm.iterations,
        "warm_residual": warm.residual,
        "networkx_seconds": None if networkx is None else networkx[0],
        "networkx_max_abs_diff": (
            None if networkx is None else float(np.abs(networkx[1] - cold.pi).max())
        ),
    }


def _grown_chain(
    n_vertices: int, n_controls: int, rng: np.random.Generator
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(dst per edge, control per vertex, blend edge ids) of a randomly grown state graph."""
    dst = np.empty(n_vertices * n_controls, dtype=np.int64)
    vertex_control = np.zeros(n_vertices, dtype=np.int64)
    # Open blend edges, as a list with swap-remove for O(1) random picks.
    open_blends = list(range(n_controls))
    picks = rng.random(n_vertices)
    for w in range(1, n_vertices):
        at = int(picks[w] * len(open_blends))
        edge = open_blends[at]
        open_blends[at] = open_blends[-1]
        open_blends.pop()
        dst[edge] = w
        vertex_control[w] = edge_vertex_control(edge, n_controls)[1]
        open_blends.extend(range(w * n_controls, (w + 1) * n_controls))
    blends = np.sort(np.asarray(open_blends, dtype=np.int64))
    for control in range(n_controls):
        ours = blends[edge_vertex_control(blends, n_controls)[1] == control]
        dst[ours] = _blend_destinations(vertex_control, control, ours.size, rng)
    return dst, vertex_control, blends


def _blend_destinations(
    vertex_control: np.ndarray, control: int, size: int, rng: np.random.Generator
) -> np.ndarray:
    """Where ``size`` blend edges of ``control`` lead: the end of a random SIM edge of it.

    The ends of the SIM edges of a control are the vertices of that control except the
    start, which no SIM edge enters; while there are none, blends lead back to the start.
    """
    targets = np.flatnonzero(vertex_control == control)
    targets = targets[targets != START]
    if targets.size == 0:
        return np.full(size, START, dtype=np.int64)
    return rng.choice(targets, size=size)


def _timed_staterank(
    src: np.ndarray,
    dst: np.ndarray,
    prob: np.ndarray,
    n_vertices: int,
    restart: float,
    warm_start: np.ndarray | None,
) -> tuple[StateRankResult, float]:
    began = time.perf_counter()
    result = staterank(src, dst, prob, n_vertices, START, restart, warm_start=warm_start, tol=TOL)
    return result, time.perf_counter() - began


def _networkx_pagerank(
    src: np.ndarray, dst: np.ndarray, prob: np.ndarray, n_vertices: int, restart: float
) -> tuple[float, np.ndarray] | None:
    """(seconds, pi) of ``networkx.pagerank`` on the chain, or None without networkx.

    The graph is built outside the timing from the transition matrix, parallel edges
    summed; the timed call includes networkx's own conversion back to a matrix.
    """
    try:
        import networkx as nx
    except ImportError:
        return None
    transitions = sp.csr_array((prob, (src, dst)), shape=(n_vertices, n_vertices))
    graph = nx.from_scipy_sparse_array(transitions, create_using=nx.DiGraph)
    began = time.perf_counter()
    ranks = nx.pagerank(
        graph,
        alpha=1.0 - restart,
        personalization={START: 1.0},
        tol=TOL / n_vertices,
        max_iter=100_000,
    )
    seconds = time.perf_counter() - began
    return seconds, np.fromiter((ranks[v] for v in range(n_vertices)), float, n_vertices)
