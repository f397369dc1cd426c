"""Checkpoint metrics on a hand-checked two-vertex graph (N = 2, edges e = 2 v + c)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from app.core.evaluation.metrics import (
    density_agreement,
    error_histogram,
    evaluate_checkpoint,
    high_error_fraction,
    observed_edge_density,
    observed_mean_error,
    observed_step_errors,
    per_vertex_bound_edge_probabilities,
)
from app.core.graph.staterank import predicted_edge_probabilities
from app.core.players.player_models import mean_session_length, observed_control_counts

ERR = np.array([0.0, 0.5, 1.0, 0.0])
TRACES = [[(0, 1), (1, 0)], [(0, 0), (0, 1), (1, 1), (1, 0)]]
# the edges taken: 1, 2 | 0, 1, 3, 2 -> errors 0.5, 1.0 | 0.0, 0.5, 0.0, 1.0


def test_step_errors_and_mean() -> None:
    np.testing.assert_array_equal(
        observed_step_errors(TRACES, ERR, 2), [0.5, 1.0, 0.0, 0.5, 0.0, 1.0]
    )
    assert observed_mean_error(TRACES, ERR, 2) == pytest.approx(0.5)


def test_high_error_fraction_counts_steps_strictly_above() -> None:
    assert high_error_fraction(TRACES, ERR, 2, 0.6) == pytest.approx(2 / 6)
    assert high_error_fraction(TRACES, ERR, 2, 0.5) == pytest.approx(2 / 6)
    assert high_error_fraction(TRACES, ERR, 2, 0.4) == pytest.approx(4 / 6)


def test_error_histogram_fixed_bins_and_overflow() -> None:
    counts, edges = error_histogram(TRACES, ERR, 2, upper=1.0, bins=4)
    np.testing.assert_array_equal(edges, [0.0, 0.25, 0.5, 0.75, 1.0])
    np.testing.assert_array_equal(counts, [2, 0, 2, 2])
    counts, _ = error_histogram(TRACES, ERR, 2, upper=0.5, bins=2)
    np.testing.assert_array_equal(counts, [2, 4])  # 1.0 lands in the last bin
    with pytest.raises(ValueError, match="upper > 0"):
        error_histogram(TRACES, ERR, 2, upper=0.0)


def test_observed_edge_density() -> None:
    np.testing.assert_allclose(observed_edge_density(TRACES, 4, 2), [1 / 6, 2 / 6, 2 / 6, 1 / 6])
    with pytest.raises(ValueError, match="no step"):
        observed_edge_density([[]], 4, 2)
    with pytest.raises(ValueError, match="not a multiple"):
        observed_edge_density(TRACES, 5, 2)


def test_density_agreement() -> None:
    same = density_agreement(np.array([1.0, 2.0, 3.0]), np.array([2.0, 4.0, 6.0]))
    assert same == pytest.approx((1.0, 0.0))
    assert density_agreement(np.array([1.0, 0.0]), np.array([0.0, 1.0])) == pytest.approx(
        (-1.0, 1.0)
    )
    correlation, tv = density_agreement(np.array([0.5, 0.5]), np.array([0.25, 0.75]))
    assert math.isnan(correlation)
    assert tv == pytest.approx(0.25)
    with pytest.raises(ValueError, match="1-D of one length"):
        density_agreement(np.ones(2), np.ones(3))
    with pytest.raises(ValueError, match="not all zero"):
        density_agreement(np.zeros(2), np.ones(2))


def test_no_steps_is_an_error() -> None:
    with pytest.raises(ValueError, match="no step"):
        observed_mean_error([[], []], ERR, 2)


def test_err_length_must_be_a_multiple_of_n_controls() -> None:
    with pytest.raises(ValueError, match="length V"):
        observed_step_errors(TRACES, np.zeros(5), 2)


def test_evaluate_checkpoint() -> None:
    predicted = np.array([0.1, 0.2, 0.3, 0.4])
    report = evaluate_checkpoint(TRACES, ERR, 2, predicted, high_error_threshold=0.6, bins=4)
    assert (report.n_traces, report.n_steps) == (2, 6)
    assert report.observed_mean_error == pytest.approx(0.5)
    assert report.high_error_fraction == pytest.approx(2 / 6)
    assert report.histogram_edges == pytest.approx([0.0, 0.6, 1.2, 1.8, 2.4])
    assert report.histogram_counts == [4, 2, 0, 0]
    observed = np.array([1, 2, 2, 1]) / 6
    assert report.density_correlation == pytest.approx(np.corrcoef(predicted, observed)[0, 1])
    assert report.density_tv_distance == pytest.approx(0.5 * np.abs(predicted - observed).sum())
    # predicted expected error: 0.2 * 0.5 + 0.3 * 1.0 = 0.4; observed 0.5
    assert report.predicted_expected_error == pytest.approx(0.4)
    assert report.expected_error_relative_difference == pytest.approx(-0.2)
    assert json.loads(json.dumps(report.to_dict(), allow_nan=False))["n_steps"] == 6


def test_checkpoint_report_dict_turns_nan_into_null() -> None:
    report = evaluate_checkpoint(
        [[(0, 0), (1, 1)]], ERR, 2, np.full(4, 0.25), high_error_threshold=0.6
    )
    as_dict = report.to_dict()
    assert as_dict["density_correlation"] is None  # constant prediction
    assert as_dict["expected_error_relative_difference"] is None  # observed error is 0
    assert as_dict["histogram_counts"] == report.histogram_counts
    assert len(report.histogram_counts) == 20
    json.dumps(as_dict, allow_nan=False)


EDGE_DST = np.array([0, 1, 0, 1])  # the edges TRACES follow: 0 -> 0, 0 -> 1, 1 -> 1; 1 -> 0


def test_predicted_edge_probabilities_solve_the_restarted_chain() -> None:
    # from 0 either control, from 1 always back to 0; rho = 0.5:
    # pi1 = 0.5 * 0.5 pi0 and pi0 + pi1 = 1 -> pi = (0.8, 0.2)
    model = np.array([[0.5, 0.5], [1.0, 0.0]])
    prob = predicted_edge_probabilities(EDGE_DST, model, start=0, restart=0.5)
    np.testing.assert_allclose(prob, [0.4, 0.4, 0.2, 0.0], atol=1e-9)
    with pytest.raises(ValueError, match="one entry per cell"):
        predicted_edge_probabilities(EDGE_DST[:3], model, start=0, restart=0.5)


def test_per_vertex_bound_uses_the_traces_frequencies_and_session_length() -> None:
    fallback = np.full((2, 2), 0.5)
    counts = observed_control_counts(TRACES, 2, 2)
    bound = per_vertex_bound_edge_probabilities(counts, 3.0, EDGE_DST, 0, fallback)
    # controls at 0: 1 x c0, 2 x c1; at 1: 2 x c0, 1 x c1; L = (2 + 4) / 2 = 3
    model = np.array([[1 / 3, 2 / 3], [2 / 3, 1 / 3]])
    expected = predicted_edge_probabilities(EDGE_DST, model, start=0, restart=1 / 3)
    np.testing.assert_allclose(bound, expected, rtol=1e-12)
    assert not np.allclose(bound, predicted_edge_probabilities(EDGE_DST, fallback, 0, 1 / 3))


def test_per_vertex_bound_matches_markov_play() -> None:
    """Players that choose by vertex alone, with geometric sessions: the bound is exact."""
    rng = np.random.default_rng(3)
    n_vertices, n_controls = 25, 3
    edge_dst = rng.integers(0, n_vertices, size=n_vertices * n_controls)
    err = rng.random(n_vertices * n_controls)
    policy = rng.dirichlet(np.ones(n_controls), size=n_vertices)
    traces = []
    for length in rng.geometric(1 / 30, size=600):
        vertex, trace = 0, []
        for _ in range(length):
            control = int(rng.choice(n_controls, p=policy[vertex]))
            trace.append((vertex, control))
            vertex = int(edge_dst[vertex * n_controls + control])
        traces.append(trace)
    fallback = np.full((n_vertices, n_controls), 1 / n_controls)
    counts = observed_control_counts(traces, n_vertices, n_controls)
    bound = per_vertex_bound_edge_probabilities(
        counts, mean_session_length(traces), edge_dst, 0, fallback
    )
    observed = observed_mean_error(traces, err, n_controls)
    assert abs(bound @ err - observed) < 0.005 * observed
    # a model that ignores the traces is far off on the same play
    uniform = predicted_edge_probabilities(edge_dst, fallback, 0, 1 / 30)
    assert abs(uniform @ err - observed) > 0.02 * observed


def test_evaluate_checkpoint_reports_the_bound_next_to_the_prediction() -> None:
    predicted = np.array([0.1, 0.2, 0.3, 0.4])
    bound = np.array([0.0, 0.4, 0.5, 0.1])  # expected error 0.2 + 0.5 = 0.7; observed 0.5
    report = evaluate_checkpoint(TRACES, ERR, 2, predicted, 0.6, bound_edge_prob=bound)
    assert report.per_vertex_bound_expected_error == pytest.approx(0.7)
    assert report.per_vertex_bound_relative_difference == pytest.approx(0.4)
    assert report.expected_error_relative_difference == pytest.approx(-0.2)
    unbounded = evaluate_checkpoint(TRACES, ERR, 2, predicted, 0.6).to_dict()
    assert unbounded["per_vertex_bound_expected_error"] is None
