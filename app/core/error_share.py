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

``mixed-held`` applies a share other than one half only once the share chosen the time
before held on the next players (docs/player-models.md, "`mixed-held`"): at 5,000 frames
``mixed-error`` chose the fewest heuristic players on every selection world, the next
players left the route the last ones had met their error on, and the graph dipped.
Pure numpy.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from app.core.crowd_play import PlayCounts
from app.core.metrics import predicted_edge_probabilities
from app.core.player_models import PlayerModelKind
from app.core.publication import Publication
from app.core.strategies import UNSEEN_SHARE

#: shares of heuristic players tried; ``mixed``'s (UNSEEN_SHARE) among them
SHARES = (0.25, 0.5, 0.75, 0.9)
#: the crowd models whose share of heuristic players is chosen here
ERROR_SHARE_KINDS = frozenset({PlayerModelKind.MIXED_ERROR, PlayerModelKind.MIXED_HELD})
#: a player model of the control counts it learns from: (V, N) counts in, P(c|v) out
CountsModel = Callable[[np.ndarray], np.ndarray]


@dataclass(frozen=True)
class ShareFit:
    """The share chosen, and every candidate's error-weighted log score, keyed by share
    (empty where nothing was scored)."""

    share: float
    scores: dict[float, float] = field(default_factory=dict)
    #: for a held fit, the share chosen on the publications before the latest (None
    #: where none was chosen): the choice is applied only if that one held
    before: float | None = None


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
    return float(np.sum(mass[met] * np.log(np.maximum(weights[met], 1e-300))) / total)


def fit_error_share(
    played: Sequence[tuple[Publication, PlayCounts]],
    model: CountsModel,
    heuristic: np.ndarray,
    n_vertices: int,
    restart: float,
    *,
    shares: Sequence[float] = SHARES,
    held: bool = False,
) -> ShareFit:
    """The share of heuristic players under which the ranking's population, the crowd
    ``model`` learnt from every publication's sessions but the latest mixed with the
    ``heuristic`` P(c|v), best scores where the latest's players met error
    (:func:`error_weighted_score`), both predicted by STATERANK on the latest
    publication. ``mixed``'s share before two publications' sessions or when the
    latest's met no error; ties go to the share nearest it.

    With ``held``, the share chosen on the publications before the latest must score at
    least as well as one half on the latest's players (its forecast held) for the new
    choice to be applied; otherwise, and before any earlier choice, the share is one half.
    A choice of one half moved nothing and has nothing to hold."""
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
    if not held:
        return ShareFit(share, scores)
    before = fit_error_share(played[:-1], model, heuristic, n_vertices, restart, shares=shares)
    if not before.scores:
        return ShareFit(UNSEEN_SHARE, scores)
    kept = scores[before.share] >= scores[UNSEEN_SHARE]
    return ShareFit(share if kept else UNSEEN_SHARE, scores, before.share)
