"""Player models: the heuristic eq. 1, the crowd eq. 2 against a literal loop and its kernel,
trace counts, session lengths, the names of the models."""

from __future__ import annotations

import numpy as np
import pytest

from app.core.players.crowd_models.eq2 import crowd_player_model
from app.core.players.crowd_models.kernel import (
    kernel_counts,
    kernel_support,
    nearest_visited_distance,
)
from app.core.players.kinds import PlayerModelKind, parse_player_model
from app.core.players.player_models import (
    Trace,
    heuristic_player_model,
    mean_session_length,
    observed_control_counts,
    observed_player_model,
    robust_session_length,
    trace_edges,
)


def test_heuristic_values() -> None:
    model = heuristic_player_model(np.array([0, 2, 1]), 3, 0.8)
    low, high = 0.2 / 3, 0.8 + 0.2 / 3
    np.testing.assert_allclose(
        model, [[high, low, low], [low, low, high], [low, high, low]], rtol=0, atol=1e-15
    )
    np.testing.assert_allclose(model.sum(axis=1), 1.0, rtol=0, atol=1e-15)


@pytest.mark.parametrize(
    ("controls", "n_controls", "alpha", "message"),
    [
        (np.array([0, 3]), 3, 0.8, "outside 0..2"),
        (np.array([0, 1]), 3, 1.2, r"alpha must lie in \[0, 1\]"),
        (np.array([[0, 1]]), 3, 0.8, "1-D"),
        (np.array([0.0]), 3, 0.8, "integers"),
        (np.array([0]), 0, 0.8, "n_controls must be at least 1"),
    ],
)
def test_heuristic_rejects_bad_input(
    controls: np.ndarray, n_controls: int, alpha: float, message: str
) -> None:
    with pytest.raises(ValueError, match=message):
        heuristic_player_model(controls, n_controls, alpha)


def brute_force_crowd(
    descriptors: np.ndarray,
    vertex_control: np.ndarray,
    counts: np.ndarray,
    radius: float,
    eps: float,
    fallback: np.ndarray,
) -> np.ndarray:
    """Eq. 2 written out term by term, one vertex pair at a time."""
    n_vertices, n_controls = counts.shape
    visits = counts.sum(axis=1)
    total = visits.sum()
    model = np.empty_like(fallback)
    for v in range(n_vertices):
        row = np.zeros(n_controls)
        for u in range(n_vertices):
            if visits[u] == 0 or vertex_control[u] != vertex_control[v]:
                continue
            distance = np.linalg.norm(descriptors[u] - descriptors[v])
            weight = max(0.0, 1.0 - float(distance) / radius) + eps
            p_control = counts[u] / visits[u]
            p_vertex = visits[u] / total
            row += weight * p_control * p_vertex
        model[v] = row / row.sum() if row.sum() > 0 else fallback[v]
    return model


