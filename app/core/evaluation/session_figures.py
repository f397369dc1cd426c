"""Figures measured over play sessions, with the standard error that says how far they hold.

Sessions are the independent draws, steps are not: one player's steps follow each other
through the graph, so a session that wanders into a badly blended corner brings many
high-error steps at once. A figure such as the mean error per step is therefore a ratio of
per-session totals (error summed over a session's steps, over its step count), and its
standard error comes from resampling whole sessions (a seeded bootstrap), never steps.

A figure *rests on too few sessions* (``srg analytics`` warns; docs/play.md, "When a figure
rests on too few sessions") when

- it has fewer than :data:`MIN_SESSIONS` sessions: below that the standard error itself is
  too uncertain to go by (the sample deviation of n draws is off by about
  1 / sqrt(2 (n - 1)) of itself, which is :data:`MAX_RELATIVE_SE` at n = 9), or
- its standard error is more than :data:`MAX_RELATIVE_SE` of the figure: a 95 % interval
  wider than about +-50 %. (The Australian Bureau of Statistics marks estimates with a
  relative standard error over 25 % "use with caution" for the same reason.)

A figure of 0 whose sessions all agree (no session met any error) has no spread to judge
and is judged on its session count alone.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

#: the largest standard error, relative to its figure, that a figure is shown without warning
MAX_RELATIVE_SE = 0.25
#: the fewest sessions whose standard error is itself known to within MAX_RELATIVE_SE
MIN_SESSIONS = 9
#: bootstrap resamples of the sessions (seeded, so a figure's error is the same every time)
RESAMPLES = 400
#: nearest-rank percentiles of session length that analytics report
SESSION_LENGTH_QUANTILES = (0.5, 0.9, 0.99)


@dataclass(frozen=True)
class SessionFigure:
    """A ratio of per-session totals: ``sum(totals) / sum(weights)`` over the sessions."""

    #: None without sessions (or without weight: no step to average over)
    value: float | None
    sessions: int
    #: standard error over sessions relative to ``value``; None where it cannot be told
    #: (fewer than two sessions, or a figure of 0)
    relative_se: float | None

    @classmethod
    def over_sessions(
        cls, totals: Sequence[float] | np.ndarray, weights: Sequence[float] | np.ndarray
    ) -> SessionFigure:
        """The figure of sessions with these totals and weights (steps, or 1 for a plain
        mean over sessions), its standard error from a seeded bootstrap over sessions."""
        totals = np.asarray(totals, dtype=np.float64)
        weights = np.asarray(weights, dtype=np.float64)
        n = len(totals)
        if n == 0 or weights.sum() <= 0.0:
            return cls(None, n, None)
        value = float(totals.sum() / weights.sum())
        if n < 2 or value == 0.0:
            return cls(value, n, None)
        picks = np.random.default_rng(0).integers(0, n, size=(RESAMPLES, n))
        means = totals[picks].sum(axis=1) / weights[picks].sum(axis=1)
        return cls(value, n, float(means.std() / abs(value)))

    @property
    def too_few_sessions(self) -> bool:
        """Whether the figure rests on fewer sessions than its standard error allows."""
        if self.sessions < MIN_SESSIONS:
            return True
        return self.relative_se is not None and self.relative_se > MAX_RELATIVE_SE

    @property
    def sessions_needed(self) -> int:
        """About how many sessions would bring it within the rule: the standard error falls
        as one over the square root of the sessions."""
        if self.relative_se is None or self.sessions == 0:
            return MIN_SESSIONS
        scaled = self.sessions * (self.relative_se / MAX_RELATIVE_SE) ** 2
        return max(MIN_SESSIONS, math.ceil(scaled))


@dataclass(frozen=True)
class SessionLengths:
    """Steps per session: their mean (with its standard error), extremes and percentiles."""

    sessions: int
    mean: float | None
    mean_relative_se: float | None
    min: int | None
    max: int | None
    #: nearest-rank percentiles, keyed "p50", "p90", "p99"
    percentiles: dict[str, int]

    @classmethod
    def of(cls, lengths: Sequence[int] | np.ndarray) -> SessionLengths:
        """The summary of these session lengths (any order).

        A percentile is nearest-rank: the value at 1-based rank ceil(q n), ascending.
        """
        ordered = np.sort(np.asarray(lengths, dtype=np.int64))
        n = len(ordered)
        mean = SessionFigure.over_sessions(ordered, np.ones(n))
        return cls(
            sessions=n,
            mean=mean.value,
            mean_relative_se=mean.relative_se,
            min=int(ordered[0]) if n else None,
            max=int(ordered[-1]) if n else None,
            percentiles={
                f"p{round(q * 100)}": int(ordered[math.ceil(q * n) - 1])
                for q in SESSION_LENGTH_QUANTILES
                if n
            },
        )

    @property
    def mean_figure(self) -> SessionFigure:
        return SessionFigure(self.mean, self.sessions, self.mean_relative_se)
