"""The null of a world's sr-crowd / sr-heuristic: sr-heuristic nudged against itself,
and the default's own ratios regrown at the nudge beside the stored ones.

Reads the result.json of the nudged runs (SRG_ALPHA 0.79 and 0.81 on worlds 10-12, 0.79
on worlds 13 and 14) and of the stored sr-heuristic at 0.8 (the mixed-held selection's
and sel-w1314's, the same worlds and bots), prints per crowd and checkpoint the
per-world ratios of mean error per step and the root mean square of their logs, beside
the pooled within-candidate standard deviation of the selections' per-world sr-crowd /
sr-heuristic (sel-gd20k-* and sel-av20k-*, worlds 10-12).

    python docs/results/null-alpha/ratios.py

from the stored reports (null-alpha079-tiny, null-alpha081-tiny, null-w1314-alpha079-tiny,
null-crowd079-tiny, sel-w1314-mixed-error-tiny and the selections').
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from app.core.evaluation.seed_interval import seed_interval

RESULTS = Path(__file__).resolve().parent.parent
REFERENCE = {"goal-directed": "sel-gd20k-mixed-held-tiny", "avoider": "sel-av20k-mixed-held-tiny"}
SEEDS = ("10", "11", "12")
LATER_SEEDS = ("13", "14")


def errors(result: dict, crowd: str, seeds: tuple[str, ...] = SEEDS) -> dict[int, np.ndarray]:
    """Mean error per step of sr-heuristic per checkpoint, one per world."""
    runs = result["crowds"][crowd]["results"]["sr-heuristic"]
    by_frames: dict[int, list[float]] = {}
    for seed in seeds:
        for row in runs[seed]:
            by_frames.setdefault(row["checkpoint_frames"], []).append(row["observed_mean_error"])
    return {frames: np.asarray(v) for frames, v in by_frames.items()}


def within_candidates(crowd: str) -> dict[int, tuple[float, int]]:
    """Per checkpoint, the pooled within-candidate standard deviation of log sr-crowd /
    sr-heuristic over worlds, of every stored selection on these worlds, and their count."""
    prefix = "sel-gd20k-" if crowd == "goal-directed" else "sel-av20k-"
    pooled: dict[int, list[tuple[float, int]]] = {}
    for path in sorted(RESULTS.glob(f"{prefix}*/result.json")):
        for row in stored(path.parent.name)["comparison"].get(crowd, []):
            logs = np.log(row["crowd_vs_heuristic"]["per_seed"])
            if row["checkpoint_frames"] >= 5000:
                squares = float(((logs - logs.mean()) ** 2).sum())
                pooled.setdefault(row["checkpoint_frames"], []).append((squares, len(logs) - 1))
    return {
        frames: (float(np.sqrt(sum(s for s, _ in v) / sum(d for _, d in v))), len(v))
        for frames, v in pooled.items()
    }


def stored(name: str) -> dict:
    return json.loads((RESULTS / name / "result.json").read_text())


def main() -> None:
    nudged = {alpha: stored(f"null-alpha{alpha}-tiny") for alpha in ("079", "081")}
    later = stored("null-w1314-alpha079-tiny"), stored("sel-w1314-mixed-error-tiny")
    for crowd, reference in REFERENCE.items():
        at80 = errors(stored(reference), crowd)
        low, high = errors(nudged["079"], crowd), errors(nudged["081"], crowd)
        later_low, later_at80 = (errors(result, crowd, LATER_SEEDS) for result in later)
        spread = within_candidates(crowd)
        print(f"{crowd}: ratios of mean error per step, worlds 10, 11, 12 (then 13, 14)")
        for frames in sorted(at80):
            pairs = {
                "0.79/0.80": low[frames] / at80[frames],
                "0.81/0.80": high[frames] / at80[frames],
                "0.79/0.81": low[frames] / high[frames],
                "worlds 13, 14: 0.79/0.80": later_low[frames] / later_at80[frames],
            }
            logs = np.log(np.concatenate([pairs["0.79/0.80"], pairs["0.81/0.80"]]))
            five = np.concatenate([logs, np.log(pairs["worlds 13, 14: 0.79/0.80"])])
            line = "; ".join(f"{k} " + ", ".join(f"{r:.2f}" for r in v) for k, v in pairs.items())
            null = np.sqrt(np.mean(logs**2))
            print(f"  {frames}: {line}")
            print(
                f"    null: rms of log {null:.2f}, largest {np.exp(np.abs(logs).max()):.2f}x; "
                f"with worlds 13, 14 {np.sqrt(np.mean(five**2)):.2f}, "
                f"largest {np.exp(np.abs(five).max()):.2f}x"
            )
            if frames in spread:
                sd, n = spread[frames]
                print(
                    f"    candidates' sr-crowd / sr-heuristic: within-candidate sd of log "
                    f"{sd:.2f} over {n} selections"
                )

    crowd_null()
    five_worlds()


def crowd_null() -> None:
    """mixed-error's sr-crowd / sr-heuristic per world, stored (0.8) and both arms at 0.79."""
    for crowd, worlds, pair in (
        ("goal-directed", "10, 11, 12", ("sel-gd20k-mixed-error-tiny", "null-crowd079-tiny")),
        ("goal-directed", "13, 14", ("sel-w1314-mixed-error-tiny", "null-w1314-crowd079-tiny")),
        ("avoider", "13, 14", ("sel-w1314-mixed-error-tiny", "null-w1314-crowd079-tiny")),
    ):
        print(f"{crowd}, mixed-error's sr-crowd / sr-heuristic, worlds {worlds}")
        crowd_pair(crowd, pair)


