"""A study's bars judged from per-world figures: ratios, share differences and the frames
a strategy needs before its players see a clean game (docs/experiment.md, "Scoreboard").

Every bar says whether it can fail. One that cannot (its arms met no error, or no
visibly wrong step, in any world; every arm clean at the first checkpoint) is listed but
left out of the count of bars met, so that the count says only what could have gone
the other way.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import asdict, dataclass

import numpy as np

from app.core.evaluation.comparison import SeedComparison, difference_interval, ratio_interval


@dataclass(frozen=True)
class Bar:
    """One endpoint at one checkpoint: its estimate over worlds, the rule it is judged
    by, whether it is met and whether it could have failed."""

    endpoint: str
    players: str
    frames: int
    mean: float | None
    low: float | None
    high: float | None
    per_world: list[float | None]
    rule: str
    met: bool
    can_fail: bool
    primary: bool = False

    def to_dict(self) -> dict[str, object]:
        """The bar as JSON takes it: a figure no world gave (a checkpoint not every run
        reached) is null, not NaN, which strict JSON readers refuse."""
        figures = asdict(self)
        for key in ("mean", "low", "high"):
            figures[key] = _number(figures[key])
        figures["per_world"] = [_number(value) for value in self.per_world]
        return figures


def _number(value: float | None) -> float | None:
    return None if value is None or np.isnan(value) else float(value)


def ratio_bar(
    endpoint: str,
    players: str,
    frames: int,
    numerator: Sequence[float],
    denominator: Sequence[float],
    *,
    primary: bool = False,
) -> Bar:
    """Geometric mean over worlds of numerator / denominator with its 95 % t interval on
    the log ratios; met when the upper end is below 1. A world whose denominator is 0
    leaves the ratio undefined, which is not met; arms at 0 in every world cannot fail."""
    compared = ratio_interval(numerator, denominator)
    met = compared.high is not None and compared.high < 1.0
    where = (endpoint, players, frames)
    return _bar(where, compared, "upper end < 1", met, (numerator, denominator), primary)


def difference_bar(
    endpoint: str,
    players: str,
    frames: int,
    first: Sequence[float],
    second: Sequence[float],
) -> Bar:
    """Mean over worlds of first - second (shares of steps) with its 95 % t interval;
    met when the upper end is at most 0. Both at 0 in every world cannot fail."""
    compared = difference_interval(first, second)
    met = compared.high is not None and compared.high <= 0.0
    return _bar((endpoint, players, frames), compared, "upper end <= 0", met, (first, second))


def _bar(
    where: tuple[str, str, int],
    compared: SeedComparison,
    rule: str,
    met: bool,
    arms: Sequence[Sequence[float]],
    primary: bool = False,
) -> Bar:
    """A bar of two arms compared over worlds; it can fail unless both arms are 0 in
    every world."""
    endpoint, players, frames = where
    return Bar(
        endpoint,
        players,
        frames,
        compared.mean,
        compared.low,
        compared.high,
        compared.per_seed,
        rule,
        met,
        any(bool(np.any(np.asarray(arm) > 0)) for arm in arms),
        primary,
    )


def frames_to_clean(shares: np.ndarray, frames: Sequence[int], bar: float) -> np.ndarray:
    """Per world (a row of ``shares``, one column per checkpoint of ``frames``), the
    smallest checkpoint from which the visibly-wrong share stays below ``bar`` at every
    later checkpoint; ``inf`` where it is not below at the last one.

    "Stays" because a graph that dips below the bar and rises again was not yet clean:
    its players would meet the artifacts again as it grew.
    """
    below = np.asarray(shares) < bar
    if below.shape[1] == 0:  # no checkpoint judged yet: clean nowhere so far
        return np.full(below.shape[0], np.inf)
    stays = np.flip(np.logical_and.accumulate(np.flip(below, axis=1), axis=1), axis=1)
    first = np.where(stays.any(axis=1), stays.argmax(axis=1), -1)
    return np.where(first >= 0, np.asarray(frames, dtype=np.float64)[first], np.inf)


@dataclass(frozen=True)
class CleanGame:
    """Frames to a clean game per strategy at one bar: per world, and the spread."""

    bar: float
    per_world: dict[str, list[float]]

    def summary(self) -> dict[str, dict[str, float | int | None]]:
        """Per strategy: median, min and max over worlds (inf: beyond the last
        checkpoint, given as None) and the number of worlds that reached a clean game."""
        return {
            strategy: {
                "median": _frames(np.median(values)),
                "min": _frames(np.min(values)),
                "max": _frames(np.max(values)),
                "reached": int(np.isfinite(values).sum()),
            }
            for strategy, values in self.per_world.items()
        }

    def listed(self) -> dict[str, list[float | None]]:
        """Per strategy, each world's frames (None: beyond the last checkpoint)."""
        return {s: [_frames(v) for v in values] for s, values in self.per_world.items()}

    def judged(self, crowd: str, others: Sequence[str], frames: Sequence[int]) -> Bar:
        """sr-crowd's median at most every other arm's, and fewer frames than the first
        other arm (the control) in more worlds than the reverse, over the checkpoints
        ``frames``: the bar belongs to the last of them, since "stays clean" needs them
        all. Every arm clean at the first checkpoint in every world cannot fail."""
        mine = np.asarray(self.per_world[crowd])
        control = np.asarray(self.per_world[others[0]])
        medians = {s: float(np.median(v)) for s, v in self.per_world.items()}
        fewer, more = int(np.sum(mine < control)), int(np.sum(mine > control))
        met = all(medians[crowd] <= medians[o] for o in others) and fewer > more
        everyone = np.concatenate([np.asarray(v) for v in self.per_world.values()])
        return Bar(
            f"frames to under {self.bar:.1%} visibly wrong, {crowd} against " + ", ".join(others),
            "",
            frames[-1],
            _frames(medians[crowd]),
            None,
            None,
            [_frames(v) for v in mine],
            f"median <= the others', fewer frames than {others[0]} in more worlds than "
            f"not ({fewer} against {more})",
            met,
            not bool(np.all(everyone <= frames[0])),
        )


def _frames(value: float) -> float | None:
    """A frame count, None for beyond the last checkpoint (JSON has no infinity)."""
    return float(value) if np.isfinite(value) else None
