"""The experiment pipeline end to end on a small plan (the --quick figures live in the README)."""

from __future__ import annotations

from pathlib import Path

import pytest

from app.core.strategies import Strategy
from app.reports.experiment import write_report
from app.services.experiment import ExperimentPlan, parse_checkpoints, run_experiment


def test_small_experiment_shows_sr_crowd_ahead_of_baseline(tmp_path: Path) -> None:
    plan = ExperimentPlan(
        strategies=(Strategy.BASELINE, Strategy.SR_CROWD),
        seeds=(5,),
        checkpoints=(600, 2_400),
        sessions=20,
        mean_steps=40,
    )
    frames: list[int] = []
    result = run_experiment(plan, frames.append)
    rows = result["results"]
    assert set(rows) == {"baseline", "sr-crowd"}  # type: ignore[arg-type]
    last = {s: rows[s]["5"][-1] for s in rows}  # type: ignore[index]
    assert all(row["size_frames"] >= 2_400 for row in last.values())
    assert last["sr-crowd"]["observed_mean_error"] < last["baseline"]["observed_mean_error"]
    assert sum(frames) >= 2 * 2_400
    report = write_report(result, tmp_path)
    text = report.read_text()
    assert "sr-crowd" in text and (tmp_path / "error-per-step.png").stat().st_size > 1000


@pytest.mark.parametrize("text", ["", "a,b", "300,200", "0,100", "100,100"])
def test_bad_checkpoints_are_refused(text: str) -> None:
    with pytest.raises(ValueError, match="checkpoints"):
        parse_checkpoints(text)