def crowd_pair(crowd: str, pair: tuple[str, str]) -> None:
    rows = {}
    for name in pair:
        result = stored(name)
        for row in result["comparison"][crowd]:
            rows.setdefault(row["checkpoint_frames"], []).append(row["crowd_vs_heuristic"])
        shares = [
            [run["model_fit"] and run["model_fit"].get("unseen_share") for run in runs]
            for _, runs in sorted(result["crowds"][crowd]["results"]["sr-crowd"].items())
        ]
        print(f"  {name}: shares that grew each checkpoint, per world {shares}")
    for frames, (stored_row, nudged) in sorted(rows.items()):
        print(
            f"  {frames}: at 0.8 {stored_row['mean']:.2f} "
            f"({', '.join(f'{r:.2f}' for r in stored_row['per_seed'])}); "
            f"at 0.79 {nudged['mean']:.2f} [{nudged['low']:.2f}, {nudged['high']:.2f}] "
            f"({', '.join(f'{r:.2f}' for r in nudged['per_seed'])})"
        )


def five_worlds() -> None:
    """mixed-error's sr-crowd / sr-heuristic over the five selection worlds 10-14: the
    stored selections' 10-12 and sel-w1314's 13, 14; geometric mean and 95 % Student t."""
    print("mixed-error's sr-crowd / sr-heuristic over selection worlds 10-14")
    for crowd, name in (
        ("goal-directed", "sel-gd20k-mixed-error-tiny"),
        ("avoider", "sel-av20k-mixed-error-tiny"),
    ):
        ratios: dict[int, list[float]] = {}
        for source in (name, "sel-w1314-mixed-error-tiny"):
            for row in stored(source)["comparison"][crowd]:
                ratios.setdefault(row["checkpoint_frames"], []).extend(
                    row["crowd_vs_heuristic"]["per_seed"]
                )
        for frames, per_world in sorted(ratios.items()):
            if frames < 5000:
                continue
            mean, low, high = (
                float(np.exp(v[0])) for v in seed_interval(np.log(per_world)[:, None])[:3]
            )
            print(
                f"  {crowd} {frames}: {mean:.2f} [{low:.2f}, {high:.2f}] "
                f"({', '.join(f'{r:.2f}' for r in per_world)})"
            )


if __name__ == "__main__":
    main()
