"""``shrunk``: eq. 2's evidence shrunk toward the heuristic model, state by state
(docs/player-models.md, "`shrunk`").

sr-crowd must never rank worse than sr-heuristic for having read traces. A learned model
that extrapolates the crowd's choices to states nobody played sends STATERANK's mass down
the crowd's old paths, and a growing graph adds most of its states where no session has
been: there the extrapolation is a confident guess, and the blends on the branches it
rules out stay unrefined until players fall into them.

Here the heuristic model P_h (what sr-heuristic ranks with) is a Dirichlet prior of
``prior_weight`` pseudo-steps at every vertex, and eq. 2's kernel-weighted counts K
(:func:`~app.core.players.crowd_models.kernel.kernel_counts`, radius ``radius``) are the evidence::

    P(c | v) = (K[v, c] + prior_weight * P_h(c | v)) / (sum_c K[v, c] + prior_weight)

Where players went often their choices rule; where the kernel reaches no visited state
the model is P_h exactly, so the ranking there is sr-heuristic's. The radius and the
prior weight are chosen by the held-out log-likelihood of whole sessions' controls
(:class:`~app.core.players.session_folds.SessionFolds`). Pure numpy/scipy.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from app.core.players.crowd_models.estimator import CrowdGraph, CrowdPlay
from app.core.players.crowd_models.kernel import kernel_counts
from app.core.players.crowd_play import PlayCounts
from app.core.players.kinds import PlayerModelKind
from app.core.players.model_checks import check_counts, check_distributions
from app.core.players.session_folds import FOLDS, LearnedModel, SessionFolds

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
        :func:`~app.core.players.player_models.observed_control_counts` of the traces.
    radius : float
        Kernel radius r > 0 in descriptor space.
    prior_weight : float
        m > 0: how many steps of evidence weigh as much as the prior.
    prior : ndarray, shape (V, N)
        Rows are probability distributions
        (:func:`~app.core.players.player_models.heuristic_player_model`).

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
) -> ShrunkFit:
    """The (radius, prior weight) whose model best predicts held-out sessions' controls
    (``play``: the sessions' summed counts), ``folds`` folds of them in turn.

    Radii are ``base_radius`` times ``radius_scales``. Ties go to the smaller radius,
    then the larger prior weight (the model closer to the heuristic). Raises ValueError
    when no trace has a step.
    """
    prior = np.asarray(prior, dtype=np.float64)
    n_vertices, n_controls = prior.shape
    score = SessionFolds.of(play, n_vertices, n_controls, folds).score

    def model(radius: float, weight: float) -> LearnedModel:
        return lambda counts: shrunk_player_model(
            descriptors, vertex_control, counts, radius, weight, prior=prior
        )

    candidates = [(base_radius * s, float(m)) for s in radius_scales for m in prior_weights]
    scores = {key: score(model(*key)) for key in candidates}
    radius, weight = max(scores, key=lambda key: (scores[key], -key[0], key[1]))
    return ShrunkFit(radius, weight, scores)


class Shrunk:
    """Eq. 2's evidence over the heuristic model as a prior, its radius and prior weight
    chosen by 5-fold cross-validation over whole sessions."""

    kind: ClassVar[PlayerModelKind] = PlayerModelKind.SHRUNK
    reads_publications: ClassVar[bool] = False

    def fit(self, graph: CrowdGraph, play: CrowdPlay) -> FittedShrunk:
        chosen = fit_shrunk_model(
            graph.descriptors, graph.vertex_control, play.all, graph.heuristic, graph.radius
        )
        return FittedShrunk(play, chosen)


@dataclass(frozen=True)
class FittedShrunk:
    """``shrunk`` with its radius and prior weight chosen; ``unseen_share`` is the share of
    heuristic players growth ranks for beside its crowd (``mixed``), None for none."""

    play: CrowdPlay
    chosen: ShrunkFit
    unseen_share: float | None = None

    def player_model(self, graph: CrowdGraph) -> np.ndarray:
        return self.of_counts(graph, self.play.counts(graph))

    def of_counts(self, graph: CrowdGraph, counts: np.ndarray) -> np.ndarray:
        """P(c|v) on ``graph`` learnt from the (V, N) control ``counts`` instead."""
        return shrunk_player_model(
            graph.descriptors,
            graph.vertex_control,
            counts,
            self.chosen.radius,
            self.chosen.prior_weight,
            prior=graph.heuristic,
        )

    def figures(self) -> dict[str, Any]:
        return {
            "radius": self.chosen.radius,
            "prior_weight": self.chosen.prior_weight,
            "cv_scores": {
                f"{r:.6g}/{m:g}": round(v, 6) for (r, m), v in self.chosen.cv_scores.items()
            },
        }
