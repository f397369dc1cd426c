"""A threshold on blend error from blends labelled visibly wrong or not.

Given blends with their error ``dist`` (eq. 3) and a label "visibly wrong"
(``app.core.liquid.visible_error``), the high-error threshold is the ``dist`` above which blends
are mostly wrong: the 50 % point of a logistic regression of the label on
``log10(dist)`` (:func:`logistic_threshold`). The dist that misclassifies the fewest
blends (:func:`separating_threshold`) is a distribution-free check on it, and a cluster
bootstrap (:func:`bootstrap_thresholds`) gives the uncertainty when blends come in
groups that share a dead-end clip. Pure NumPy.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from app.core.errors import InvalidInput

#: weight of the penalty ``ridge / 2 * slope^2``: finite fits when the groups separate
DEFAULT_RIDGE = 0.01
#: fewest blends of each label a threshold is computed from
MIN_GROUP = 5


class ThresholdFitError(InvalidInput):
    """No threshold: too few blends of a label, or wrongness does not grow with dist."""


class LogisticConvergenceError(ThresholdFitError):
    """Newton's method did not converge within ``max_iter`` iterations."""


@dataclass(frozen=True)
class LogisticFit:
    """``P(wrong | x) = 1 / (1 + exp(-(intercept + slope x)))``."""

    intercept: float
    slope: float
    iterations: int

    @property
    def midpoint(self) -> float:
        """The x where P = 1/2 (``inf`` for a flat fit)."""
        return -self.intercept / self.slope if self.slope != 0.0 else float("inf")

    def probability(self, x: np.ndarray) -> np.ndarray:
        return 1.0 / (1.0 + np.exp(-(self.intercept + self.slope * np.asarray(x, float))))


def _penalised_loglik(b: np.ndarray, x: np.ndarray, y: np.ndarray, ridge: float) -> float:
    eta = b[0] + b[1] * x
    # log p = -log(1 + e^-eta), log(1 - p) = -log(1 + e^eta), both overflow-safe
    return float(
        -np.sum(y * np.logaddexp(0.0, -eta) + (1 - y) * np.logaddexp(0.0, eta))
        - 0.5 * ridge * b[1] ** 2
    )


