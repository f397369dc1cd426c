"""``mixed-error``: ``mixed``, its share of heuristic players chosen by where the latest
players met error (docs/player-models.md, "`mixed-error`"); the default crowd model.

``mixed`` ranks for a population half of which plays as the heuristic model says. On one
world in three the goal-directed crowd still loses at 20,000 frames: a sixth of its
players' steps fell on edges the learnt model gave less than a tenth of the heuristic's
play, and half of the error they met lay there, while per step the learnt model predicted
them better than the heuristic one. A per-step likelihood weighs the many steps on the
crowd's route; growth only cares about the steps that meet a blend. So the share is
chosen here by the error-weighted log score: over the error the latest publication's
players met, the mean log of the share of play the ranking's population, learnt from the
earlier publications' sessions, put on the edge where they met it. Pure numpy.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from app.core.graph.publication import Publication
from app.core.graph.staterank import predicted_edge_probabilities
from app.core.players.crowd_models.estimator import CrowdGraph, CrowdPlay
from app.core.players.crowd_models.mixed import UNSEEN_SHARE
from app.core.players.crowd_models.shrunk import FittedShrunk, Shrunk
from app.core.players.crowd_play import PlayCounts
from app.core.players.kinds import PlayerModelKind

#: shares of heuristic players tried; ``mixed``'s (UNSEEN_SHARE) among them
SHARES = (0.25, 0.5, 0.75, 0.9)
#: a player model of the control counts it learns from: (V, N) counts in, P(c|v) out
CountsModel = Callable[[np.ndarray], np.ndarray]


@dataclass(frozen=True)
class ShareFit:
    """The share chosen, and every candidate's error-weighted log score, keyed by share
    (empty where nothing was scored)."""

    share: float
    scores: dict[float, float] = field(default_factory=dict)


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
) -> ShareFit:
    """The share of heuristic players under which the ranking's population, the crowd
    ``model`` learnt from every publication's sessions but the latest mixed with the
    ``heuristic`` P(c|v), best scores where the latest's players met error
    (:func:`error_weighted_score`), both predicted by STATERANK on the latest
    publication. ``mixed``'s share before two publications' sessions or when the
    latest's met no error; ties go to the share nearest it."""
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
    return ShareFit(share, scores)


class MixedError:
    """``mixed`` whose share of heuristic players is chosen where the latest
    publication's players met error; it reads every session's publication."""

    kind: ClassVar[PlayerModelKind] = PlayerModelKind.MIXED_ERROR
    reads_publications: ClassVar[bool] = True

    def fit(self, graph: CrowdGraph, play: CrowdPlay) -> FittedMixedError:
        shrunk = Shrunk().fit(graph, play)
        share = fit_error_share(
            play.published(),
            lambda counts: shrunk.of_counts(graph, counts),
            graph.heuristic,
            graph.n_vertices,
            play.restart,
        )
        return FittedMixedError(shrunk, share)


@dataclass(frozen=True)
class FittedMixedError:
    """``shrunk``'s fit and the share of heuristic players chosen."""

    shrunk: FittedShrunk
    share: ShareFit

    @property
    def unseen_share(self) -> float:
        return self.share.share

    def player_model(self, graph: CrowdGraph) -> np.ndarray:
        return self.shrunk.player_model(graph)

    def figures(self) -> dict[str, Any]:
        return self.shrunk.figures() | {
            "unseen_share": self.share.share,
            "share_scores": {f"{s:g}": round(v, 6) for s, v in self.share.scores.items()},
        }
