"""An experiment's comparison of strategies from its stored samples, and the report's first
table (app.services.experiment.results.compare_strategies, app.reports.experiment)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from app.core.growth.kinds import Strategy
from app.core.players.kinds import BotKind
from app.reports.experiment import comparison_section
from app.services.experiment.plan import ExperimentPlan
from app.services.experiment.results import compare_strategies

THRESHOLD = 1.0
#: per strategy, each seed's step errors at both checkpoints (mean error, share above 1)
STEPS = {
    "baseline": [1.0, 1.0, 2.0, 4.0],  # mean 2, half the steps above the threshold
    "sr-heuristic": [1.0, 1.0, 1.0, 1.0],  # mean 1, none above
    "sr-crowd": [0.5, 0.5, 0.5, 0.5],  # mean 0.5, none above
}


def plan(*strategies: Strategy) -> ExperimentPlan:
    return ExperimentPlan(
        strategies=strategies,
        seeds=(0, 1),
        checkpoints=(2_000, 5_000),
        bots=(BotKind.GOAL_DIRECTED,),
    )


def samples(
    compared: ExperimentPlan,
) -> dict[tuple[str, str, str, int], tuple[np.ndarray, float]]:
    """Every seed the same, but seed 1's sr-crowd twice as bad as seed 0's."""
    return {
        (bot.value, s.value, str(seed), index): (
            np.array(STEPS[s.value]) * (2.0 if s is Strategy.SR_CROWD and seed == 1 else 1.0),
            THRESHOLD,
        )
        for bot in compared.bots
        for s in compared.strategies
        for seed in compared.seeds
        for index in range(len(compared.checkpoints))
    }


def test_every_pair_is_compared_with_the_traces_headline_and_targets() -> None:
    full = plan(Strategy.BASELINE, Strategy.SR_HEURISTIC, Strategy.SR_CROWD)
    rows = compare_strategies(full, samples(full))["goal-directed"]
    assert [row["checkpoint_frames"] for row in rows] == [2_000, 5_000]
    last = rows[-1]
    # sr-crowd / sr-heuristic per seed 0.5 and 1.0: geometric mean sqrt(0.5)
    headline = last["crowd_vs_heuristic"]
    assert headline["per_seed"] == [0.5, 1.0]
    assert headline["mean"] == pytest.approx(math.sqrt(0.5))
    assert headline["method"] == "Student t on log ratios over seeds, 95 %"
    assert last["crowd_vs_baseline"]["per_seed"] == [0.25, 0.5]
    assert last["heuristic_vs_baseline"]["mean"] == pytest.approx(0.5)
    assert last["heuristic_vs_baseline"]["low"] == pytest.approx(0.5)  # no spread
    assert last["high_error_fraction"] == {"baseline": 0.5, "sr-heuristic": 0.0, "sr-crowd": 0.0}
    difference = last["high_error_difference"]
    assert (difference["mean"], difference["low"], difference["high"]) == (0.0, 0.0, 0.0)
    met = {(t["target"], t["frames"]): t["met"] for row in rows for t in row["targets"]}
    assert met[("sr-crowd / sr-heuristic error, mean (no dip)", 5_000)]
    assert not met[("sr-crowd / sr-heuristic error, mean", 5_000)]  # 0.71 > 0.5
    assert met[("sr-crowd / baseline error, mean", 5_000)]
    assert met[("visibly-wrong share, sr-crowd / baseline", 2_000)]
    assert last["meets_targets"] is False and "meets_targets" not in rows[0]

    lines = "\n".join(
        comparison_section({"plan": full.to_dict(), "comparison": {"goal-directed": rows}})
    )
    assert "| goal-directed | 5000 | 0.71 [" in lines
    assert "| 0.500 / 0.000 / 0.000 |" in lines
    assert (
        "Intervals: ratios, Student t on log ratios over seeds, 95 %; "
        "share difference, Student t on differences over seeds, 95 %." in lines
    )
    assert "| goal-directed | 5000 | sr-crowd / sr-heuristic error, mean | 0.707 | <= 0.5 " in lines
    assert "goal-directed: NOT all met." in lines


def test_a_comparison_whose_arms_are_absent_is_left_out() -> None:
    two = plan(Strategy.BASELINE, Strategy.SR_HEURISTIC)
    (row, _) = compare_strategies(two, samples(two))["goal-directed"]
    assert set(row) == {"checkpoint_frames", "heuristic_vs_baseline", "high_error_fraction"}
    one = plan(Strategy.BASELINE)
    assert compare_strategies(one, samples(one)) == {}


def test_a_target_on_a_strategy_not_grown_is_reported_not_met_and_not_measured() -> None:
    two = plan(Strategy.SR_HEURISTIC, Strategy.SR_CROWD)
    rows = compare_strategies(two, samples(two))["goal-directed"]
    lines = comparison_section({"plan": two.to_dict(), "comparison": {"goal-directed": rows}})
    assert (
        "| goal-directed | 5000 | sr-crowd / baseline error, mean | n/a | <= 0.5 "
        "| NOT met: not measured |" in lines
    )
    assert (
        "| goal-directed | 5000 | sr-crowd / sr-heuristic error, mean | 0.707 | <= 0.5 | NOT met |"
        in lines
    )
    assert rows[-1]["meets_targets"] is False


def test_one_world_names_the_targets_it_cannot_judge_instead_of_failing_them() -> None:
    """The demo grows one world: a target that needs an interval over worlds is not
    "NOT met" there but waits for more worlds, and no verdict line is printed."""
    one = ExperimentPlan(
        strategies=(Strategy.BASELINE, Strategy.SR_HEURISTIC, Strategy.SR_CROWD),
        seeds=(0,),
        checkpoints=(2_000, 5_000),
    )
    rows = compare_strategies(one, samples(one))["goal-directed"]
    lines = comparison_section({"plan": one.to_dict(), "comparison": {"goal-directed": rows}})
    text = "\n".join(lines)
    assert "| needs more worlds |" in text and "NOT met: not measured" not in text
    assert not any("NOT all met" in line for line in lines)
    (summary,) = [line for line in lines if line.startswith("One world: ")]
    waiting = sum("needs more worlds" in line for line in lines)
    assert f"{waiting} need an interval over worlds" in summary
