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


def checkpoints(run: str, crowd: str, strategies: tuple[str, ...]) -> dict:
    crowds = json.loads((RESULTS / run / "result.json").read_text())["crowds"]
    if crowd not in crowds:
        sys.exit(f"{run} has no crowd {crowd!r} (it has {', '.join(crowds)})")
    results = crowds[crowd]["results"]
    for strategy in strategies:
        if strategy not in results:
            sys.exit(f"{run} grew no {strategy} for {crowd}")
    return results


def by_frames(points: list[dict]) -> dict[int, dict]:
    return {point["checkpoint_frames"]: point for point in points}


def main(crowd_run: str, baseline_run: str, crowd: str) -> None:
    grown = checkpoints(crowd_run, crowd, ("sr-crowd", "sr-heuristic"))
    other = checkpoints(baseline_run, crowd, ("baseline", "sr-heuristic"))
    seeds = sorted(grown["sr-crowd"], key=int)
    for point in grown["sr-crowd"][seeds[0]]:
        frames = point["checkpoint_frames"]
        if frames not in by_frames(other["baseline"][seeds[0]]):
            print(f"{frames}: no baseline grown to it in {baseline_run}")
            continue
        pairs = {
            s: (
                by_frames(grown["sr-heuristic"][s])[frames],
                by_frames(other["sr-heuristic"][s])[frames],
            )
            for s in seeds
        }
        for seed, (ours, theirs) in pairs.items():
            if ours["observed_mean_error"] != theirs["observed_mean_error"]:
                sys.exit(
                    f"seed {seed}, {frames} frames: sr-heuristic met "
                    f"{ours['observed_mean_error']} here and "
                    f"{theirs['observed_mean_error']} there: not the same worlds"
                )
        crowd_error = [
            by_frames(grown["sr-crowd"][s])[frames]["observed_mean_error"] for s in seeds
        ]
        baseline = [by_frames(other["baseline"][s])[frames] for s in seeds]
        ratio = ratio_interval(crowd_error, [b["observed_mean_error"] for b in baseline])
        visible = sum(b["high_error_fraction"] for b in baseline) / len(baseline)
        print(
            f"{frames}: sr-crowd / baseline {ratio.mean:.2f} "
            f"[{ratio.low:.2f}, {ratio.high:.2f}] per seed "
            f"{', '.join(f'{r:.2f}' for r in ratio.per_seed)}; baseline visibly wrong "
            f"{visible:.4f} ({ratio.method})"
        )


if __name__ == "__main__":
    main(*sys.argv[1:4])
