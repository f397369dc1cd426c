"""A ranking's selection read by the rule fixed before its runs (docs/experiment.md,
"`squared`: growth ranking blends by their squared error", "`squared-large`", and
"`squared` again, on five new worlds").

Reads the candidate's result.json (sel-squared-tiny unless named: both strategies grown
with the SRG_RANK_ERROR its provenance names, on selection worlds 10-14) and the
reference, `mixed-error` under the mean ranking on the same worlds and bots
(sel-gd20k-mixed-error-tiny, sel-av20k-mixed-error-tiny for worlds 10-12,
sel-w1314-mixed-error-tiny for 13, 14). With ``fresh`` it reads the confirmation on
worlds 15-19 instead (fresh-squared-tiny against fresh-mean-tiny, to 10k, with its own
factors); with ``eval``, the confirmed candidate on the evaluation seeds 0, 1, 2 beside
the default's stored runs (no rule: the issue's targets judge it). Prints per crowd and
checkpoint, per world and as a geometric mean over the worlds with its 95 % Student t
interval: (1) what the traces add, sr-crowd /
sr-heuristic, under each ranking; (2) what the players meet, the candidate's error over
the reference's, sr-crowd and sr-heuristic; the visibly wrong shares; then the rule's
verdict.

    python docs/results/sel-squared/ratios.py [sel-squared-large-tiny | fresh | eval]
"""

from __future__ import annotations

import json
import sys
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from app.core.evaluation.seed_interval import seed_interval

RESULTS = Path(__file__).resolve().parent.parent


@dataclass(frozen=True)
class Selection:
    """One reading of a candidate ranking against the mean ranking, and its rule."""

    candidate: str
    #: the reference's result names per crowd, read in order (later worlds override)
    reference: dict[str, tuple[str, ...]]
    worlds: tuple[str, ...]
    checkpoints: tuple[int, ...]
    #: per crowd and checkpoint, beyond which ratio a difference counts: (1) the traces'
    #: ratio, (2) sr-crowd's error; None for an evaluation, which no rule decides
    factors: dict[str, dict[int, tuple[float, float]]] | None
    #: what the rule says when the candidate passes, and when it does not
    verdict: tuple[str, str] = ("becomes the default", "does not become the default")


#: twice the null's standard error of a five-world mean, per crowd and checkpoint, as
#: fixed before the first selection (docs/experiment.md, "How far one world's ratio moves")
FIRST = Selection(
    candidate="sel-squared-tiny",
    reference={
        "goal-directed": ("sel-gd20k-mixed-error-tiny", "sel-w1314-mixed-error-tiny"),
        "avoider": ("sel-av20k-mixed-error-tiny", "sel-w1314-mixed-error-tiny"),
    },
    worlds=("10", "11", "12", "13", "14"),
    checkpoints=(5000, 10000, 20000),
    factors={
        "goal-directed": {5000: (1.02, 1.02), 10000: (1.24, 1.24), 20000: (1.37, 1.37)},
        "avoider": {5000: (1.99, 1.99), 10000: (1.08, 1.08), 20000: (2.32, 2.32)},
    },
)
#: the confirmation on new worlds, its factors from the wider of sr-heuristic's and
#: sr-crowd's nulls (docs/results/sel-squared-fresh/factors.py)
FRESH = Selection(
    candidate="fresh-squared-tiny",
    reference={"goal-directed": ("fresh-mean-tiny",), "avoider": ("fresh-mean-tiny",)},
    worlds=("15", "16", "17", "18", "19"),
    checkpoints=(5000, 10000),
    factors={
        "goal-directed": {5000: (1.11, 1.11), 10000: (1.49, 1.36)},
        "avoider": {5000: (3.95, 1.99), 10000: (1.08, 1.08)},
    },
    verdict=("is confirmed", "is not confirmed"),
)
#: the confirmed candidate on the evaluation seeds, beside the default's stored runs
EVALUATION = Selection(
    candidate="eval-squared-low-tiny",
    reference={
        "goal-directed": ("gd-mixed-error-20k-tiny",),
        "avoider": ("av-mixed-error-20k-tiny",),
    },
    worlds=("0", "1", "2"),
    checkpoints=(5000, 10000, 20000),
    factors=None,
)


def stored(name: str) -> dict:
    return json.loads((RESULTS / name / "result.json").read_text())


def figure(
    selection: Selection,
    results: list[dict],
    crowd: str,
    strategy: str,
    key: str = "observed_mean_error",
) -> dict[int, np.ndarray]:
    """``key`` of ``strategy`` per checkpoint, one per world of ``selection``."""
    per_world: dict[str, dict[int, float]] = {}
    for result in results:
        for seed, rows in result["crowds"][crowd]["results"][strategy].items():
            per_world[seed] = {row["checkpoint_frames"]: row[key] for row in rows}
    return {
        frames: np.asarray([per_world[world][frames] for world in selection.worlds])
        for frames in selection.checkpoints
    }


