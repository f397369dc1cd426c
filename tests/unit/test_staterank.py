"""STATERANK against independent solutions: a dense eigenvector, networkx, hand algebra."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from app.core.graph.staterank import (
    StateRankConvergenceError,
    edge_probabilities,
    expected_error,
    staterank,
)


def random_chain(
    rng: np.random.Generator, n_vertices: int, n_controls: int, n_dangling: int = 0
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """N edges per vertex to random destinations (parallel edges likely), Dirichlet rows.

    The last ``n_dangling`` vertices get no outgoing edges.
    """
    n_active = n_vertices - n_dangling
    src = np.repeat(np.arange(n_active), n_controls)
    dst = rng.integers(0, n_vertices, size=src.size)
    prob = rng.dirichlet(np.ones(n_controls), size=n_active).ravel()
    return src, dst, prob


def dense_stationary(
    src: np.ndarray, dst: np.ndarray, prob: np.ndarray, n: int, start: int, restart: float
) -> np.ndarray:
    """Eigenvector for eigenvalue 1 of the dense Google-style matrix, by numpy.linalg.eig."""
    walk = np.zeros((n, n))
    np.add.at(walk, (dst, src), prob)
    dangling = walk.sum(axis=0) == 0.0
    walk[start, dangling] = 1.0  # a dangling vertex ends the session
    google = (1.0 - restart) * walk
    google[start, :] += restart
    values, vectors = np.linalg.eig(google)
    top = np.real(vectors[:, np.argmin(np.abs(values - 1.0))])
    return top / top.sum()


@settings(max_examples=40, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    n_vertices=st.integers(1, 40),
    n_controls=st.integers(1, 4),
    restart=st.floats(0.01, 1.0),
    dangling=st.booleans(),
)
def test_matches_dense_eigenvector(
    seed: int, n_vertices: int, n_controls: int, restart: float, dangling: bool
) -> None:
    rng = np.random.default_rng(seed)
    n_dangling = int(dangling and n_vertices > 1)
    src, dst, prob = random_chain(rng, n_vertices, n_controls, n_dangling)
    start = int(rng.integers(0, n_vertices))
    result = staterank(src, dst, prob, n_vertices, start, restart, tol=1e-13)
    expected = dense_stationary(src, dst, prob, n_vertices, start, restart)
    np.testing.assert_allclose(result.pi, expected, rtol=0, atol=1e-8)
    assert result.pi.sum() == pytest.approx(1.0, abs=1e-12)
    assert result.residual < 1e-13


@pytest.mark.parametrize("seed", range(5))
def test_matches_networkx_personalized_pagerank(seed: int) -> None:
    nx = pytest.importorskip("networkx")
    rng = np.random.default_rng(seed)
    n, start, restart = 60, 3, 1 / 20
    src, dst, prob = random_chain(rng, n, 3, n_dangling=2)
    graph = nx.MultiDiGraph()  # parallel edges are summed when networkx builds its matrix
    graph.add_nodes_from(range(n))
    graph.add_weighted_edges_from(zip(src.tolist(), dst.tolist(), prob.tolist(), strict=True))
    theirs = nx.pagerank(
        graph, alpha=1 - restart, personalization={start: 1.0}, tol=1e-15, max_iter=10_000
    )
    ours = staterank(src, dst, prob, n, start, restart, tol=1e-13).pi
    np.testing.assert_allclose(ours, [theirs[v] for v in range(n)], rtol=0, atol=1e-8)


def test_parallel_edges_add() -> None:
    # Vertex 0 has two controls both leading to 1; vertex 1 returns to 0.
    # pi0 = (1 - rho) pi1 + rho and pi1 = (1 - rho) pi0, so pi0 = 1 / (2 - rho).
    rho = 0.1
    result = staterank(
        np.array([0, 0, 1]), np.array([1, 1, 0]), np.array([0.5, 0.5, 1.0]), 2, 0, rho
    )
    np.testing.assert_allclose(result.pi, [1 / (2 - rho), (1 - rho) / (2 - rho)], atol=1e-9)


def test_restart_one_stays_at_start() -> None:
    result = staterank(np.array([0, 1]), np.array([1, 0]), np.array([1.0, 1.0]), 2, 1, 1.0)
    np.testing.assert_array_equal(result.pi, [0.0, 1.0])


def test_warm_start_after_one_expansion_beats_cold_start() -> None:
    rng = np.random.default_rng(7)
    n, n_controls, restart = 400, 3, 1 / 90
    src, dst, prob = random_chain(rng, n, n_controls)
    before = staterank(src, dst, prob, n, 0, restart)
    # Expansion: a new vertex with N edges, and one old edge redirected to it.
    src = np.concatenate([src, np.full(n_controls, n)])
    dst = np.concatenate([dst, rng.integers(0, n, size=n_controls)])
    dst[17] = n
    prob = np.concatenate([prob, np.full(n_controls, 1 / n_controls)])
    cold = staterank(src, dst, prob, n + 1, 0, restart)
    warm = staterank(src, dst, prob, n + 1, 0, restart, warm_start=before.pi)
    assert warm.iterations < cold.iterations
    np.testing.assert_allclose(warm.pi, cold.pi, rtol=0, atol=1e-9)


def test_warm_start_at_the_solution_stops_at_once() -> None:
    rng = np.random.default_rng(1)
    src, dst, prob = random_chain(rng, 30, 2)
    solved = staterank(src, dst, prob, 30, 0, 0.05, tol=1e-13)
    again = staterank(src, dst, prob, 30, 0, 0.05, warm_start=2.0 * solved.pi)  # renormalised
    assert again.iterations == 1


def test_non_convergence_raises_named_error() -> None:
    rng = np.random.default_rng(2)
    src, dst, prob = random_chain(rng, 50, 3)
    with pytest.raises(StateRankConvergenceError) as caught:
        staterank(src, dst, prob, 50, 0, 0.01, max_iter=3)
    assert caught.value.iterations == 3
    assert caught.value.residual > 1e-10


GOOD = (np.array([0, 1]), np.array([1, 0]), np.array([1.0, 1.0]))


@pytest.mark.parametrize(
    ("src", "dst", "prob", "kwargs", "message"),
    [
        (GOOD[0], GOOD[1][:1], GOOD[2], {}, "1-D of one length"),
        (GOOD[0], np.array([1, 2]), GOOD[2], {}, "dst holds vertices outside"),
        (np.array([0, -1]), GOOD[1], GOOD[2], {}, "src holds vertices outside"),
        (np.array([0.0, 1.0]), GOOD[1], GOOD[2], {}, "integer vertex ids"),
        (GOOD[0], GOOD[1], np.array([1.0, -1.0]), {}, "non-negative"),
        (GOOD[0], GOOD[1], np.array([1.0, np.nan]), {}, "finite"),
        (GOOD[0], GOOD[1], np.array([1.0, 0.9]), {}, "do not sum to 1"),
        (*GOOD, {"start": 2}, "start 2 is not a vertex"),
        (*GOOD, {"restart": 0.0}, r"restart must lie in \(0, 1\]"),
        (*GOOD, {"restart": 1.5}, r"restart must lie in \(0, 1\]"),
        (*GOOD, {"tol": 0.0}, "tol must be positive"),
        (*GOOD, {"max_iter": 0}, "max_iter must be at least 1"),
        (*GOOD, {"warm_start": np.ones(3)}, "at most 2 entries"),
        (*GOOD, {"warm_start": np.zeros(2)}, "not all zero"),
        (*GOOD, {"warm_start": np.array([1.0, -0.5])}, "non-negative"),
    ],
)
def test_invalid_input_is_rejected(
    src: np.ndarray, dst: np.ndarray, prob: np.ndarray, kwargs: dict, message: str
) -> None:
    args = {"start": 0, "restart": 0.1} | kwargs
    start, restart = args.pop("start"), args.pop("restart")
    with pytest.raises(ValueError, match=message):
        staterank(src, dst, prob, 2, start, restart, **args)


def test_edge_probabilities_and_expected_error() -> None:
    pi = np.array([0.25, 0.75])
    src = np.array([0, 0, 1, 1])
    prob = np.array([0.6, 0.4, 0.1, 0.9])
    edge_prob = edge_probabilities(pi, src, prob)
    np.testing.assert_allclose(edge_prob, [0.15, 0.1, 0.075, 0.675])
    assert expected_error(edge_prob, np.array([0.0, 2.0, 4.0, 0.0])) == pytest.approx(0.5)
    with pytest.raises(ValueError, match="differ in shape"):
        expected_error(edge_prob, np.zeros(3))
    with pytest.raises(ValueError, match="outside pi"):
        edge_probabilities(pi, np.array([0, 2]), np.array([1.0, 1.0]))
