"""A stored experiment's scoreboard: the primary endpoint, every secondary bar with its
number, interval and verdict, and the frames each strategy needs to a clean game
(docs/experiment.md, "Scoreboard"; a study's plan fixes which of them it reports).

It reads only the stored checkpoints (and, where given, an outside judge's lines about
the same publications), so anyone with the database gets the same table.
"""

from __future__ import annotations

import json
from collections.abc import Iterable
from dataclasses import dataclass, field, replace
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np

from app.config import Settings
from app.core.errors import InvalidInput
from app.core.evaluation.comparison import BASELINE, CROWD, HEURISTIC
from app.core.evaluation.scoreboard import (
    Bar,
    CleanGame,
    difference_bar,
    frames_to_clean,
    ratio_bar,
)
from app.db.sessions import transaction
from app.services.experiment.plan import ExperimentPlan, stored_experiment_id, stored_plan
from app.services.experiment.players import FRESH, POPULATION, with_populations
from app.services.loading import artifact_store
from app.store.experiments import checkpoint_rows

#: the project's primary size, where a plan has it (otherwise its last checkpoint)
PRIMARY_FRAMES = 10_000
#: bars are judged from this size on: earlier, the crowd model has learned from few traces
FROM_FRAMES = 5_000
#: the visibly-wrong shares under which a game counts as clean
CLEAN_BARS = (0.01, 0.001)
#: the label of an outside judge's lines (``--outside``)
OUTSIDE = "tilt-holder"

#: (players, strategy, seed, checkpoint index) -> (mean error per step, visibly-wrong share)
Figures = dict[tuple[str, str, int, int], tuple[float, float]]


@dataclass(frozen=True)
class Scoreboard:
    """What :func:`scoreboard` judged, ready to print or dump."""

    name: str
    checkpoints: tuple[int, ...]
    seeds: tuple[int, ...]
    primary: Bar
    bars: list[Bar]
    clean: list[CleanGame]
    #: the checkpoints not every run has reached (their bars are not judged)
    missing: tuple[int, ...]

    def counted(self) -> tuple[int, int]:
        """(met, judged) over the bars that can fail at checkpoints every run reached,
        the primary included."""
        judged = [
            b for b in (self.primary, *self.bars) if b.can_fail and b.frames not in self.missing
        ]
        return sum(b.met for b in judged), len(judged)

    def to_dict(self) -> dict[str, Any]:
        met, judged = self.counted()
        return {
            "name": self.name,
            "checkpoints": list(self.checkpoints),
            "seeds": list(self.seeds),
            "missing_checkpoints": list(self.missing),
            "primary": self.primary.to_dict(),
            "bars": [bar.to_dict() for bar in self.bars],
            "met": met,
            "judged": judged,
            "clean_game": [
                {"bar": clean.bar, "per_world": clean.listed(), **clean.summary()}
                for clean in self.clean
            ],
        }


