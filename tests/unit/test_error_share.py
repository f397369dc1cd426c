"""The share of heuristic players ``mixed-error`` ranks for: the error-weighted log score
by hand, the share it chooses on the latest publication's players, ``mixed-held``'s check of
the choice made the time before, and the refiners that rank with them."""

from __future__ import annotations

import math

import numpy as np
import pytest
from refiner_helpers import toy_refiners

from app.core.crowd_play import PlayCounts
from app.core.error_share import SHARES, ShareFit, error_weighted_score, fit_error_share
from app.core.metrics import predicted_edge_probabilities
from app.core.player_models import PlayerModelKind
from app.core.publication import Publication, freeze
from app.core.refinement import Refiner
from app.core.strategies import (
    UNSEEN_SHARE,
    EdgeWeights,
    Strategy,
    edge_weights,
    mixed_weights,
    split_weights,
)


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


#: players who turn at vertex 1, where the earlier crowd never went, and players who keep
#: to its route to vertex 2; each meets a blend there
TURN, KEEP = np.array([[0, 0], [1, 1]]), np.array([[0, 0], [1, 0], [2, 0]])


@pytest.mark.parametrize(
    ("middle", "latest", "before", "chosen"),
    [
        # the middle players turned (more heuristic players, 0.9), the latest did too: held
        (TURN, TURN, 0.9, 0.9),
        # they kept to the route (0.25), the latest did too: held
        (KEEP, KEEP, 0.25, 0.25),
        # they kept to it, the latest left it: 0.25 scores below one half, which stays
        (KEEP, TURN, 0.25, UNSEEN_SHARE),
        (TURN, KEEP, 0.9, UNSEEN_SHARE),
    ],
)
def test_mixed_held_applies_its_choice_only_once_the_one_before_held(
    middle: np.ndarray, latest: np.ndarray, before: float, chosen: float
) -> None:
    err = _chain([0, 0, 0, 0.5, 0.5, 0, 0, 0])
    played = [
        (_chain([0.0] * 8), ROUTE),
        (err, PlayCounts.of_traces([middle] * 5, first=30)),
        (err, PlayCounts.of_traces([latest] * 5, first=35)),
    ]
    plain = fit_error_share(played, _uniform_blend, UNIFORM, 4, 0.1)
    held = fit_error_share(played, _uniform_blend, UNIFORM, 4, 0.1, held=True)
    earlier = fit_error_share(played[:2], _uniform_blend, UNIFORM, 4, 0.1)
    assert held == ShareFit(chosen, plain.scores, before) and earlier.share == before
    assert (chosen == plain.share) == (plain.scores[before] >= plain.scores[UNSEEN_SHARE])
    # with no choice made before (two publications), nothing has held: one half
    two = played[:1] + played[2:]
    first = fit_error_share(two, _uniform_blend, UNIFORM, 4, 0.1, held=True)
    assert first == ShareFit(
        UNSEEN_SHARE, fit_error_share(two, _uniform_blend, UNIFORM, 4, 0.1).scores
    )


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
    assert error.share_fit() == ShareFit(UNSEEN_SHARE)
    np.testing.assert_array_equal(error.weights().weights, mixed.weights().weights)
    # later players walk where the first did not, into the tree's blends
    blends = np.flatnonzero(published.edge_err > 0)
    vertex, control = divmod(int(blends[0]), published.n_controls)
    path = PlayCounts.of_traces([np.array([[vertex, control]])] * 4, first=first.sessions)
    for refiner in (mixed, error):
        refiner.learn_counts(path, published)
    fit = error.share_fit()
    assert set(fit.scores) == set(SHARES) and fit.share == max(fit.scores, key=fit.scores.get)
    assert mixed.share_fit() == ShareFit(UNSEEN_SHARE)
    np.testing.assert_array_equal(error.player_model(), mixed.player_model())
    assert_ranks_mixed(error, fit.share)


