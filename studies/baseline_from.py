"""sr-crowd / baseline where baseline was grown by another run of the same worlds.

A run planned with ``--strategies sr-heuristic,sr-crowd`` grows no baseline. Baseline and
sr-heuristic read no traces, so an earlier run of the same fluid, crowd and world seeds
grew the very same graphs and its bots played them the same sessions. This script checks
that (sr-heuristic's mean error per step must be equal in both runs at every checkpoint
and seed, else it refuses) and then prints sr-crowd / baseline per checkpoint with the
interval the reports use (``app.core.evaluation.comparison.ratio_interval``).

    PYTHONPATH=. python studies/baseline_from.py CROWD_RUN BASELINE_RUN CROWD

CROWD_RUN and BASELINE_RUN are folders under studies/ holding a ``result.json``.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

from app.core.evaluation.comparison import ratio_interval

RESULTS = Path(__file__).resolve().parent


def checkpoints(run: str, crowd: str, strategies: tuple[str, ...]) -> dict:
    """Per strategy and seed, the run's checkpoints keyed by their frames."""
    path = RESULTS / run / "result.json"
    if not path.is_file():
        sys.exit(f"no {path}")
    crowds = json.loads(path.read_text())["crowds"]
    if crowd not in crowds:
        sys.exit(f"{run} has no crowd {crowd!r} (it has {', '.join(crowds)})")
    results = crowds[crowd]["results"]
    for strategy in strategies:
        if strategy not in results:
            sys.exit(f"{run} grew no {strategy} for {crowd}")
    return {
        strategy: {
            seed: {point["checkpoint_frames"]: point for point in points}
            for seed, points in results[strategy].items()
        }
        for strategy in strategies
    }


def same_worlds(grown: dict, other: dict, seeds: list[str], frames: int) -> None:
    """Exits, in one line, unless sr-heuristic met the same error in both runs at
    ``frames`` on every seed: trace-blind growth of the same worlds is bit for bit."""
    for seed in seeds:
        ours = grown["sr-heuristic"][seed][frames]["observed_mean_error"]
        theirs = other["sr-heuristic"][seed][frames]["observed_mean_error"]
        if ours != theirs:
            sys.exit(
                f"seed {seed}, {frames} frames: sr-heuristic met {ours} here and "
                f"{theirs} there: not the same worlds"
            )


def main(crowd_run: str, baseline_run: str, crowd: str) -> None:
    grown = checkpoints(crowd_run, crowd, ("sr-crowd", "sr-heuristic"))
    other = checkpoints(baseline_run, crowd, ("baseline", "sr-heuristic"))
    seeds = sorted(grown["sr-crowd"], key=int)
    if missing := [s for s in seeds if s not in other["baseline"]]:
        sys.exit(f"{baseline_run} grew no baseline for seed(s) {', '.join(missing)}")
    for frames in sorted(grown["sr-crowd"][seeds[0]]):
        if any(frames not in other["baseline"][s] for s in seeds):
            print(f"{frames}: no baseline grown to it in {baseline_run}")
            continue
        same_worlds(grown, other, seeds, frames)
        crowd_error = [grown["sr-crowd"][s][frames]["observed_mean_error"] for s in seeds]
        baseline = [other["baseline"][s][frames] for s in seeds]
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