def geometric(ratios: np.ndarray) -> tuple[float, float, float]:
    """Geometric mean of per-world ratios and its 95 % Student t interval on the logs."""
    mean, low, high = (float(np.exp(v[0])) for v in seed_interval(np.log(ratios)[:, None])[:3])
    return mean, low, high


def line(ratios: np.ndarray) -> str:
    mean, low, high = geometric(ratios)
    return f"{mean:.2f} [{low:.2f}, {high:.2f}] ({', '.join(f'{r:.2f}' for r in ratios)})"


def chosen(argv: list[str]) -> Selection:
    if not argv:
        return FIRST
    named = {"fresh": FRESH, "eval": EVALUATION}
    return named[argv[0]] if argv[0] in named else replace(FIRST, candidate=argv[0])


def main() -> None:
    selection = chosen(sys.argv[1:])
    candidate = [stored(selection.candidate)]
    ranked = candidate[0]["provenance"]["growth"]["SRG_RANK_ERROR"]
    width = len(ranked) + 1
    worse, better = [], []
    for crowd, names in selection.reference.items():
        reference = [stored(name) for name in names]
        runs = {ranked: candidate, "mean": reference}
        arms, wrong = (
            {
                (ranking, strategy): figure(selection, results, crowd, strategy, key)
                for ranking, results in runs.items()
                for strategy in ("sr-heuristic", "sr-crowd")
            }
            for key in ("observed_mean_error", "high_error_fraction")
        )
        print(f"{crowd}, worlds {', '.join(selection.worlds)}: geometric mean [95 % t] (per world)")
        for frames in selection.checkpoints:
            factors = selection.factors[crowd][frames] if selection.factors else None
            print(f"  {frames}{counted(factors)}")
            traces = {
                ranking: arms[ranking, "sr-crowd"][frames] / arms[ranking, "sr-heuristic"][frames]
                for ranking in runs
            }
            crowd_gain = arms[ranked, "sr-crowd"][frames] / arms["mean", "sr-crowd"][frames]
            heuristic_gain = (
                arms[ranked, "sr-heuristic"][frames] / arms["mean", "sr-heuristic"][frames]
            )
            for ranking, ratios in traces.items():
                print(f"    sr-crowd / sr-heuristic, {ranking + ':':{width}} {line(ratios)}")
            print(f"    sr-crowd, {ranked} / mean:         {line(crowd_gain)}")
            print(f"    sr-heuristic, {ranked} / mean:     {line(heuristic_gain)}")
            print(
                "    visibly wrong, mean over worlds: "
                + "; ".join(
                    f"{strategy} {ranking} {100 * wrong[ranking, strategy][frames].mean():.2f} %"
                    for strategy in ("sr-heuristic", "sr-crowd")
                    for ranking in runs
                )
            )
            if factors is not None:
                judge(crowd, frames, factors, traces, ranked, crowd_gain, worse, better)
    if selection.factors is None:
        return
    print("worse beyond the factor: " + ("; ".join(worse) or "none"))
    print("better beyond the factor: " + ("; ".join(better) or "none"))
    kept = not worse and bool(better)
    print(f"rule: {ranked} {selection.verdict[0] if kept else selection.verdict[1]}")


def counted(factors: tuple[float, float] | None) -> str:
    """Where a difference counts, for the checkpoint's heading."""
    if factors is None:
        return ""
    if factors[0] == factors[1]:
        return f" (a difference counts beyond {factors[0]:.2f}x)"
    return (
        f" (a difference counts beyond {factors[0]:.2f}x for the traces' ratio, "
        f"{factors[1]:.2f}x for sr-crowd's error)"
    )


def judge(
    crowd: str,
    frames: int,
    factors: tuple[float, float],
    traces: dict[str, np.ndarray],
    ranked: str,
    crowd_gain: np.ndarray,
    worse: list[str],
    better: list[str],
) -> None:
    """Adds the checkpoint's two readings to ``worse`` or ``better`` beyond their factor."""
    for what, ratio, factor in (
        (
            "the traces' ratio",
            geometric(traces[ranked])[0] / geometric(traces["mean"])[0],
            factors[0],
        ),
        ("sr-crowd's error", geometric(crowd_gain)[0], factors[1]),
    ):
        where = f"{crowd} {frames}, {what} {ratio:.2f}x"
        if ratio > factor:
            worse.append(where)
        elif ratio < 1 / factor:
            better.append(where)


if __name__ == "__main__":
    main()