def test_mixed_held_ranks_with_its_checked_share() -> None:
    error, held = toy_refiners(PlayerModelKind.MIXED_ERROR, PlayerModelKind.MIXED_HELD)
    published = freeze(error.graph)
    first = PlayCounts.of_traces([np.array([[0, 1], [1, 1], [3, 1]]), np.array([[0, 1], [1, 1]])])
    blends = np.flatnonzero(published.edge_err > 0)
    for refiner in (error, held):
        refiner.learn_counts(first, published)
        for ordinal, blend in enumerate(blends[:2]):
            vertex, control = divmod(int(blend), published.n_controls)
            path = np.array([[vertex, control]])
            refiner.learn_counts(PlayCounts.of_traces([path] * 4, 2 + 4 * ordinal), published)
    checked = fit_error_share(
        held.published_play(),
        held.shrunk_model,
        held.heuristic_model(),
        held.graph.n_vertices,
        held.restart,
        held=True,
    )
    assert held.share_fit() == checked and checked.scores == error.share_fit().scores
    assert checked.before is not None and error.share_fit().before is None
    assert_ranks_mixed(held, checked.share)


def test_mixed_error_needs_every_sessions_publication() -> None:
    (error,) = toy_refiners(PlayerModelKind.MIXED_ERROR)
    error.learn([np.array([[0, 1], [1, 1]])])
    with pytest.raises(ValueError, match="mixed-error model needs every session's publication"):
        error.weights()


def test_mixed_split_grows_half_for_each_kind_of_player() -> None:
    mixed, split = toy_refiners(PlayerModelKind.MIXED, PlayerModelKind.MIXED_SPLIT)
    (heuristic,) = toy_refiners(PlayerModelKind.MIXED, strategy=Strategy.SR_HEURISTIC)
    # before any trace both halves are the heuristic's: it grows as sr-heuristic
    assert split.plan_epoch(4).expanded == heuristic.plan_epoch(4).expanded
    first = PlayCounts.of_traces([np.array([[0, 1], [1, 1], [3, 1]]), np.array([[0, 1], [1, 1]])])
    for refiner in (mixed, split):
        refiner.learn_counts(first, freeze(refiner.graph))
    ranked = split.weights()
    assert ranked.hedge is not None and ranked.hedge[1] == UNSEEN_SHARE
    restart = split.restart
    crowd = edge_weights(Strategy.SR_CROWD, split.graph, split.player_model(), restart=restart)
    by_heuristic = edge_weights(
        Strategy.SR_CROWD, split.graph, split.heuristic_model(), restart=restart
    )
    np.testing.assert_allclose(ranked.weights, crowd.weights, rtol=1e-6)
    np.testing.assert_allclose(ranked.hedge[0], by_heuristic.weights, rtol=1e-6)
    # the same population as mixed's, but not its ranking
    np.testing.assert_array_equal(split.player_model(), mixed.player_model())
    err = np.asarray(split.graph.edge_err)
    blends = split.graph.blend_edges()

    def first_of(weights: np.ndarray) -> list[int]:
        return [int(e) for e in blends[np.argsort(-(weights[blends] * err[blends]), kind="stable")]]

    by_crowd, by_prior = first_of(ranked.weights), first_of(ranked.hedge[0])
    expanded = split.plan_epoch(4).expanded
    # alternately the crowd's best and the heuristic's best not yet taken
    expected: list[int] = []
    for queue in (by_crowd, by_prior, by_crowd, by_prior):
        expected.append(next(e for e in queue if e not in expected))
    assert expanded == expected


def test_split_weights_refuse_a_bad_share_and_give_way_to_a_fallen_back_ranking() -> None:
    crowd = EdgeWeights(np.array([0.6, 0.4]), None)
    fallen = EdgeWeights(np.array([0.5, 0.5]), None, fallback="did not converge")
    with pytest.raises(ValueError, match=r"a share is in \[0, 1\], not 1.5"):
        split_weights(crowd, crowd, 1.5)
    # the heuristic ranking fell back: no second queue, the crowd's weights with the reason
    given_way = split_weights(crowd, fallen, 0.5)
    assert given_way.hedge is None and given_way.fallback == "did not converge"
    np.testing.assert_array_equal(given_way.weights, crowd.weights)
