"""Checkpoint metrics on a hand-checked two-vertex graph (N = 2, edges e = 2 v + c)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from app.core.metrics import (
    density_agreement,
    error_histogram,
    evaluate_checkpoint,
    high_error_fraction,
    observed_edge_density,
    observed_mean_error,
    observed_step_errors,
)

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