def random_crowd_data(
    seed: int, n_vertices: int = 60, n_controls: int = 3
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    descriptors = rng.random((n_vertices, 4))
    descriptors[1] = descriptors[0]  # coincident descriptors: distance 0, full weight
    vertex_control = rng.integers(0, n_controls, size=n_vertices)
    counts = rng.integers(0, 5, size=(n_vertices, n_controls))
    counts[rng.random(n_vertices) < 0.5] = 0  # about half the vertices unvisited
    fallback = heuristic_player_model(vertex_control, n_controls, 0.8)
    return descriptors, vertex_control, counts, fallback


@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize(("radius", "eps"), [(0.4, 1e-3), (0.6, 0.5), (0.3, 0.0)])
def test_crowd_matches_brute_force_eq2(seed: int, radius: float, eps: float) -> None:
    descriptors, vertex_control, counts, fallback = random_crowd_data(seed)
    model = crowd_player_model(descriptors, vertex_control, counts, radius, eps, fallback=fallback)
    expected = brute_force_crowd(descriptors, vertex_control, counts, radius, eps, fallback)
    np.testing.assert_allclose(model, expected, rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(model.sum(axis=1), 1.0, rtol=0, atol=1e-12)


def test_far_unvisited_vertex_gets_the_eps_prior_of_its_control_group() -> None:
    descriptors = np.array([[0.0, 0.0], [0.1, 0.0], [0.0, 0.1], [50.0, 50.0]])
    vertex_control = np.array([1, 1, 0, 1])
    counts = np.array([[2, 6, 0], [1, 0, 1], [9, 0, 0], [0, 0, 0]])
    fallback = heuristic_player_model(vertex_control, 3, 0.8)
    model = crowd_player_model(descriptors, vertex_control, counts, 1.0, 1e-3, fallback=fallback)
    # Only group-1 visits (vertices 0 and 1) count: [3, 6, 1] / 10.
    np.testing.assert_allclose(model[3], [0.3, 0.6, 0.1], rtol=1e-12)


def test_rows_without_support_take_the_fallback() -> None:
    descriptors = np.array([[0.0], [0.5], [10.0], [0.2]])
    vertex_control = np.array([0, 1, 0, 2])
    counts = np.array([[4, 0, 0], [0, 0, 0], [0, 0, 0], [0, 0, 0]])
    fallback = heuristic_player_model(vertex_control, 3, 0.8)
    model = crowd_player_model(descriptors, vertex_control, counts, 1.0, 0.0, fallback=fallback)
    np.testing.assert_array_equal(model[0], [1.0, 0.0, 0.0])
    # vertices 1 and 3: no visited vertex holds their control; vertex 2: eps = 0, out of reach
    np.testing.assert_array_equal(model[1:], fallback[1:])


def test_crowd_without_any_visit_is_the_fallback() -> None:
    fallback = heuristic_player_model(np.array([0, 1]), 2, 0.5)
    model = crowd_player_model(
        np.zeros((2, 3)), np.array([0, 1]), np.zeros((2, 2)), 1.0, 1e-3, fallback=fallback
    )
    np.testing.assert_array_equal(model, fallback)


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"descriptors": np.zeros(4)}, "descriptors must be 2-D"),
        ({"control_counts": np.zeros((3, 3))}, r"control_counts must be \(4, N\)"),
        ({"vertex_control": np.array([0, 1, 2])}, "vertex_control has 3 entries"),
        ({"control_counts": -np.ones((4, 3))}, "non-negative"),
        ({"fallback": np.ones((4, 3))}, "fallback rows must be probability distributions"),
        ({"fallback": np.ones((4, 2)) / 2}, "fallback must have shape"),
        ({"radius": 0.0}, "radius must be positive"),
        ({"eps": -1.0}, "eps must be non-negative"),
    ],
)
def test_crowd_rejects_bad_input(change: dict, message: str) -> None:
    vertex_control = np.array([0, 1, 2, 0])
    args = {
        "descriptors": np.zeros((4, 2)),
        "vertex_control": vertex_control,
        "control_counts": np.ones((4, 3)),
        "radius": 1.0,
        "eps": 1e-3,
        "fallback": heuristic_player_model(vertex_control, 3, 0.8),
    } | change
    fallback = args.pop("fallback")
    with pytest.raises(ValueError, match=message):
        crowd_player_model(**args, fallback=fallback)


def test_observed_control_counts() -> None:
    traces: list[Trace] = [[(0, 1), (2, 0), (0, 1)], [], np.array([[1, 2], [0, 0]])]
    counts = observed_control_counts(traces, 3, 3)
    np.testing.assert_array_equal(counts, [[1, 2, 0], [0, 0, 1], [1, 0, 0]])
    np.testing.assert_array_equal(trace_edges(traces, 3, 3), [1, 6, 1, 5, 0])


