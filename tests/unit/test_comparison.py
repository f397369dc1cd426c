"""Strategies compared over seeds: Student t intervals on log ratios and on differences,
their verdicts, and the targets judged on them (app.core.evaluation.comparison)."""

from __future__ import annotations

import math

import pytest

from app.core.evaluation.comparison import (
    CheckpointComparison,
    SeedComparison,
    Target,
    compare_checkpoint,
    difference_interval,
    ratio_interval,
    targets,
)

#: t_{0.975} with 2 degrees of freedom, in closed form (2p - 1) / sqrt(2p(1 - p)): 4.3027
T_975_2 = 0.95 / math.sqrt(2 * 0.975 * 0.025)
#: and with 1 degree of freedom (Cauchy): tan(pi (p - 1/2)), 12.706
T_975_1 = math.tan(math.pi * 0.475)


def test_the_ratio_is_the_geometric_mean_with_a_t_interval_on_its_log() -> None:
    """Ratios 0.5, 1 and 2: log ratios -ln 2, 0, ln 2, mean 0, sd ln 2."""
    ratio = ratio_interval([0.5, 1.0, 4.0], [1.0, 1.0, 2.0])
    assert ratio.per_seed == [0.5, 1.0, 2.0]
    half = T_975_2 * math.log(2.0) / math.sqrt(3.0)
    assert ratio.mean == pytest.approx(1.0)
    assert ratio.low == pytest.approx(math.exp(-half))
    assert ratio.high == pytest.approx(math.exp(half))
    assert ratio.method == "Student t on log ratios over seeds, 95 %"
    assert ratio.verdict("sr-crowd", "sr-heuristic").startswith("within the noise")


def test_the_point_estimate_is_the_geometric_mean_not_the_arithmetic_one() -> None:
    ratio = ratio_interval([0.1, 0.4], [1.0, 1.0])  # geometric mean 0.2, arithmetic 0.25
    assert ratio.mean == pytest.approx(0.2)
    # two seeds, one degree of freedom; log ratios ln 0.1, ln 0.4, sd ln 4 / sqrt 2
    half = T_975_1 * (math.log(4.0) / math.sqrt(2.0)) / math.sqrt(2.0)
    assert ratio.high == pytest.approx(0.2 * math.exp(half))


def test_a_clear_gain_is_below_the_noise_and_its_inverse_above() -> None:
    crowd, heuristic = [0.20, 0.25, 0.22], [1.0, 1.1, 0.9]
    gain = ratio_interval(crowd, heuristic)
    assert gain.high is not None and gain.high < 1.0
    assert gain.verdict("sr-crowd", "sr-heuristic") == (
        "sr-crowd below sr-heuristic by more than the noise"
    )
    loss = ratio_interval(heuristic, crowd)
    assert loss.verdict("sr-crowd", "sr-heuristic").startswith("sr-crowd above")


@pytest.mark.parametrize(
    ("numerator", "denominator"),
    [([0.5, 0.0], [1.0, 1.0]), ([0.5, 0.5], [1.0, 0.0])],
    ids=["a ratio of 0", "a denominator of 0"],
)
def test_a_ratio_of_zero_or_without_denominator_leaves_the_estimate_undefined(
    numerator: list[float], denominator: list[float]
) -> None:
    ratio = ratio_interval(numerator, denominator)
    assert ratio.mean is None and ratio.low is None and ratio.high is None
    assert len(ratio.per_seed) == 2 and ratio.per_seed[0] == 0.5
    assert ratio.verdict("sr-crowd", "baseline").startswith("undefined")


def test_one_seed_has_a_point_estimate_and_no_interval() -> None:
    ratio = ratio_interval([0.3], [0.6])
    assert ratio.mean == pytest.approx(0.5) and ratio.low is None and ratio.high is None
    assert ratio.verdict("sr-crowd", "baseline") == "no interval from 1 seed"


