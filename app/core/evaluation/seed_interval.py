"""A figure's spread over seeds: its mean and Student's t interval of that mean.

An experiment measures each figure once per seed at every checkpoint; a plot of the mean
draws this interval beside it. With a handful of seeds the t interval is the honest one: a
bootstrap over three values sees ten distinct resamples and comes out too narrow, so the
strategies' ratios take it too, on their logs
(:func:`app.core.evaluation.comparison.ratio_interval`).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from scipy import stats


class SeedInterval(NamedTuple):
    """Per point: the mean over seeds, the interval's ends (NaN below two seeds), and how
    many seeds had a value there."""

    mean: np.ndarray
    low: np.ndarray
    high: np.ndarray
    seeds: np.ndarray


def seed_interval(values: np.ndarray, *, level: float = 0.95) -> SeedInterval:
    r"""Mean over seeds of each column of ``values`` and the t interval of that mean.

    .. math:: \bar x \pm t_{(1+\ell)/2,\, n-1} \, \frac{s}{\sqrt n}

    with :math:`s` the sample standard deviation of the column's :math:`n` finite values
    and :math:`\ell` the ``level``. NaN values (a figure a seed could not give) are left
    out; a column with fewer than two has no interval (NaN ends), and one with none has a
    NaN mean.

    Parameters
    ----------
    values : ndarray, shape (seeds, points)
    level : float
        Coverage of the interval, in (0, 1).
    """
    if not 0.0 < level < 1.0:
        raise ValueError(f"level must lie in (0, 1), got {level}")
    values = np.asarray(values, dtype=np.float64)
    finite = np.isfinite(values)
    seeds = finite.sum(axis=0)
    total = np.where(finite, values, 0.0).sum(axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        mean = np.where(seeds > 0, total / seeds, np.nan)
        squares = np.where(finite, (values - mean) ** 2, 0.0).sum(axis=0)
        std_error = np.sqrt(squares / (seeds - 1) / seeds)
    half = np.where(
        seeds > 1, stats.t.ppf((1.0 + level) / 2.0, np.maximum(seeds - 1, 1)) * std_error, np.nan
    )
    return SeedInterval(mean, mean - half, mean + half, seeds)
