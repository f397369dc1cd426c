"""sr-crowd / baseline where baseline was grown by another run of the same worlds.

A run planned with ``--strategies sr-heuristic,sr-crowd`` grows no baseline. Baseline and
sr-heuristic read no traces, so an earlier run of the same fluid, crowd and world seeds
grew the very same graphs and its bots played them the same sessions. This script checks
that (sr-heuristic's mean error per step must be equal in both runs at every checkpoint
and seed, else it refuses) and then prints sr-crowd / baseline per checkpoint with the
interval the reports use (``app.core.comparison.ratio_interval``).

    PYTHONPATH=. python docs/results/baseline_from.py CROWD_RUN BASELINE_RUN CROWD

CROWD_RUN and BASELINE_RUN are folders under docs/results holding a ``result.json``.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

from app.core.comparison import ratio_interval

RESULTS = Path(__file__).resolve().parent


def checkpoints(run: str, crowd: str) -> dict:
    return json.loads((RESULTS / run / "result.json").read_text())["crowds"][crowd]["results"]


def main(crowd_run: str, baseline_run: str, crowd: str) -> None:
    grown, other = checkpoints(crowd_run, crowd), checkpoints(baseline_run, crowd)
    seeds = sorted(grown["sr-crowd"], key=int)
    for i, point in enumerate(grown["sr-crowd"][seeds[0]]):
        for seed in seeds:
            ours = grown["sr-heuristic"][seed][i]["observed_mean_error"]
            theirs = other["sr-heuristic"][seed][i]["observed_mean_error"]
            if ours != theirs:
                sys.exit(f"seed {seed}, {point['checkpoint_frames']} frames: sr-heuristic "
                         f"met {ours} here and {theirs} there: not the same worlds")
        crowd_error = [grown["sr-crowd"][s][i]["observed_mean_error"] for s in seeds]
        baseline = [other["baseline"][s][i]["observed_mean_error"] for s in seeds]
        ratio = ratio_interval(crowd_error, baseline)
        visible = [other["baseline"][s][i]["high_error_fraction"] for s in seeds]
        print(f"{point['checkpoint_frames']}: sr-crowd / baseline {ratio.mean:.2f} "
              f"[{ratio.low:.2f}, {ratio.high:.2f}] per seed "
              f"{', '.join(f'{r:.2f}' for r in ratio.per_seed)}; baseline visibly wrong "
              f"{sum(visible) / len(visible):.4f} ({ratio.method})")


if __name__ == "__main__":
    main(*sys.argv[1:4])