def test_the_arms_must_pair() -> None:
    with pytest.raises(ValueError, match="paired"):
        ratio_interval([1.0, 2.0], [1.0])
    with pytest.raises(ValueError, match="paired"):
        difference_interval([], [])


def test_shares_are_compared_by_their_difference_with_a_t_interval() -> None:
    """Differences 0, 0.1, 0.2: mean 0.1, sd 0.1."""
    difference = difference_interval([0.0, 0.1, 0.3], [0.0, 0.0, 0.1])
    assert difference.per_seed == pytest.approx([0.0, 0.1, 0.2])
    half = T_975_2 * 0.1 / math.sqrt(3.0)
    assert difference.mean == pytest.approx(0.1)
    assert difference.low == pytest.approx(0.1 - half)
    assert difference.high == pytest.approx(0.1 + half)
    assert difference.method == "Student t on differences over seeds, 95 %"
    assert difference.verdict("sr-crowd", "sr-heuristic").startswith("within the noise")
    none_at_all = difference_interval([0.0, 0.0], [0.0, 0.0])  # a ratio would be undefined
    assert (none_at_all.mean, none_at_all.low, none_at_all.high) == (0.0, 0.0, 0.0)


def test_the_dict_names_the_method_and_the_verdict() -> None:
    data = ratio_interval([0.5, 1.0, 4.0], [1.0, 1.0, 2.0]).to_dict("sr-crowd", "baseline")
    assert set(data) == {"mean", "low", "high", "per_seed", "level", "method", "verdict"}
    assert data["method"] == "Student t on log ratios over seeds, 95 %"


def test_a_checkpoint_leaves_out_the_comparisons_whose_arms_are_absent() -> None:
    errors = {"baseline": [1.0, 1.0], "sr-crowd": [0.4, 0.6]}
    shares = {"baseline": [0.2, 0.4], "sr-crowd": [0.0, 0.02]}
    point = compare_checkpoint(600, errors, shares)
    assert point.crowd_vs_heuristic is None and point.heuristic_vs_baseline is None
    assert point.high_error_difference is None
    assert point.crowd_vs_baseline is not None
    assert point.crowd_vs_baseline.mean == pytest.approx(math.sqrt(0.24))
    assert point.high_error_fraction == pytest.approx({"baseline": 0.3, "sr-crowd": 0.01})


def comparison(mean: float, high: float | None = None, low: float | None = None) -> SeedComparison:
    return SeedComparison(mean, low, high, [mean], 0.95, "given", 1.0)


def point(
    frames: int,
    versus_heuristic: SeedComparison | None,
    versus_baseline: SeedComparison | None,
    shares: dict[str, float],
    share_low: float | None,
) -> CheckpointComparison:
    difference = None if share_low is None else SeedComparison(0.0, share_low, 0.1, [], 0.95, "", 0)
    return CheckpointComparison(
        frames, versus_heuristic, versus_baseline, comparison(1.0, 1.2, 0.8), shares, difference
    )


SHARES = {"baseline": 0.3, "sr-heuristic": 0.1, "sr-crowd": 0.05}


def judged(found: list[Target]) -> dict[tuple[str, int], tuple[float | None, bool]]:
    return {(t.description, t.frames): (t.value, t.met) for t in found}