def scoreboard(play: StoredPlay, *, primary_players: str | None = None) -> Scoreboard:
    """Judge the stored experiment of ``play`` (it needs baseline, sr-heuristic and
    sr-crowd). ``primary_players``: whose error the primary endpoint is (default: the
    fresh population, else the population, else the first crowd)."""
    plan, name = play.plan, play.name
    if {BASELINE, HEURISTIC, CROWD} - {s.value for s in plan.strategies}:
        raise InvalidInput(f"{name} did not grow baseline, sr-heuristic and sr-crowd")
    figures = play.figures()
    players = [*plan.players, *plan.populations]
    if play.outside:
        figures.update(play.outside)
        players.append(OUTSIDE)
    primary_players = primary_players or next(
        p for p in (FRESH + POPULATION, POPULATION, *plan.players) if p in players
    )
    if primary_players not in players:
        raise InvalidInput(
            f"no players {primary_players!r} in {name}: choose from {', '.join(players)}"
        )
    reached = [i for i in range(len(plan.checkpoints)) if _complete(figures, plan, i)]
    judged = [i for i in reached if plan.checkpoints[i] >= FROM_FRAMES]
    primary_at = plan.checkpoints.index(
        PRIMARY_FRAMES if PRIMARY_FRAMES in plan.checkpoints else plan.checkpoints[-1]
    )

    def ratio(players: str, index: int, versus: str, primary: bool = False) -> Bar:
        return ratio_bar(
            f"{CROWD} / {versus} error",
            players,
            plan.checkpoints[index],
            _per_world(figures, plan, players, CROWD, index, 0),
            _per_world(figures, plan, players, versus, index, 0),
            primary=primary,
        )

    primary = ratio(primary_players, primary_at, HEURISTIC, primary=True)
    if primary_at not in reached:
        primary = replace(primary, mean=None, low=None, high=None, met=False)
    bars: list[Bar] = []
    for index in judged:
        frames = plan.checkpoints[index]
        ordered = [primary_players, *(p for p in players if p != primary_players)]
        bars += [
            ratio(p, index, HEURISTIC)
            for p in ordered
            if (p, index) != (primary_players, primary_at)
        ]
        bars.append(ratio(primary_players, index, BASELINE))
        bars.append(
            difference_bar(
                f"{CROWD} - {HEURISTIC} visibly-wrong share",
                primary_players,
                frames,
                _per_world(figures, plan, primary_players, CROWD, index, 1),
                _per_world(figures, plan, primary_players, HEURISTIC, index, 1),
            )
        )
    clean = [clean_game(figures, plan, primary_players, bar, reached) for bar in CLEAN_BARS]
    bars += [game.judged(CROWD, (HEURISTIC, BASELINE), plan.checkpoints) for game in clean]
    missing = tuple(c for i, c in enumerate(plan.checkpoints) if i not in reached)
    return Scoreboard(name, plan.checkpoints, plan.seeds, primary, bars, clean, missing)


def scoreboard_figures(board: Scoreboard, play: StoredPlay, out: Path) -> list[Path]:
    """The paper's Figs. 6 and 7 for ``board``'s primary players at every checkpoint
    every run reached: the visibly-wrong share against frames, and the errors met per
    checkpoint, the three strategies beside each other (:mod:`app.reports.scoreboard`)."""
    from app.reports.scoreboard import plot_error_histograms, plot_visibly_wrong

    plan, steps, threshold = play.plan, play.steps, play.threshold
    players = board.primary.players
    reached = [i for i, c in enumerate(plan.checkpoints) if c not in board.missing]
    if not reached:
        raise InvalidInput(f"{board.name} has no checkpoint every run reached: no figure yet")
    frames = [plan.checkpoints[i] for i in reached]
    strategies = (BASELINE, HEURISTIC, CROWD)
    shares = {
        s: np.array(
            [
                [np.mean(steps[(players, s, seed, i)] > threshold) for i in reached]
                for seed in plan.seeds
            ]
        )
        for s in strategies
    }
    errors = {
        s: [np.concatenate([steps[(players, s, seed, i)] for seed in plan.seeds]) for i in reached]
        for s in strategies
    }
    out.mkdir(parents=True, exist_ok=True)
    return [
        plot_visibly_wrong(shares, frames, players, out / "visibly-wrong.png"),
        plot_error_histograms(errors, frames, threshold, players, out / "error-histograms.png"),
    ]


def clean_game(
    figures: Figures, plan: ExperimentPlan, players: str, bar: float, reached: list[int]
) -> CleanGame:
    """Frames to a clean game per strategy and world, on the checkpoints ``reached``."""
    frames = [plan.checkpoints[i] for i in reached]
    per_world = {}
    for strategy in (CROWD, HEURISTIC, BASELINE):
        shares = np.array(
            [[figures[(players, strategy, seed, i)][1] for i in reached] for seed in plan.seeds]
        )
        per_world[strategy] = [float(v) for v in frames_to_clean(shares, frames, bar)]
    return CleanGame(bar, per_world)