def fit_logistic(
    x: np.ndarray,
    y: np.ndarray,
    *,
    ridge: float = DEFAULT_RIDGE,
    tol: float = 1e-10,
    max_iter: int = 100,
) -> LogisticFit:
    """Maximum penalised likelihood logistic regression of 0/1 ``y`` on ``x``.

    Maximises

    .. math:: \\sum_i y_i \\log p_i + (1 - y_i) \\log(1 - p_i) - \\tfrac{\\lambda}{2} b_1^2,
        \\qquad p_i = \\sigma(b_0 + b_1 x_i),

    by Newton's method with step halving, on centred ``x``. The ridge ``lambda`` on the
    slope alone keeps the estimate finite under complete separation (where the plain
    maximum likelihood slope is infinite) and leaves the midpoint where the data put it.

    Raises
    ------
    LogisticConvergenceError
        If the Newton step is still above ``tol`` after ``max_iter`` iterations.
    """
    x = np.asarray(x, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    if x.shape != y.shape or x.ndim != 1:
        raise ValueError(f"x and y must be equal 1-d arrays, got {x.shape} and {y.shape}")
    centre = float(x.mean())
    xc = x - centre
    design = np.stack([np.ones_like(xc), xc], axis=1)
    penalty = np.diag([0.0, ridge])
    mean = float(np.clip(y.mean(), 1e-3, 1 - 1e-3))
    b = np.array([np.log(mean / (1 - mean)), 0.0])
    objective = _penalised_loglik(b, xc, y, ridge)
    for iteration in range(1, max_iter + 1):
        p = 1.0 / (1.0 + np.exp(-(design @ b)))
        gradient = design.T @ (y - p) - penalty @ b
        hessian = (design * (p * (1 - p))[:, None]).T @ design + penalty
        step = np.linalg.solve(hessian + 1e-12 * np.eye(2), gradient)
        scale = 1.0
        while True:
            trial = b + scale * step
            value = _penalised_loglik(trial, xc, y, ridge)
            if value >= objective - 1e-12 or scale < 1e-8:
                break
            scale /= 2
        converged = np.max(np.abs(scale * step)) < tol or value < objective - 1e-12
        if value >= objective - 1e-12:
            b, objective = trial, value
        if converged:
            return LogisticFit(float(b[0] - b[1] * centre), float(b[1]), iteration)
    raise LogisticConvergenceError(f"logistic fit did not converge in {max_iter} iterations")


def log_dist(dist: np.ndarray) -> np.ndarray:
    """``log10(dist)``, with ``dist = 0`` at half the smallest positive dist.

    A zero dist (two settled clips of one control, eq. 6) is the least error there is, so
    it goes just below the smallest measured one rather than to minus infinity.
    """
    d = np.asarray(dist, dtype=np.float64)
    if np.any(d < 0) or not np.all(np.isfinite(d)):
        raise ValueError("dist must be finite and non-negative")
    positive = d[d > 0]
    floor = 0.5 * positive.min() if len(positive) else 1.0
    return np.log10(np.maximum(d, floor))


def _check_groups(wrong: np.ndarray, min_group: int) -> None:
    n_wrong = int(wrong.sum())
    if min(n_wrong, len(wrong) - n_wrong) < min_group:
        raise ThresholdFitError(
            f"{n_wrong} visibly wrong and {len(wrong) - n_wrong} right blends: "
            f"need at least {min_group} of each"
        )


def logistic_threshold(
    dist: np.ndarray,
    wrong: np.ndarray,
    *,
    ridge: float = DEFAULT_RIDGE,
    min_group: int = MIN_GROUP,
) -> float:
    """The dist at which a blend is as likely visibly wrong as not (logistic 50 % point).

    Raises
    ------
    ThresholdFitError
        Fewer than ``min_group`` blends of a label, or a fit where wrongness does not
        increase with dist (no threshold to speak of).
    """
    w = np.asarray(wrong, dtype=bool)
    _check_groups(w, min_group)
    fit = fit_logistic(log_dist(dist), w.astype(np.float64), ridge=ridge)
    if fit.slope <= 0.0:
        raise ThresholdFitError(f"wrongness does not grow with dist (slope {fit.slope:.3g})")
    return float(10.0**fit.midpoint)


def separating_threshold(
    dist: np.ndarray, wrong: np.ndarray, *, min_group: int = MIN_GROUP
) -> float:
    """The dist that misclassifies the fewest blends as ``wrong = dist > threshold``.

    Candidates are the geometric midpoints between consecutive distinct dists (and
    beyond the ends); of several equally good ones the middle one is returned.
    """
    w = np.asarray(wrong, dtype=bool)
    _check_groups(w, min_group)
    x = log_dist(dist)
    values = np.unique(x)
    candidates = np.concatenate(
        [[values[0] - 1.0], 0.5 * (values[1:] + values[:-1]), [values[-1] + 1.0]]
    )
    errors = np.array([np.sum(w & (x <= c)) + np.sum(~w & (x > c)) for c in candidates])
    best = np.flatnonzero(errors == errors.min())
    return float(10.0 ** candidates[best[len(best) // 2]])


@dataclass(frozen=True)
class BootstrapResult:
    """Thresholds of the resamples that gave one, and how many did not."""

    thresholds: np.ndarray
    failed: int

    def interval(self, level: float = 0.95) -> tuple[float, float]:
        """Percentile interval of the thresholds (in log space, as they were fitted)."""
        if len(self.thresholds) == 0:
            raise ThresholdFitError("no bootstrap resample gave a threshold")
        tail = 50.0 * (1.0 - level)
        lo, hi = np.percentile(np.log10(self.thresholds), [tail, 100.0 - tail])
        return float(10.0**lo), float(10.0**hi)


def bootstrap_thresholds(
    dist: np.ndarray,
    wrong: np.ndarray,
    groups: np.ndarray,
    estimator: Callable[[np.ndarray, np.ndarray], float] = logistic_threshold,
    *,
    n_boot: int = 1000,
    seed: int = 0,
) -> BootstrapResult:
    """Cluster bootstrap of ``estimator(dist, wrong)``: whole groups are resampled.

    Blends of one dead-end clip share its motion, so they are not independent; drawing
    the groups with replacement (and all blends of each drawn group) keeps that
    dependence in the resamples. Resamples where the estimator raises
    :class:`ThresholdFitError` are counted in ``failed``.
    """
    d = np.asarray(dist, dtype=np.float64)
    w = np.asarray(wrong, dtype=bool)
    g = np.asarray(groups)
    labels, inverse = np.unique(g, return_inverse=True)
    members = [np.flatnonzero(inverse == i) for i in range(len(labels))]
    rng = np.random.default_rng(seed)
    out: list[float] = []
    failed = 0
    for _ in range(n_boot):
        drawn = rng.integers(0, len(labels), len(labels))
        index = np.concatenate([members[i] for i in drawn])
        try:
            out.append(estimator(d[index], w[index]))
        except ThresholdFitError:
            failed += 1
    return BootstrapResult(np.asarray(out, dtype=np.float64), failed)
