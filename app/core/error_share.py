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

``mixed-residual`` scores the same populations by what growth under each would have left
the latest players: the error they met on the edges growth would not have reached, had
it replaced the blends that population ranks first, as many as growth made between the
two latest publications (docs/player-models.md, "`mixed-residual`"). Pure numpy.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from app.core.crowd_play import PlayCounts
from app.core.graph import EdgeKind
from app.core.metrics import predicted_edge_probabilities
from app.core.publication import Publication
from app.core.strategies import UNSEEN_SHARE

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


def residual_error(
    weights: np.ndarray, steps: np.ndarray, edge_err: np.ndarray, blend: np.ndarray, budget: int
) -> float:
    """The error per step players would still have met (``steps`` on edge e, each meeting
    ``edge_err[e]``) had growth replaced the ``budget`` blends (``blend`` mask) with the
    largest ``weights[e] * edge_err[e]`` by simulation, which meets none.

    Growth pops blends by that priority (app.core.growth.select_for_expansion); this is
    its first pop without relinking and without the blends an expansion adds.
    """
    steps = np.asarray(steps, np.float64)
    edge_err = np.asarray(edge_err, np.float64)
    candidates = np.flatnonzero(blend)
    priority = weights[candidates] * edge_err[candidates]
    # stable on ties, so that equal rankings leave equal residuals
    chosen = candidates[np.argsort(-priority, kind="stable")[: max(budget, 0)]]
    left = steps * edge_err
    left[chosen] = 0.0
    return float(left.sum() / max(float(steps.sum()), 1.0))


@dataclass(frozen=True)
class _Populations:
    """What a share is scored on: the latest publication, its players' steps per edge,
    and the share of play the crowd (learnt from the earlier sessions) and the heuristic
    model put on each of its edges by STATERANK."""

    latest: Publication
    steps: np.ndarray
    crowd: np.ndarray
    prior: np.ndarray
    #: vertices growth added between the two latest publications: its expansions
    grown: int

    def mix(self, share: float) -> np.ndarray:
        return (1.0 - share) * self.crowd + share * self.prior


def _populations(
    played: Sequence[tuple[Publication, PlayCounts]],
    model: CountsModel,
    heuristic: np.ndarray,
    n_vertices: int,
    restart: float,
) -> _Populations | None:
    """None before two publications' sessions, or when the latest's met no error: such
    players say nothing about where error lies."""
    played = [(then, play) for then, play in played if play.sessions]
    if len(played) < 2:
        return None
    latest, play = played[-1]
    vertices, controls = latest.n_vertices, latest.n_controls
    steps = play.control_counts(vertices, controls).reshape(-1)
    if float(np.sum(steps * latest.edge_err)) <= 0.0:
        return None
    learnt = PlayCounts.merged([p for _, p in played[:-1]]).control_counts(n_vertices, controls)

    def ranked(model_of_vertices: np.ndarray) -> np.ndarray:
        return predicted_edge_probabilities(
            latest.edge_dst, model_of_vertices[:vertices], latest.start, restart
        )

    return _Populations(
        latest, steps, ranked(model(learnt)), ranked(heuristic), vertices - played[-2][0].n_vertices
    )


def _nearest_unseen(scores: dict[float, float]) -> float:
    """The share with the highest score, ties to the one nearest ``mixed``'s."""
    return max(scores, key=lambda s: (scores[s], -abs(s - UNSEEN_SHARE)))


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
    parts = _populations(played, model, heuristic, n_vertices, restart)
    if parts is None:
        return ShareFit(UNSEEN_SHARE)
    scores = {
        float(share): error_weighted_score(parts.mix(share), parts.steps, parts.latest.edge_err)
        for share in shares
    }
    return ShareFit(_nearest_unseen(scores), scores)


def fit_residual_share(
    played: Sequence[tuple[Publication, PlayCounts]],
    model: CountsModel,
    heuristic: np.ndarray,
    n_vertices: int,
    restart: float,
    *,
    shares: Sequence[float] = SHARES,
) -> ShareFit:
    """The share whose population, ranking the latest publication's blends for growth
    as many as growth made since the publication before, would have left the latest's
    players the least error (:func:`residual_error`; ``scores`` are those residuals,
    lower better). The log score rewards every further step of weight put where error
    was met; a residual stops rewarding once growth would have reached it, and then the
    tie goes to the share nearest ``mixed``'s, the one that protects unseen players
    most evenly. ``mixed``'s share where :func:`fit_error_share` has it too."""
    parts = _populations(played, model, heuristic, n_vertices, restart)
    if parts is None:
        return ShareFit(UNSEEN_SHARE)
    blend = parts.latest.edge_kind == EdgeKind.BLEND
    residuals = {
        float(share): residual_error(
            parts.mix(share), parts.steps, parts.latest.edge_err, blend, parts.grown
        )
        for share in shares
    }
    share = _nearest_unseen({s: -r for s, r in residuals.items()})
    return ShareFit(share, residuals)