@dataclass(frozen=True)
class StoredPlay:
    """An experiment's plan and every stored row's per-step errors by (players, strategy,
    seed, checkpoint index), read once for the bars and figures, with an outside judge's
    figures where one was given."""

    name: str
    plan: ExperimentPlan
    #: each stored row's per-step errors, by (crowd or judge, strategy, seed, index)
    rows: dict[tuple[str, str, int, int], np.ndarray]
    #: the visibility threshold, fixed in the plan when the experiment was made
    threshold: float
    outside: Figures = field(default_factory=dict)

    @cached_property
    def steps(self) -> dict[tuple[str, str, int, int], np.ndarray]:
        """The rows' steps and each population's (:func:`with_populations`)."""
        return with_populations(self.plan.populations, self.rows)

    def figures(self) -> Figures:
        """Each row's mean error per step and visibly-wrong share."""
        return {key: _figures(errors, self.threshold) for key, errors in self.steps.items()}


def read_play(settings: Settings, name: str, outside: Path | None = None) -> StoredPlay:
    """The stored experiment ``name``'s play (:class:`StoredPlay`), with the outside
    judge's lines at ``outside`` (:func:`outside_figures`)."""
    plan = stored_plan(settings, name)
    with transaction(settings) as session:
        rows = checkpoint_rows(session, stored_experiment_id(session, name))
    artifacts = artifact_store(settings)
    steps = {
        (row.bot, row.strategy, row.seed, row.checkpoint): artifacts.get_arrays(
            row.arrays, ("step_errors",)
        )["step_errors"]
        for row in rows
    }
    # one threshold, fixed in the plan when the experiment was made, on every row
    threshold = float(rows[0].figures["high_error_threshold"]) if rows else 0.0
    judged = {} if outside is None else outside_figures(settings, name, outside)
    return StoredPlay(name, plan, steps, threshold, judged)


def outside_figures(settings: Settings, name: str, path: Path) -> Figures:
    """An outside judge's JSON lines (``world``, ``strategy``, ``publication_id``,
    ``mean_error``, ``high_share``) on the experiment's stored publications, placed at
    the checkpoint that stored each publication; lines about other publications are
    refused, so a judge cannot be matched to the wrong graph."""
    with transaction(settings) as session:
        rows = checkpoint_rows(session, stored_experiment_id(session, name))
    where = {row.publication_id: (row.strategy, row.seed, row.checkpoint) for row in rows}
    found: Figures = {}
    for number, line in enumerate(_lines(path), start=1):
        try:
            strategy, seed, index = where[int(line["publication_id"])]
            figures = (float(line["mean_error"]), float(line["high_share"]))
        except (KeyError, TypeError, ValueError):
            raise InvalidInput(
                f"--outside {path}, line {number}: not a judged publication of {name}"
            ) from None
        found[(OUTSIDE, strategy, seed, index)] = figures
    return found


def _lines(path: Path) -> Iterable[dict[str, Any]]:
    try:
        text = path.read_text()
    except OSError as error:
        raise InvalidInput(f"--outside {path}: {error.strerror}") from None
    for number, line in enumerate(text.splitlines(), start=1):
        if line.strip():
            try:
                yield json.loads(line)
            except json.JSONDecodeError:
                raise InvalidInput(f"--outside {path}, line {number}: not JSON") from None


def _figures(errors: np.ndarray, threshold: float) -> tuple[float, float]:
    if not errors.size:
        return 0.0, 0.0
    return float(errors.mean()), float(np.mean(errors > threshold))


def _per_world(
    figures: Figures, plan: ExperimentPlan, players: str, strategy: str, index: int, which: int
) -> list[float]:
    return [
        figures.get((players, strategy, seed, index), (np.nan, np.nan))[which]
        for seed in plan.seeds
    ]


def _complete(figures: Figures, plan: ExperimentPlan, index: int) -> bool:
    """Whether every run's checkpoint ``index`` is stored (for every crowd's players)."""
    return all(
        (plan.players[0], strategy.value, seed, index) in figures
        for strategy in plan.strategies
        for seed in plan.seeds
    )
