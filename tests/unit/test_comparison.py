"""sr-crowd against baseline with its uncertainty: the ratio, its interval, the verdict."""

from __future__ import annotations

import numpy as np
import pytest

from app.core.comparison import (
    RatioInterval,
    SessionSample,
    error_ratio_target,
    meets_targets,
    ratio_interval,
)


def sample(rng: np.random.Generator, rate: float, sessions: int = 30) -> SessionSample:
    """Sessions of 20-80 steps whose steps cost ``rate`` on average, noisily."""
    steps = rng.integers(20, 80, size=sessions)
    return SessionSample.of(rng.exponential(rate, size=int(steps.sum())), steps)


def test_sessions_are_cut_from_the_steps_in_order() -> None:
    cut = SessionSample.of(np.array([1.0, 2.0, 3.0, 4.0, 5.0]), np.array([2, 3]))
    np.testing.assert_array_equal(cut.totals, [3.0, 12.0])
    assert cut.rate == pytest.approx(3.0)


@pytest.mark.parametrize("lengths", [[2, 2], [5, 1], [0, 5]])
def test_session_lengths_must_cover_the_steps(lengths: list[int]) -> None:
    with pytest.raises(ValueError, match="session lengths"):
        SessionSample.of(np.ones(5), np.array(lengths))


def test_a_clear_gain_is_larger_than_the_noise() -> None:
    rng = np.random.default_rng(1)
    crowd = [sample(rng, 0.2) for _ in range(3)]
    base = [sample(rng, 1.0) for _ in range(3)]
    ratio = ratio_interval(crowd, base)
    assert ratio.mean == pytest.approx(
        np.mean([c.rate / b.rate for c, b in zip(crowd, base, strict=True)])
    )
    assert ratio.low is not None and ratio.high is not None
    assert ratio.low < ratio.mean < ratio.high < 1.0
    assert ratio.verdict("sr-crowd", "baseline") == (
        "sr-crowd below baseline by more than the noise"
    )
    assert ratio_interval(base, crowd).verdict("sr-crowd", "baseline").startswith("sr-crowd above")


def test_equal_arms_are_within_the_noise_and_the_interval_spans_one() -> None:
    rng = np.random.default_rng(2)
    ratio = ratio_interval(
        [sample(rng, 1.0) for _ in range(3)], [sample(rng, 1.0) for _ in range(3)]
    )
    assert ratio.low is not None and ratio.high is not None
    assert ratio.low < 1.0 < ratio.high
    assert ratio.verdict("sr-crowd", "baseline").startswith("within the noise")


def test_seeds_that_disagree_widen_the_interval() -> None:
    """The same sessions' noise, but seeds that part: the interval must show the spread."""
    rng = np.random.default_rng(3)
    steady = ratio_interval(
        [sample(rng, 0.5) for _ in range(4)], [sample(rng, 1.0) for _ in range(4)]
    )
    parted = ratio_interval(
        [sample(rng, r) for r in (0.1, 0.9, 0.15, 0.85)], [sample(rng, 1.0) for _ in range(4)]
    )
    assert steady.high is not None and steady.low is not None
    assert parted.high is not None and parted.low is not None
    assert parted.high - parted.low > 2 * (steady.high - steady.low)


def test_a_seed_where_baseline_met_no_error_leaves_the_ratio_undefined() -> None:
    rng = np.random.default_rng(4)
    zero = SessionSample.of(np.zeros(10), np.array([4, 6]))
    ratio = ratio_interval([sample(rng, 0.5), sample(rng, 0.5)], [sample(rng, 1.0), zero])
    assert ratio.mean is None and ratio.per_seed[1] is None
    assert ratio.verdict("sr-crowd", "baseline").startswith("undefined")
    assert not meets_targets(ratio, ratio, 0.0)


def test_the_interval_is_reproducible_and_the_arms_must_pair() -> None:
    rng = np.random.default_rng(5)
    crowd, base = [sample(rng, 0.4) for _ in range(2)], [sample(rng, 1.0) for _ in range(2)]
    assert ratio_interval(crowd, base) == ratio_interval(crowd, base)
    with pytest.raises(ValueError, match="paired"):
        ratio_interval(crowd, base[:1])


def interval(mean: float, high: float) -> RatioInterval:
    return RatioInterval(mean, mean / 2, high, [mean], 0.95)


@pytest.mark.parametrize(
    ("error", "high_error", "baseline_high", "met"),
    [
        (interval(0.4, 0.9), interval(0.1, 0.5), 0.3, True),
        (interval(0.4, 1.1), interval(0.1, 0.5), 0.3, False),  # not above the noise
        (interval(0.6, 0.9), interval(0.1, 0.5), 0.3, False),  # error ratio above 0.5
        (interval(0.4, 0.9), interval(0.3, 0.5), 0.3, False),  # high-error ratio above 0.2
        (interval(0.4, 0.9), interval(0.3, 0.5), 0.04, True),  # baseline's fraction too small
    ],
)
def test_targets(
    error: RatioInterval, high_error: RatioInterval, baseline_high: float, met: bool
) -> None:
    assert meets_targets(error, high_error, baseline_high) is met


def test_an_aimless_crowd_needs_only_a_gain_above_the_noise() -> None:
    assert error_ratio_target("goal-directed") == error_ratio_target("avoider") == 0.5
    assert error_ratio_target("hesitant") is None and error_ratio_target("random") is None
    no_high = interval(0.0, 0.0)
    assert meets_targets(interval(0.7, 0.8), no_high, 0.0, error_ratio_target("hesitant"))
    assert not meets_targets(interval(0.7, 0.8), no_high, 0.0, error_ratio_target("avoider"))
    assert not meets_targets(interval(0.7, 1.05), no_high, 0.0, error_ratio_target("hesitant"))
