"""The share of heuristic players a ``mixed`` ranking assumes, chosen by where the latest
players met error (docs/player-models.md, "`mixed-error`").

``mixed`` ranks for a population half of which plays as the heuristic model says. On one
world in three the goal-directed crowd still loses at 20,000 frames: a sixth of its
players' steps fell on edges the learnt model gave less than a tenth of the heuristic's
play, and half of the error they met lay there, while per step the learnt model predicted
them better than the heuristic one. A per-step likelihood weighs the many steps on the
crowd's route; growth only cares about the steps that meet a blend. So the share is
chosen here by the error-weighted log score: over the error the latest publication's
players met, the mean log of the share of play the ranking's population, learnt from the
earlier publications' sessions, put on the edge where they met it.

``mixed-sure`` moves the share from one half only where the latest players' sessions are
sure of the move (docs/player-models.md, "`mixed-sure`"): at 5,000 frames ``mixed-error``
chose the fewest heuristic players on every selection world and dipped at 10,000, as the
next players left the route the last ones had met their error on. Pure numpy and scipy.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
from scipy import stats

from app.core.crowd_play import FOLD_BUCKETS, PlayCounts
from app.core.metrics import predicted_edge_probabilities
from app.core.player_models import PlayerModelKind
from app.core.publication import Publication
from app.core.strategies import UNSEEN_SHARE

#: shares of heuristic players tried; ``mixed``'s (UNSEEN_SHARE) among them
SHARES = (0.25, 0.5, 0.75, 0.9)
#: the crowd models whose share of heuristic players is chosen here
ERROR_SHARE_KINDS = frozenset({PlayerModelKind.MIXED_ERROR, PlayerModelKind.MIXED_SURE})
#: ``mixed-sure``'s confidence that a share gains over one half, all shares tried together
SURE_LEVEL = 0.95
#: a player model of the control counts it learns from: (V, N) counts in, P(c|v) out
CountsModel = Callable[[np.ndarray], np.ndarray]


@dataclass(frozen=True)
class ShareFit:
    """The share chosen, and every candidate's error-weighted log score, keyed by share
    (empty where nothing was scored)."""

    share: float
    scores: dict[float, float] = field(default_factory=dict)
    #: for a sure fit, the lower end of the best other share's gain over one half, in
    #: units of the score (:func:`sure_gain`); None where nothing was tested
    lower: float | None = None


def error_weighted_score(weights: np.ndarray, steps: np.ndarray, edge_err: np.ndarray) -> float:
    """Mean over the error players met, edge by edge (``steps`` on edge e, each meeting
    ``edge_err[e]``), of log ``weights[e]``, the share of play a ranking put there.

    ValueError when no step met error: such players say nothing about where error lies.
    """
    mass = np.asarray(steps, np.float64) * np.asarray(edge_err, np.float64)
    total = float(mass.sum())
    if total <= 0.0:
        raise ValueError("no step met error: nothing to score")
    met = mass > 0.0
    return float(np.sum(mass[met] * _log(weights[met])) / total)


def _log(weights: np.ndarray) -> np.ndarray:
    """log of shares of play, a share of zero as the least positive double's."""
    return np.log(np.maximum(weights, 1e-300))


def sure_gain(log_gain: np.ndarray, groups: np.ndarray, level: float, tests: int) -> float:
    """The lower end of a one-sided Student t bound, at ``level`` split over ``tests``
    (Bonferroni), on the mean over session groups of what a share gains over another:
    ``log_gain[e]`` is the difference of their log shares of play on edge e, ``groups``
    (G, E) the error each group of sessions met there. In units of the score (the gain
    divided by the mean error a group met); -inf with fewer than two groups that met error.
    """
    mass = groups.sum(axis=1)
    met = mass > 0.0
    if int(met.sum()) < 2:
        return float("-inf")
    gains = groups[met] @ log_gain
    n = gains.size
    spread = float(np.std(gains, ddof=1)) / np.sqrt(n)
    quantile = float(stats.t.ppf(1.0 - (1.0 - level) / tests, n - 1))
    return float((np.mean(gains) - quantile * spread) / np.mean(mass[met]))


def fit_error_share(
    played: Sequence[tuple[Publication, PlayCounts]],
    model: CountsModel,
    heuristic: np.ndarray,
    n_vertices: int,
    restart: float,
    *,
    shares: Sequence[float] = SHARES,
    sure: float | None = None,
) -> ShareFit:
    """The share of heuristic players under which the ranking's population, the crowd
    ``model`` learnt from every publication's sessions but the latest mixed with the
    ``heuristic`` P(c|v), best scores where the latest's players met error
    (:func:`error_weighted_score`), both predicted by STATERANK on the latest
    publication. ``mixed``'s share before two publications' sessions or when the
    latest's met no error; ties go to the share nearest it.

    With ``sure`` (a confidence level), the best share replaces ``mixed``'s only where
    its gain over it is sure at that level across the latest publication's session
    groups, the sessions of one ordinal bucket each (:func:`sure_gain`)."""
    played = [(then, play) for then, play in played if play.sessions]
    if len(played) < 2:
        return ShareFit(UNSEEN_SHARE)
    latest, play = played[-1]
    vertices, controls = latest.n_vertices, latest.n_controls
    steps = play.control_counts(vertices, controls).reshape(-1)
    if float(np.sum(steps * latest.edge_err)) <= 0.0:
        return ShareFit(UNSEEN_SHARE)
    learnt = PlayCounts.merged([p for _, p in played[:-1]]).control_counts(n_vertices, controls)
    crowd = predicted_edge_probabilities(
        latest.edge_dst, model(learnt)[:vertices], latest.start, restart
    )
    prior = predicted_edge_probabilities(
        latest.edge_dst, heuristic[:vertices], latest.start, restart
    )
    scores = {
        float(share): error_weighted_score(
            (1.0 - share) * crowd + share * prior, steps, latest.edge_err
        )
        for share in shares
    }
    share = max(scores, key=lambda s: (scores[s], -abs(s - UNSEEN_SHARE)))
    if sure is None or share == UNSEEN_SHARE:
        return ShareFit(share, scores)
    groups = (
        np.stack([f.reshape(-1) for f in play.fold_counts(FOLD_BUCKETS, vertices, controls)])
        * latest.edge_err
    )
    best, half = ((1.0 - s) * crowd + s * prior for s in (share, UNSEEN_SHARE))
    lower = sure_gain(_log(best) - _log(half), groups, sure, len(scores) - 1)
    return ShareFit(share if lower > 0.0 else UNSEEN_SHARE, scores, lower)