def test_the_targets_of_a_crowd_with_an_aim() -> None:
    points = [
        point(2_000, comparison(1.3), comparison(0.9), {**SHARES, "baseline": 0.04}, -0.01),
        point(5_000, comparison(0.9), comparison(0.7), SHARES, 0.02),
        point(10_000, comparison(0.45, 0.95), comparison(0.4), SHARES, -0.02),
    ]
    found = judged(targets("goal-directed", points))
    assert found == {
        ("sr-crowd / sr-heuristic error, mean", 10_000): (0.45, True),
        ("sr-crowd / sr-heuristic error, interval's upper end", 10_000): (0.95, True),
        ("sr-crowd / baseline error, mean", 10_000): (0.4, True),
        # a dip before 5,000 frames is allowed; none from there on
        ("sr-crowd / sr-heuristic error, mean (no dip)", 5_000): (0.9, True),
        ("sr-crowd / sr-heuristic error, mean (no dip)", 10_000): (0.45, True),
        ("visibly-wrong share, sr-crowd - sr-heuristic, interval's low end", 2_000): (-0.01, True),
        ("visibly-wrong share, sr-crowd - sr-heuristic, interval's low end", 5_000): (0.02, False),
        ("visibly-wrong share, sr-crowd - sr-heuristic, interval's low end", 10_000): (-0.02, True),
        # baseline's share at 2,000 frames is under the floor: no bar there
        ("visibly-wrong share, sr-crowd / baseline", 5_000): (pytest.approx(1 / 6), True),
        ("visibly-wrong share, sr-crowd / baseline", 10_000): (pytest.approx(1 / 6), True),
    }


@pytest.mark.parametrize(
    ("last", "failed"),
    [
        (comparison(0.55, 0.9), "sr-crowd / sr-heuristic error, mean"),
        (comparison(0.45, 1.0), "sr-crowd / sr-heuristic error, interval's upper end"),
        (comparison(0.45, None), "sr-crowd / sr-heuristic error, interval's upper end"),
    ],
)
def test_each_bar_holds_exactly(last: SeedComparison, failed: str) -> None:
    found = targets("avoider", [point(20_000, last, comparison(0.5), SHARES, 0.0)])
    assert [t.description for t in found if not t.met] == [failed]


def test_a_report_that_stops_early_leaves_the_last_bars_unmeasured() -> None:
    points = [
        point(5_000, comparison(0.9), comparison(0.7), SHARES, 0.0),
        point(10_000, comparison(0.3, 0.6), comparison(0.3), SHARES, 0.0),
    ]
    found = judged(targets("goal-directed", points, final_frames=20_000))
    # 0.3 at 10,000 frames would meet the last checkpoint's bars: they are not judged there
    assert ("sr-crowd / sr-heuristic error, mean", 10_000) not in found
    assert found[("sr-crowd / sr-heuristic error, mean", 20_000)] == (None, False)
    assert found[("sr-crowd / sr-heuristic error, interval's upper end", 20_000)] == (None, False)
    assert found[("sr-crowd / baseline error, mean", 20_000)] == (None, False)
    assert found[("sr-crowd / sr-heuristic error, mean (no dip)", 10_000)] == (0.3, True)
    whole = judged(targets("goal-directed", points, final_frames=10_000))
    assert whole == judged(targets("goal-directed", points))
    assert whole[("sr-crowd / sr-heuristic error, mean", 10_000)] == (0.3, True)


def test_an_absent_control_leaves_its_targets_unmet_and_a_high_share_fails() -> None:
    shares = {"baseline": 0.3, "sr-crowd": 0.1}
    found = judged(targets("goal-directed", [point(600, None, comparison(0.3), shares, None)]))
    assert found[("sr-crowd / sr-heuristic error, mean", 600)] == (None, False)
    assert found[("sr-crowd / baseline error, mean", 600)] == (0.3, True)
    assert found[("visibly-wrong share, sr-crowd / baseline", 600)] == (
        pytest.approx(1 / 3),
        False,
    )


def test_an_aimless_crowd_needs_only_a_gain_above_the_noise() -> None:
    points = [
        point(5_000, comparison(1.2, 1.5), comparison(1.1), SHARES, 0.0),
        point(10_000, comparison(0.8, 0.95), comparison(0.9), SHARES, 0.0),
    ]
    for crowd in ("hesitant", "random"):
        found = targets(crowd, points)
        assert all(t.met for t in found)
        assert {t.description for t in found if t.description.startswith("sr-crowd")} == {
            "sr-crowd / sr-heuristic error, interval's upper end"
        }
