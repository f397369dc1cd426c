"""The factors of the confirmation of `squared` on worlds 15-19 (docs/experiment.md,
"`squared` again, on five new worlds"): the null of sr-crowd's own readings beside
sr-heuristic's, and twice the standard error of a five-world mean under the wider.

sr-crowd's null is the default (`mixed-error`) grown with the heuristic's keep-control
probability nudged to 0.79 (null-crowd079-tiny for worlds 10-12, goal-directed;
null-w1314-crowd079-tiny for 13, 14, both crowds) against the stored runs at 0.8
(sel-gd20k-mixed-error-tiny, sel-w1314-mixed-error-tiny). sr-heuristic's is the one the
earlier rule used (studies/null-alpha/ratios.py: "with worlds 13, 14"). The
confirmation reads 5k and 10k; 20k is printed for the record.

    python studies/sel-squared-fresh/factors.py
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

RESULTS = Path(__file__).resolve().parent.parent
PAIRS = {
    "goal-directed": (
        ("sel-gd20k-mixed-error-tiny", "null-crowd079-tiny", ("10", "11", "12")),
        ("sel-w1314-mixed-error-tiny", "null-w1314-crowd079-tiny", ("13", "14")),
    ),
    "avoider": (("sel-w1314-mixed-error-tiny", "null-w1314-crowd079-tiny", ("13", "14")),),
}
#: root mean square of log sr-heuristic nudged / stored, all eight samples of worlds
#: 10-14, as printed by studies/null-alpha/ratios.py
HEURISTIC_NULL = {
    "goal-directed": {5000: 0.02, 10000: 0.24, 20000: 0.35},
    "avoider": {5000: 0.77, 10000: 0.09, 20000: 0.94},
}
WORLDS = 5


def errors(name: str, crowd: str, strategy: str, seeds: tuple[str, ...]) -> dict[int, list[float]]:
    """Mean error per step of ``strategy`` per checkpoint, one per world in ``seeds``."""
    runs = json.loads((RESULTS / name / "result.json").read_text())["crowds"][crowd]["results"]
    by_frames: dict[int, list[float]] = {}
    for seed in seeds:
        for row in runs[strategy][seed]:
            by_frames.setdefault(row["checkpoint_frames"], []).append(row["observed_mean_error"])
    return by_frames


def crowd_null(crowd: str) -> dict[int, tuple[np.ndarray, np.ndarray]]:
    """Per checkpoint, the logs of sr-crowd's error and of its sr-crowd / sr-heuristic,
    nudged over stored, one per world."""
    own: dict[int, list[float]] = {}
    ratio: dict[int, list[float]] = {}
    for stored, nudged, seeds in PAIRS[crowd]:
        arms = {
            (name, strategy): errors(name, crowd, strategy, seeds)
            for name in (stored, nudged)
            for strategy in ("sr-crowd", "sr-heuristic")
        }
        for frames in arms[stored, "sr-crowd"]:
            at80, at79 = (np.asarray(arms[name, "sr-crowd"][frames]) for name in (stored, nudged))
            h80, h79 = (np.asarray(arms[name, "sr-heuristic"][frames]) for name in (stored, nudged))
            own.setdefault(frames, []).extend(np.log(at79 / at80))
            ratio.setdefault(frames, []).extend(np.log((at79 / h79) / (at80 / h80)))
    return {frames: (np.asarray(own[frames]), np.asarray(ratio[frames])) for frames in own}


def factor(rms: float) -> float:
    """Twice the standard error of a five-world mean of logs with that spread, as a ratio."""
    return float(np.exp(2 * rms / np.sqrt(WORLDS)))


def main() -> None:
    for crowd, heuristic in HEURISTIC_NULL.items():
        nulls = crowd_null(crowd)
        for frames, rms_heuristic in heuristic.items():
            own, ratio = nulls[frames]
            rms_own, rms_ratio = (float(np.sqrt(np.mean(v**2))) for v in (own, ratio))
            print(
                f"{crowd} {frames}: sr-crowd nudged / stored "
                f"{', '.join(f'{r:.2f}' for r in np.exp(own))} (rms of log {rms_own:.2f}); "
                f"its sr-crowd / sr-heuristic {', '.join(f'{r:.2f}' for r in np.exp(ratio))} "
                f"(rms {rms_ratio:.2f}); sr-heuristic's null rms {rms_heuristic:.2f}"
            )
            print(
                f"  factors: (1) traces' ratio {factor(max(rms_ratio, rms_heuristic)):.2f}, "
                f"(2) sr-crowd's error {factor(max(rms_own, rms_heuristic)):.2f}"
            )


if __name__ == "__main__":
    main()
