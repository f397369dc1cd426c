"""studies/baseline_from.py: a baseline paired from another run of the same worlds.

The README's rows marked ``*`` rest on it, so it is held to what a run that grew its own
baseline reports, and to refusing runs whose worlds differ.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
SCRIPT = ROOT / "studies/baseline_from.py"


def pair(*args: str) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    return subprocess.run(
        [sys.executable, str(SCRIPT), *args], capture_output=True, text=True, env=env
    )


def test_a_paired_baseline_gives_the_ratio_the_run_reported_with_its_own() -> None:
    done = pair("gd-mixed-error-20k-tiny", "gd-mixed-20k-tiny", "goal-directed")
    assert done.returncode == 0, done.stderr
    result = json.loads((ROOT / "studies/gd-mixed-error-20k-tiny/result.json").read_text())
    for point, line in zip(
        result["comparison"]["goal-directed"], done.stdout.splitlines(), strict=True
    ):
        own = point["crowd_vs_baseline"]
        assert line.startswith(
            f"{point['checkpoint_frames']}: sr-crowd / baseline {own['mean']:.2f} "
        )
        assert f"[{own['low']:.2f}, {own['high']:.2f}]" in line


def test_runs_of_other_worlds_are_refused_in_one_line() -> None:
    done = pair("high-hes-mixed-error-20k-tiny", "avhes-mixed-20k-tiny", "hesitant")
    assert done.returncode != 0
    assert done.stdout == ""
    assert done.stderr.strip().endswith("not the same worlds")
    assert len(done.stderr.strip().splitlines()) == 1


def test_a_run_without_baseline_is_refused() -> None:
    done = pair("hes-mixed-error-20k-tiny", "high-hes-mixed-20k-tiny", "hesitant")
    assert done.returncode != 0
    assert done.stderr.strip() == "high-hes-mixed-20k-tiny grew no baseline for hesitant"
