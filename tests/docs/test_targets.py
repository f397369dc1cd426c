"""studies/targets.py: every bar judged on the runs the README quotes.

Where a run grew its own baseline, the script must judge exactly what the run's report
judged; where it pairs a baseline from another run, it must refuse other worlds.
"""

from __future__ import annotations

import importlib
import json
import sys
from collections.abc import Iterator
from pathlib import Path
from types import ModuleType

import numpy as np
import pytest

from app.core.evaluation.comparison import ratio_interval

ROOT = Path(__file__).resolve().parents[2]
RESULTS = ROOT / "studies"


@pytest.fixture
def scorecard() -> Iterator[ModuleType]:
    """The script as a module; its folder's scripts leave sys.path and sys.modules after."""
    path, modules = list(sys.path), set(sys.modules)
    sys.path.insert(0, str(RESULTS))
    try:
        yield importlib.import_module("targets")
    finally:
        sys.path[:] = path
        for name in set(sys.modules) - modules:
            del sys.modules[name]


def test_a_run_with_its_own_baseline_is_judged_as_its_report_judged_it(
    scorecard: ModuleType,
) -> None:
    claim = scorecard.Claim("low", "goal-directed", "gd-mixed-error-20k-tiny")
    stored = json.loads((RESULTS / claim.run / "result.json").read_text())
    reported = [t for row in stored["comparison"][claim.crowd] for t in row["targets"]]
    assert [t.to_dict() for t in scorecard.judged(claim)] == reported


def test_a_paired_baseline_fills_the_bars_the_report_could_not_measure(
    scorecard: ModuleType,
) -> None:
    claim = scorecard.Claim("low", "avoider", "av-mixed-error-20k-tiny", "avhes-mixed-20k-tiny")
    bars = scorecard.judged(claim)
    against_baseline = [t for t in bars if "baseline" in t.description]
    assert against_baseline
    assert all(t.value is not None for t in bars)


def test_a_baseline_from_other_worlds_is_refused(scorecard: ModuleType) -> None:
    claim = scorecard.Claim(
        "high", "hesitant", "high-hes-mixed-error-20k-tiny", "avhes-mixed-20k-tiny"
    )
    with pytest.raises(SystemExit, match="not the same worlds"):
        scorecard.judged(claim)


@pytest.mark.parametrize(("geometric_mean", "spread"), [(0.32, 0.43), (0.51, 0.84), (1.0, 0.3)])
def test_the_chance_of_an_upper_end_below_one_is_how_often_the_reports_interval_gives_it(
    scorecard: ModuleType, geometric_mean: float, spread: float
) -> None:
    rng = np.random.default_rng(7)
    draws = 4000
    below = 0
    for logs in rng.normal(np.log(geometric_mean), spread, size=(draws, 3)):
        high = ratio_interval(list(np.exp(logs)), [1.0, 1.0, 1.0]).high
        below += high is not None and high < 1.0
    chance = scorecard.chance_below_one(geometric_mean, spread)
    assert abs(below / draws - chance) < 4 * np.sqrt(chance * (1 - chance) / draws) + 0.005
