"""Worlds grown apart against the committed scoreboards (deviations.md, "grown world by
world"): every per-world figure of the play files' worlds, at every checkpoint a committed
scoreboard judged, must equal the one the whole study's database gave.

    python studies/outside-the-loop/check_play.py studies/outside-the-loop/plays/worlds-*.npz

Prints each figure that differs and a count; exits 1 when any differs.
"""

from __future__ import annotations

import json
import math
import sys
from dataclasses import replace
from pathlib import Path
from typing import Any

from app.services.experiment.play_files import read_plays
from app.services.experiment.scoreboard import scoreboard

HERE = Path(__file__).resolve().parent
#: the committed scoreboards, each judged when every run had reached its size
COMMITTED = ("5k", "7k", "10k")


def _same(a: float | None, b: float | None) -> bool:
    """Equal figures; no figure is written NaN in the older files and null since."""
    missing = [x is None or math.isnan(x) for x in (a, b)]
    return all(missing) or (not any(missing) and a == b)


def _bars(board: dict[str, Any]) -> dict[tuple[str, str, int], dict[str, Any]]:
    bars = (board["primary"], *board["bars"])
    return {(b["endpoint"], b["players"], b["frames"]): b for b in bars}


def main(paths: list[str]) -> int:
    play = read_plays([Path(p) for p in paths])
    seeds = tuple(sorted({key[2] for key in play.rows}))
    # judged over these worlds only: each bar's per-world figures are the worlds' own
    part = scoreboard(replace(play, plan=replace(play.plan, seeds=seeds))).to_dict()
    compared = differing = 0
    for name in COMMITTED:
        stored = json.loads((HERE / f"scoreboard-{name}.json").read_text())
        position = {seed: i for i, seed in enumerate(stored["seeds"])}
        judged = _bars(stored)
        for key, bar in _bars(part).items():
            old = judged.get(key)
            unreached = (*stored["missing_checkpoints"], *part["missing_checkpoints"])
            if old is None or key[2] in unreached:
                continue
            for seed, value in zip(seeds, bar["per_world"], strict=True):
                compared += 1
                before = old["per_world"][position[seed]]
                if not _same(before, value):
                    differing += 1
                    print(f"{name}: {key} world {seed}: {before} != {value}")
    listed = ", ".join(map(str, seeds))
    print(f"worlds {listed}: {compared} per-world figures compared, {differing} differ")
    return 1 if differing else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