@pytest.mark.parametrize(
    ("trace", "message"), [([(3, 0)], "vertex outside 0..2"), ([(0, -1)], "control outside")]
)
def test_trace_steps_outside_the_graph_are_rejected(trace: list, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        observed_control_counts([trace], 3, 3)


def test_mean_session_length_skips_empty_traces() -> None:
    assert mean_session_length([[(0, 0)] * 3, [], [(1, 1)]]) == 2.0
    with pytest.raises(ValueError, match="no trace has a step"):
        mean_session_length([[], []])


def sessions(lengths: list[int] | np.ndarray) -> list[np.ndarray]:
    return [np.zeros((int(n), 2), dtype=np.int64) for n in lengths]


def test_robust_session_length_is_the_mean_of_geometric_sessions() -> None:
    """Under the geometric lengths STATERANK's restart assumes, it estimates their mean."""
    lengths = np.random.default_rng(0).geometric(1 / 90, size=4001)
    estimate = robust_session_length(sessions(lengths), default=90.0, ceiling=900.0)
    assert estimate == pytest.approx(90.0, rel=0.08)
    assert estimate == pytest.approx(lengths.mean(), rel=0.08)


def test_a_few_huge_traces_barely_move_the_robust_session_length() -> None:
    lengths = np.random.default_rng(1).geometric(1 / 90, size=401)
    honest = robust_session_length(sessions(lengths), default=90.0, ceiling=900.0)
    hostile = sessions(lengths) + sessions([85_000, 85_000])
    assert robust_session_length(hostile, default=90.0, ceiling=900.0) == pytest.approx(
        honest, rel=0.02
    )
    # the mean, by contrast, is moved by a whole session per 200 traces of one player
    assert mean_session_length(hostile) > 1.5 * mean_session_length(sessions(lengths))


def test_robust_session_length_is_clamped_and_defaults_without_sessions() -> None:
    # one player, two huge traces: the ceiling bounds the restart rate from below
    assert robust_session_length(sessions([85_000] * 2), default=90.0, ceiling=900.0) == 900.0
    # one-step sessions: the floor of 2 steps (restart rate at most 1/2)
    assert robust_session_length(sessions([1] * 5), default=90.0, ceiling=900.0) == 2.0
    assert robust_session_length([], default=90.0, ceiling=900.0) == 90.0
    assert robust_session_length([[], []], default=90.0, ceiling=900.0) == 90.0
    # a default outside the bounds is clamped too: no setting can stall STATERANK
    assert robust_session_length([], default=1e6, ceiling=900.0) == 900.0
    with pytest.raises(ValueError, match="ceiling"):
        robust_session_length([], default=90.0, ceiling=1.0)


def test_observed_model_is_the_visited_rows_frequencies_and_the_fallback_elsewhere() -> None:
    counts = np.array([[1, 3, 0], [0, 0, 0], [0, 0, 5]])
    fallback = heuristic_player_model(np.array([0, 1, 2]), 3, 0.8)
    model = observed_player_model(counts, fallback=fallback)
    np.testing.assert_allclose(model[0], [0.25, 0.75, 0.0])
    np.testing.assert_array_equal(model[1], fallback[1])
    np.testing.assert_array_equal(model[2], [0.0, 0.0, 1.0])
    with pytest.raises(ValueError, match="one"):
        observed_player_model(counts, fallback=fallback[:2])


@pytest.mark.parametrize("seed", range(3))
@pytest.mark.parametrize("radius", [0.2, 0.5])
def test_kernel_support_is_where_eq2_has_a_kernel_term(seed: int, radius: float) -> None:
    descriptors, vertex_control, counts, fallback = random_crowd_data(seed)
    visited = counts.sum(axis=1) > 0
    supported = kernel_support(descriptors, vertex_control, visited, radius)
    # without the eps prior, eq. 2 falls back exactly where no kernel term reaches
    model = crowd_player_model(descriptors, vertex_control, counts, radius, 0.0, fallback=fallback)
    kernel_only = brute_force_crowd(descriptors, vertex_control, counts, radius, 0.0, fallback)
    np.testing.assert_allclose(model, kernel_only, rtol=1e-12, atol=1e-14)
    expected = np.array(
        [
            any(
                visited[u]
                and vertex_control[u] == vertex_control[v]
                and np.linalg.norm(descriptors[u] - descriptors[v]) < radius
                for u in range(len(visited))
            )
            for v in range(len(visited))
        ]
    )
    np.testing.assert_array_equal(supported, expected)
    assert 0 < supported.sum() < len(supported)


def test_kernel_support_needs_a_visit_strictly_inside_the_radius() -> None:
    descriptors = np.array([[0.0], [1.0], [0.5], [0.2]])
    supported = kernel_support(
        descriptors, np.array([0, 0, 1, 0]), np.array([True, False, False, False]), 1.0
    )
    # vertex 1 sits exactly at r (kernel 0); vertex 2 holds another control
    np.testing.assert_array_equal(supported, [True, False, False, True])


@pytest.mark.parametrize("seed", range(3))
def test_crowd_model_is_the_normalised_kernel_counts_plus_the_eps_prior(seed: int) -> None:
    rng = np.random.default_rng(seed)
    descriptors = rng.random((80, 3))
    vertex_control = rng.integers(0, 3, size=80)
    counts = rng.integers(0, 5, size=(80, 3))
    counts[rng.random(80) < 0.6] = 0
    counts[vertex_control == 2] = 0  # a control group nobody visited: the fallback
    fallback = heuristic_player_model(vertex_control, 3, 0.8)
    radius, eps = 0.35, 1e-2
    k = kernel_counts(descriptors, vertex_control, counts, radius)
    group_totals = np.array([counts[vertex_control == c].sum(axis=0) for c in range(3)])
    scores = k + eps * group_totals[vertex_control]
    expected = fallback.copy()
    supported = scores.sum(axis=1) > 0
    expected[supported] = scores[supported] / scores[supported].sum(axis=1, keepdims=True)
    model = crowd_player_model(descriptors, vertex_control, counts, radius, eps, fallback=fallback)
    np.testing.assert_allclose(model, expected, rtol=1e-12, atol=1e-15)
    assert np.array_equal(model[vertex_control == 2], fallback[vertex_control == 2])


def test_kernel_counts_weigh_own_visits_fully_and_neighbours_by_the_triangle() -> None:
    descriptors = np.array([[0.0, 0.0], [0.3, 0.4], [0.0, 0.1], [5.0, 5.0]])
    vertex_control = np.array([1, 1, 0, 1])
    counts = np.array([[2, 6, 0], [1, 0, 1], [9, 0, 0], [0, 3, 0]])
    k = kernel_counts(descriptors, vertex_control, counts, radius=1.0)
    # 0 and 1 are 0.5 apart in group 1: weight 0.5 each way; 2 is alone in group 0; 3 is far
    np.testing.assert_allclose(k[0], [2 + 0.5, 6, 0.5])
    np.testing.assert_allclose(k[1], [1 + 1, 3, 1])
    np.testing.assert_array_equal(k[2], [9, 0, 0])
    np.testing.assert_array_equal(k[3], [0, 3, 0])
    # a radius that reaches nobody else leaves each vertex its own counts
    np.testing.assert_array_equal(kernel_counts(descriptors, vertex_control, counts, 0.05), counts)


def test_the_distance_to_the_nearest_visited_vertex_of_the_group() -> None:
    descriptors = np.array([[0.0], [3.0], [1.0], [7.0]])
    distance = nearest_visited_distance(
        descriptors, np.array([0, 0, 1, 1]), np.array([True, False, False, False])
    )
    np.testing.assert_array_equal(distance, [0.0, 3.0, np.inf, np.inf])


def test_player_model_names_parse_and_unknown_ones_name_the_known() -> None:
    assert parse_player_model("eq2") is PlayerModelKind.EQ2
    assert parse_player_model("mixed-error") is PlayerModelKind.MIXED_ERROR
    with pytest.raises(ValueError, match="eq2, shrunk, mixed, mixed-error"):
        parse_player_model("logit")
