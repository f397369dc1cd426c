"""Eq. 2's evidence shrunk toward the heuristic model, state by state (docs/player-models.md).

sr-crowd must never rank worse than sr-heuristic for having read traces. A learned model
that extrapolates the crowd's choices to states nobody played (``knn``) sends STATERANK's
mass down the crowd's old paths, and a growing graph adds most of its states where no
session has been: there the extrapolation is a confident guess, and the blends on the
branches it rules out stay unrefined until players fall into them.

Here the heuristic model P_h (what sr-heuristic ranks with) is a Dirichlet prior of
``prior_weight`` pseudo-steps at every vertex, and eq. 2's kernel-weighted counts K
(:func:`~app.core.player_models.kernel_counts`, radius ``radius``) are the evidence::

    P(c | v) = (K[v, c] + prior_weight * P_h(c | v)) / (sum_c K[v, c] + prior_weight)

Where players went often their choices rule; where the kernel reaches no visited state
the model is P_h exactly, so the ranking there is sr-heuristic's. The radius and the
prior weight are chosen by the held-out log-likelihood of whole sessions' controls
(:class:`~app.core.session_folds.SessionFolds`). Pure numpy/scipy.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from app.core.crowd_play import PlayCounts
from app.core.model_checks import check_counts, check_distributions
from app.core.player_models import PlayerModelKind, kernel_counts
from app.core.session_folds import FOLDS, LearnedModel, SessionFolds, held_out_score

#: the crowd models ranked for a population a share of which the traces have not seen
#: (app.core.strategies.mixed_weights): ``mixed-forward`` also chooses its radius and
#: weight otherwise, ``mixed-fresh`` weighs the counts (app.core.fresh_evidence),
#: ``mixed-error`` and ``mixed-held`` choose the share (app.core.error_share),
#: ``mixed-split`` gives each kind of player its own share of growth (strategies)
MIXED_KINDS = frozenset(
    {
        PlayerModelKind.MIXED,
        PlayerModelKind.MIXED_FORWARD,
        PlayerModelKind.MIXED_FRESH,
        PlayerModelKind.MIXED_ERROR,
        PlayerModelKind.MIXED_SPLIT,
        PlayerModelKind.MIXED_HELD,
    }
)
#: the crowd models whose P(c|v) is :func:`shrunk_player_model`
SHRUNK_KINDS = MIXED_KINDS | {PlayerModelKind.SHRUNK}

#: kernel radii tried, in multiples of the dynamics' eq. 2 radius
RADIUS_SCALES = (0.5, 1.0, 2.0, 4.0)
#: pseudo-steps of the heuristic prior tried against the kernel counts
PRIOR_WEIGHTS = (0.3, 1.0, 3.0, 10.0, 30.0)


def shrunk_player_model(
    descriptors: np.ndarray,
    vertex_control: np.ndarray,
    control_counts: np.ndarray,
    radius: float,
    prior_weight: float,
    *,
    prior: np.ndarray,
) -> np.ndarray:
    r"""P(c|v) for every vertex: eq. 2's kernel counts plus ``prior_weight`` pseudo-steps
    of ``prior`` (the heuristic model), normalised per row.

    .. math:: P(c|v) = \frac{K_r[v, c] + m\, P_h(c|v)}{\sum_{c'} K_r[v, c'] + m}

    Parameters
    ----------
    descriptors : ndarray, shape (V, D)
    vertex_control : ndarray of int, shape (V,)
    control_counts : ndarray, shape (V, N)
        :func:`~app.core.player_models.observed_control_counts` of the traces.
    radius : float
        Kernel radius r > 0 in descriptor space.
    prior_weight : float
        m > 0: how many steps of evidence weigh as much as the prior.
    prior : ndarray, shape (V, N)
        Rows are probability distributions (:func:`heuristic_player_model`).

    Returns
    -------
    ndarray, shape (V, N)
    """
    prior = np.asarray(prior, dtype=np.float64)
    counts = np.asarray(control_counts, dtype=np.float64)
    if prior.shape != counts.shape:
        raise ValueError(f"prior {prior.shape} and counts {counts.shape} must be one (V, N)")
    check_distributions(prior, "prior")
    check_counts(counts)
    if radius <= 0.0:
        raise ValueError(f"radius must be positive, got {radius}")
    if prior_weight <= 0.0:
        raise ValueError(f"prior_weight must be positive, got {prior_weight}")
    evidence = kernel_counts(descriptors, vertex_control, counts, radius)
    return (evidence + prior_weight * prior) / (evidence.sum(axis=1, keepdims=True) + prior_weight)


@dataclass(frozen=True)
class ShrunkFit:
    """The radius and prior weight chosen, and every candidate's held-out log-likelihood
    per step, keyed ``(radius, prior_weight)``."""

    radius: float
    prior_weight: float
    cv_scores: dict[tuple[float, float], float] = field(default_factory=dict)


def fit_shrunk_model(
    descriptors: np.ndarray,
    vertex_control: np.ndarray,
    play: PlayCounts,
    prior: np.ndarray,
    base_radius: float,
    *,
    radius_scales: Sequence[float] = RADIUS_SCALES,
    prior_weights: Sequence[float] = PRIOR_WEIGHTS,
    folds: int = FOLDS,
    latest: PlayCounts | None = None,
) -> ShrunkFit:
    """The (radius, prior weight) whose model best predicts held-out sessions' controls
    (``play``: the sessions' summed counts).

    Held out are ``folds`` folds of ``play``'s sessions, or, given ``latest`` (the
    sessions of the latest publication, ``play`` those of the ones before it), ``latest``
    under the model learnt from ``play``: growth's question, how the players of a graph
    that has grown since choose (docs/player-models.md, "`mixed-forward`"). Radii are
    ``base_radius`` times ``radius_scales``. Ties go to the smaller radius, then the
    larger prior weight (the model closer to the heuristic). Raises ValueError when no
    trace has a step.
    """
    prior = np.asarray(prior, dtype=np.float64)
    n_vertices, n_controls = prior.shape
    if latest is None:
        score = SessionFolds.of(play, n_vertices, n_controls, folds).score
    else:
        learnt = play.control_counts(n_vertices, n_controls)
        held = latest.control_counts(n_vertices, n_controls)

        def score(learned: LearnedModel) -> float:
            return held_out_score(learned, learnt, held)

    def model(radius: float, weight: float) -> LearnedModel:
        return lambda counts: shrunk_player_model(
            descriptors, vertex_control, counts, radius, weight, prior=prior
        )

    candidates = [(base_radius * s, float(m)) for s in radius_scales for m in prior_weights]
    scores = {key: score(model(*key)) for key in candidates}
    radius, weight = max(scores, key=lambda key: (scores[key], -key[0], key[1]))
    return ShrunkFit(radius, weight, scores)
