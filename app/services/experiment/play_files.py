"""A stored experiment's play as one file, and several such files judged as one.

A study too long for one machine's stay is grown a few worlds at a time (``srg
experiment --resume --only-seeds``); a machine that does not last takes its database
with it, so what the scoreboard reads of each part (the per-step errors of every
checkpoint row, and an outside judge's figures on its publications) is written to a
small file that is kept, and the parts are judged together (docs/experiment.md,
"A study over several machines"). Worlds are independent, so the merged play is the
play one database holding every world would give.
"""

from __future__ import annotations

import json
import os
import zipfile
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from app.core.errors import InvalidInput
from app.services.experiment.plan import ExperimentPlan
from app.services.experiment.runs import runs_of_seeds
from app.services.experiment.scoreboard import Figures, StoredPlay

#: the layout written by :func:`write_play`, checked on reading
FORMAT = "srg-play-1"


def write_play(play: StoredPlay, path: Path) -> None:
    """Write ``play`` to ``path`` (whole or not at all: a temporary file, then renamed)."""
    meta = {
        "format": FORMAT,
        "name": play.name,
        "plan": play.plan.to_dict(),
        "threshold": play.threshold,
        "rows": [list(key) for key in play.rows],
        "outside": [[*key, *figures] for key, figures in play.outside.items()],
    }
    arrays: dict[str, Any] = {f"row{i}": e for i, e in enumerate(play.rows.values())}
    partial = path.with_name(path.name + ".partial")
    with partial.open("wb") as handle:
        np.savez_compressed(handle, meta=np.array(json.dumps(meta)), **arrays)
    os.replace(partial, path)


def of_seeds(play: StoredPlay, seeds: tuple[int, ...]) -> StoredPlay:
    """``play`` with only the rows (and outside figures) of ``seeds``, each of the plan's."""
    runs_of_seeds(play.plan, seeds)  # refuses seeds that are not the plan's
    rows = {key: steps for key, steps in play.rows.items() if key[2] in seeds}
    outside = {key: figures for key, figures in play.outside.items() if key[2] in seeds}
    return replace(play, rows=rows, outside=outside)


def read_plays(paths: Sequence[Path]) -> StoredPlay:
    """The plays in ``paths`` as one: the same experiment and plan in every file, each row
    (and outside figure) in one file only."""
    plays = [_read(path) for path in paths]
    first = plays[0]
    rows: dict[tuple[str, str, int, int], np.ndarray] = {}
    outside: Figures = {}
    for path, play in zip(paths, plays, strict=True):
        if (play.name, play.plan) != (first.name, first.plan):
            raise InvalidInput(f"{path}: another experiment's play than {paths[0]}'s")
        if rows and play.rows and play.threshold != first.threshold:
            raise InvalidInput(f"{path}: another visibility threshold than {paths[0]}'s")
        if rows.keys() & play.rows.keys() or outside.keys() & play.outside.keys():
            raise InvalidInput(f"{path}: holds checkpoint rows an earlier file holds")
        rows.update(play.rows)
        outside.update(play.outside)
    threshold = next((play.threshold for play in plays if play.rows), first.threshold)
    return StoredPlay(first.name, first.plan, rows, threshold, outside)


def _read(path: Path) -> StoredPlay:
    try:
        with np.load(path, allow_pickle=False) as data:
            meta: dict[str, Any] = json.loads(str(data["meta"]))
            if meta.get("format") != FORMAT:
                raise ValueError(f"format {meta.get('format')!r}, not {FORMAT}")
            rows = {
                (str(p), str(s), int(seed), int(i)): data[f"row{n}"]
                for n, (p, s, seed, i) in enumerate(meta["rows"])
            }
            outside = {
                (str(p), str(s), int(seed), int(i)): (float(mean), float(share))
                for p, s, seed, i, mean, share in meta["outside"]
            }
            plan = ExperimentPlan.from_dict(meta["plan"])
            return StoredPlay(str(meta["name"]), plan, rows, float(meta["threshold"]), outside)
    except OSError as error:
        raise InvalidInput(f"{path}: {error.strerror or error}") from None
    except (ValueError, KeyError, TypeError, zipfile.BadZipFile) as error:
        raise InvalidInput(f"{path}: not a play file of srg ({error})") from None
