"""One strategy against another with its uncertainty: a ratio of per-step means, averaged
over seeds, with a two-level bootstrap interval (docs/experiment.md, "Crowds and intervals").

A run's figure at a checkpoint is a mean per step over a few dozen sessions, and on a
refined graph a handful of blend steps carry all of it, so one run's ratio moves a lot
between samples; seeds move it more. The interval resamples both: the seeds, and inside
each seed the sessions of either arm, independently.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from app.core.bots import BotKind

#: sr-crowd must reach these fractions of baseline's figures at the last checkpoint
#: (the paper: about 0.5 and 0.1; our bar, set before any liquid run: 0.5 and 0.2)
ERROR_RATIO_TARGET = 0.5
HIGH_ERROR_RATIO_TARGET = 0.2
#: crowds without an aim (they hesitate, or pick at random) go nearly everywhere in the
#: graph, so refining for them only has to beat baseline by more than the noise
AIMLESS_CROWDS = frozenset({BotKind.HESITANT, BotKind.RANDOM})
#: the high-error target applies where baseline's players spend more than this share of
#: their steps above the threshold (below it there is little left to divide)
HIGH_ERROR_FLOOR = 0.05


@dataclass(frozen=True)
class SessionSample:
    """One arm's play at one checkpoint of one seed: per session, the sum of a per-step
    quantity (the error, or 1 for a step above the threshold) and its number of steps."""

    totals: np.ndarray
    steps: np.ndarray

    @classmethod
    def of(cls, step_values: np.ndarray, session_steps: np.ndarray) -> SessionSample:
        """Per-step values (sessions back to back) cut into sessions of the given lengths."""
        values = np.asarray(step_values, dtype=np.float64)
        steps = np.asarray(session_steps, dtype=np.int64)
        if steps.ndim != 1 or np.any(steps < 1) or steps.sum() != values.size:
            raise ValueError(
                f"session lengths (sum {int(steps.sum())}) must be positive and cover the "
                f"{values.size} steps"
            )
        starts = np.concatenate([[0], np.cumsum(steps)[:-1]])
        return cls(np.add.reduceat(values, starts), steps)

    @property
    def rate(self) -> float:
        """The per-step mean over all sessions."""
        return float(self.totals.sum() / self.steps.sum())


@dataclass(frozen=True)
class RatioInterval:
    """Mean over seeds of numerator / denominator, and its bootstrap interval.

    ``mean``, ``low`` and ``high`` are None where a seed's denominator is 0 (the ratio
    is undefined); ``high`` is inf where resampled denominators reach 0.
    """

    mean: float | None
    low: float | None
    high: float | None
    per_seed: list[float | None]
    level: float

    def verdict(self, numerator: str, denominator: str) -> str:
        """Whether the difference is larger than the noise, in words."""
        if self.low is None or self.high is None:
            return f"undefined: {denominator} met no such step in some seed"
        if self.high < 1.0:
            return f"{numerator} below {denominator} by more than the noise"
        if self.low > 1.0:
            return f"{numerator} above {denominator} by more than the noise"
        return f"within the noise: the {self.level:.0%} interval spans 1"

    def to_dict(self) -> dict[str, object]:
        return {
            "mean": self.mean,
            "low": self.low,
            "high": self.high,
            "per_seed": self.per_seed,
            "level": self.level,
        }


def ratio_interval(
    numerator: Sequence[SessionSample],
    denominator: Sequence[SessionSample],
    *,
    level: float = 0.95,
    resamples: int = 4000,
    seed: int = 0,
) -> RatioInterval:
    r"""Mean over seeds of the ratio of per-step means, with a two-level bootstrap interval.

    .. math:: R = \frac{1}{S} \sum_s \frac{\bar x_s}{\bar y_s}

    where :math:`\bar x_s`, :math:`\bar y_s` are the per-step means of the two arms at
    seed s (the seeds pair the arms: same initial graph, same bot seeds). Each bootstrap
    replicate draws S seeds with replacement and, inside each drawn seed, each arm's
    sessions with replacement; the interval is the replicates' central ``level`` range
    (percentile method, the outer order statistics, so no interpolation towards inf).

    With few seeds the outer level sees few distinct draws (3 seeds: 10 multisets), so
    the interval is narrower than a t-interval over seeds would be; ``per_seed`` is kept
    beside it so that a reader sees the spread itself.

    Parameters
    ----------
    numerator, denominator : sequences of SessionSample, one per seed, paired by index
    level : float
        Coverage of the interval, in (0, 1).
    resamples : int
        Bootstrap replicates.
    seed : int
        Seed of the resampling (the interval is reproducible).
    """
    if len(numerator) != len(denominator) or not numerator:
        raise ValueError("give one sample per seed for both arms, paired")
    if not 0.0 < level < 1.0:
        raise ValueError(f"level must lie in (0, 1), got {level}")
    per_seed = [_ratio(n.rate, d.rate) for n, d in zip(numerator, denominator, strict=True)]
    defined = [r for r in per_seed if r is not None]
    if len(defined) < len(per_seed):
        return RatioInterval(None, None, None, per_seed, level)
    rng = np.random.default_rng(seed)
    with np.errstate(divide="ignore", invalid="ignore"):
        replicates = np.column_stack(
            [
                _resampled_rates(n, resamples, rng) / _resampled_rates(d, resamples, rng)
                for n, d in zip(numerator, denominator, strict=True)
            ]
        )
        drawn = rng.integers(0, len(per_seed), size=(resamples, len(per_seed)))
        means = np.take_along_axis(replicates, drawn, axis=1).mean(axis=1)
    tail = (1.0 - level) / 2.0
    low = float(np.nanquantile(means, tail, method="lower"))
    high = float(np.nanquantile(means, 1.0 - tail, method="higher"))
    return RatioInterval(float(np.mean(defined)), low, high, per_seed, level)


def _resampled_rates(sample: SessionSample, resamples: int, rng: np.random.Generator) -> np.ndarray:
    """Per-step means of ``resamples`` draws of the sample's sessions with replacement."""
    drawn = rng.integers(0, sample.steps.size, size=(resamples, sample.steps.size))
    return np.asarray(sample.totals[drawn].sum(axis=1) / sample.steps[drawn].sum(axis=1))


def _ratio(numerator: float, denominator: float) -> float | None:
    return numerator / denominator if denominator > 0.0 else None


def error_ratio_target(crowd: str) -> float | None:
    """The bar on the error ratio's mean for ``crowd``'s players (None: no bar on its size,
    only its interval below 1): :data:`ERROR_RATIO_TARGET` for a crowd with an aim."""
    return None if crowd in AIMLESS_CROWDS else ERROR_RATIO_TARGET


def meets_targets(
    errors: RatioInterval,
    high: RatioInterval,
    baseline_high: float,
    error_target: float | None = ERROR_RATIO_TARGET,
) -> bool:
    """The error ratio's interval's upper end below 1 and its mean at most
    ``error_target`` (when there is one), and the high-error ratio's mean at most
    :data:`HIGH_ERROR_RATIO_TARGET` wherever baseline's high-error fraction is above
    :data:`HIGH_ERROR_FLOOR`."""
    error_met = (
        errors.mean is not None
        and errors.high is not None
        and (error_target is None or errors.mean <= error_target)
        and errors.high < 1.0
    )
    high_met = baseline_high <= HIGH_ERROR_FLOOR or (
        high.mean is not None and high.mean <= HIGH_ERROR_RATIO_TARGET
    )
    return error_met and high_met
