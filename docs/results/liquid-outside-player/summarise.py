"""The table of docs/results/history.md from the rounds files: per round, each graph's error and
sr-crowd / baseline with a paired bootstrap interval over the sessions.

    python summarise.py rounds-repeat0.jsonl [rounds-repeat1.jsonl ...]

Error met = mean over sessions of the session's mean edge error; sessions are paired by
their seed (the same 30 on both graphs of a round); 10,000 resamples.
"""

from __future__ import annotations

import json
import sys

import numpy as np

RESAMPLES = 10_000


def rounds(path: str) -> list[dict[str, dict]]:
    """One dict per round: strategy ('baseline' or 'sr-crowd') -> its line."""
    lines = [json.loads(line) for line in open(path)]
    return [
        {line["graph"].removeprefix("outside-"): line for line in lines[i : i + 2]}
        for i in range(0, len(lines), 2)
    ]


def ratio(base: list[float], crowd: list[float], seed: int = 0) -> tuple[float, float, float]:
    b, c = np.asarray(base), np.asarray(crowd)
    drawn = np.random.default_rng(seed).integers(0, len(b), size=(RESAMPLES, len(b)))
    resampled = c[drawn].mean(axis=1) / b[drawn].mean(axis=1)
    low, high = np.quantile(resampled, [0.025, 0.975])
    return float(c.mean() / b.mean()), float(low), float(high)


def main(paths: list[str]) -> None:
    print("| repeat | round | frames | baseline error | sr-crowd error | sr-crowd / baseline [95 %] |")
    print("|---|---|---:|---:|---:|---|")
    for path in paths:
        for number, pair in enumerate(rounds(path), start=1):
            base, crowd = pair["baseline"], pair["sr-crowd"]
            mean, low, high = ratio(base["session_errors"], crowd["session_errors"])
            print(
                f"| {path} | {number} | {crowd['size_frames']:,} "
                f"| {np.mean(base['session_errors']):.4f} | {np.mean(crowd['session_errors']):.4f} "
                f"| {mean:.2f} [{low:.2f}, {high:.2f}] |"
            )


if __name__ == "__main__":
    main(sys.argv[1:])
