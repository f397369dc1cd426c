"""The share of heuristic players ``mixed-error`` ranks for: the error-weighted log score
by hand, the share it chooses on the latest publication's players, and the refiner that
ranks with it."""

from __future__ import annotations

import math

import numpy as np
import pytest
from refiner_helpers import toy_refiners

from app.core.graph.publication import Publication, freeze
from app.core.graph.staterank import predicted_edge_probabilities
from app.core.growth.kinds import Strategy
from app.core.growth.refinement import Refiner
from app.core.growth.strategies import edge_weights, mixed_weights
from app.core.players.crowd_models.mixed import UNSEEN_SHARE
from app.core.players.crowd_models.mixed_error import (
    SHARES,
    FittedMixedError,
    ShareFit,
    error_weighted_score,
    fit_error_share,
)
from app.core.players.crowd_play import PlayCounts
from app.core.players.kinds import PlayerModelKind


def test_the_score_is_the_error_weighted_mean_log_share_by_hand() -> None:
    weights = np.array([0.5, 0.3, 0.2])
    # only the step that met error counts, however many met none
    assert error_weighted_score(weights, np.array([2, 0, 1]), np.array([0.0, 0.1, 0.4])) == (
        pytest.approx(math.log(0.2))
    )
    by_hand = (0.2 * math.log(0.5) + 0.1 * math.log(0.3) + 2 * 0.1 * math.log(0.2)) / 0.5
    assert error_weighted_score(
        weights, np.array([1, 1, 2]), np.array([0.2, 0.1, 0.1])
    ) == pytest.approx(by_hand)
    with pytest.raises(ValueError, match="no step met error"):
        error_weighted_score(weights, np.array([1, 1, 0]), np.array([0.0, 0.0, 0.3]))


def _chain(err: list[float]) -> Publication:
    """0 -> 1 -> 2 -> 3 on control 0, control 1 back to 0; ``err`` per edge v * 2 + c."""
    edges = np.array([1, 0, 2, 0, 3, 0, 3, 0], dtype=np.int64)
    return Publication(2, 0, edges, np.zeros(8, np.int8), np.asarray(err, float), np.zeros(8))


def _uniform_blend(counts: np.ndarray) -> np.ndarray:
    """A model of the counts: one pseudo-step of each control per vertex."""
    return (counts + 1.0) / (counts.sum(axis=1, keepdims=True) + counts.shape[1])


#: the earlier crowd kept control 0 all along the chain
ROUTE = PlayCounts.of_traces([np.array([[0, 0], [1, 0], [2, 0], [3, 0]])] * 30)
UNIFORM = np.full((4, 2), 0.5)


@pytest.mark.parametrize(
    ("latest_steps", "err", "chosen"),
    [
        # the latest players met error where the earlier crowd never went: vertex 1's turn
        ([[0, 0], [1, 1]], [0, 0, 0, 0.5, 0, 0, 0, 0], 0.9),
        # they met it on the crowd's route: vertex 2's control 0
        ([[0, 0], [1, 0], [2, 0]], [0, 0, 0, 0, 0.5, 0, 0, 0], 0.25),
    ],
)
def test_the_share_is_the_one_that_best_scores_where_the_latest_players_met_error(
    latest_steps: list[list[int]], err: list[float], chosen: float
) -> None:
    then, latest = _chain([0.0] * 8), _chain(err)
    later = PlayCounts.of_traces([np.array(latest_steps)] * 5, first=ROUTE.sessions)
    fit = fit_error_share([(then, ROUTE), (latest, later)], _uniform_blend, UNIFORM, 4, 0.1)
    crowd = predicted_edge_probabilities(
        latest.edge_dst, _uniform_blend(ROUTE.control_counts(4, 2)), 0, 0.1
    )
    prior = predicted_edge_probabilities(latest.edge_dst, UNIFORM, 0, 0.1)
    steps = later.control_counts(4, 2).reshape(-1)
    by_hand = {
        s: error_weighted_score((1 - s) * crowd + s * prior, steps, latest.edge_err) for s in SHARES
    }
    assert fit.scores == pytest.approx(by_hand)
    assert fit.share == chosen == max(by_hand, key=lambda s: by_hand[s])


def test_without_a_later_publication_that_met_error_the_share_is_mixeds() -> None:
    then = _chain([0.0] * 8)
    assert fit_error_share([(then, ROUTE)], _uniform_blend, UNIFORM, 4, 0.1) == ShareFit(
        UNSEEN_SHARE
    )
    later = PlayCounts.of_traces([np.array([[0, 0], [1, 1]])] * 5, first=ROUTE.sessions)
    # the latest players met no error: they say nothing about where it lies
    assert fit_error_share(
        [(then, ROUTE), (then, later)], _uniform_blend, UNIFORM, 4, 0.1
    ) == ShareFit(UNSEEN_SHARE)


def share_fit(refiner: Refiner) -> ShareFit:
    """The share ``refiner``'s ``mixed-error`` model chose, with every share's score."""
    fitted = refiner.crowd_model()
    assert isinstance(fitted, FittedMixedError)
    return fitted.share


def assert_ranks_mixed(refiner: Refiner, share: float) -> None:
    """``refiner`` ranks for its crowd model mixed with ``share`` heuristic players."""
    restart = refiner.restart
    crowd = edge_weights(Strategy.SR_CROWD, refiner.graph, refiner.player_model(), restart=restart)
    heuristic = edge_weights(
        Strategy.SR_CROWD, refiner.graph, refiner.heuristic_model(), restart=restart
    )
    np.testing.assert_allclose(
        refiner.weights().weights, mixed_weights(crowd, heuristic, share).weights, rtol=1e-6
    )


def test_mixed_error_ranks_with_the_share_it_chose() -> None:
    mixed, error = toy_refiners(PlayerModelKind.MIXED, PlayerModelKind.MIXED_ERROR)
    published = freeze(error.graph)
    first = PlayCounts.of_traces([np.array([[0, 1], [1, 1], [3, 1]]), np.array([[0, 1], [1, 1]])])
    for refiner in (mixed, error):
        refiner.learn_counts(first, published)
    # one publication's players: nothing to choose on, the ranking is mixed's
    assert share_fit(error) == ShareFit(UNSEEN_SHARE)
    np.testing.assert_array_equal(error.weights().weights, mixed.weights().weights)
    # later players walk where the first did not, into the tree's blends
    blends = np.flatnonzero(published.edge_err > 0)
    vertex, control = divmod(int(blends[0]), published.n_controls)
    path = PlayCounts.of_traces([np.array([[vertex, control]])] * 4, first=first.sessions)
    for refiner in (mixed, error):
        refiner.learn_counts(path, published)
    fit = share_fit(error)
    assert set(fit.scores) == set(SHARES) and fit.share == max(fit.scores, key=fit.scores.get)
    assert mixed.crowd_model().unseen_share == UNSEEN_SHARE
    np.testing.assert_array_equal(error.player_model(), mixed.player_model())
    assert_ranks_mixed(error, fit.share)


def test_mixed_error_needs_every_sessions_publication() -> None:
    (error,) = toy_refiners(PlayerModelKind.MIXED_ERROR)
    error.learn([np.array([[0, 1], [1, 1]])])
    with pytest.raises(ValueError, match="crowd model needs every session's publication"):
        error.weights()
