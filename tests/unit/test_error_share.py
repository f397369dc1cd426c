"""The share of heuristic players ``mixed-error`` and ``mixed-residual`` rank for: the
error-weighted log score and the residual error by hand, the share each chooses on the
latest publication's players, and the refiners that rank with it."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import pytest
from refiner_helpers import toy_refiners

from app.core.crowd_play import PlayCounts
from app.core.error_share import (
    SHARES,
    ShareFit,
    error_weighted_score,
    fit_error_share,
    fit_residual_share,
    residual_error,
)
from app.core.graph import EdgeKind
from app.core.metrics import predicted_edge_probabilities
from app.core.player_models import PlayerModelKind
from app.core.publication import Publication, freeze
from app.core.strategies import UNSEEN_SHARE, Strategy, edge_weights, mixed_weights


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


def test_the_residual_is_the_error_left_off_the_blends_growth_would_replace_by_hand() -> None:
    weights = np.array([0.1, 0.4, 0.2, 0.3, 0.9])
    err = np.array([0.5, 0.1, 0.3, 0.2, 0.7])
    blend = np.array([True, True, True, True, False])
    steps = np.array([2, 1, 0, 3, 5])
    # priorities 0.05, 0.04, 0.06, 0.06 (edge 4 is a clip: never replaced, whatever it met)
    assert residual_error(weights, steps, err, blend, 0) == pytest.approx(
        (2 * 0.5 + 1 * 0.1 + 3 * 0.2 + 5 * 0.7) / 11
    )
    # the two first, 2 and 3 (equal: the earlier edge first), then 0
    assert residual_error(weights, steps, err, blend, 2) == pytest.approx((1 + 0.1 + 3.5) / 11)
    assert residual_error(weights, steps, err, blend, 3) == pytest.approx((0.1 + 3.5) / 11)
    assert residual_error(weights, steps, err, blend, 9) == pytest.approx(3.5 / 11)


def _blend_chain(err: list[float], vertices: int = 4) -> Publication:
    """:func:`_chain`'s first ``vertices`` vertices, every edge with an error a blend."""
    chain = _chain(err)
    kind = np.where(chain.edge_err > 0, EdgeKind.BLEND, EdgeKind.SIM).astype(np.int8)
    edges = slice(0, 2 * vertices)
    return Publication(
        2, 0, chain.edge_dst[edges], kind[edges], chain.edge_err[edges], np.zeros(2 * vertices)
    )


@pytest.mark.parametrize(
    ("latest_steps", "grown", "chosen"),
    [
        # they met error on the crowd's route (vertex 2's control 0), where any population
        # but the most heuristic one ranks first the one blend growth replaces: a tie,
        # mixed's share, where the log score takes the fewest heuristic players
        ([[0, 0], [1, 0], [2, 0]], 1, 0.5),
        # they met it where the crowd never went (vertex 1's turn): only the populations
        # that rank it above the route's blend would have reached it, 0.75 and 0.9
        ([[0, 0], [1, 1]], 1, 0.75),
        # growth replaced both blends: whatever the population, nothing is left
        ([[0, 0], [1, 1]], 2, 0.5),
    ],
)
def test_the_residual_share_is_the_one_whose_growth_would_have_left_the_least_error(
    latest_steps: list[list[int]], grown: int, chosen: float
) -> None:
    err = [0, 0, 0, 0.3, 0.3, 0, 0, 0]
    then, latest = _blend_chain([0.0] * 8, 4 - grown), _blend_chain(err)
    later = PlayCounts.of_traces([np.array(latest_steps)] * 5, first=ROUTE.sessions)
    fit = fit_residual_share([(then, ROUTE), (latest, later)], _uniform_blend, UNIFORM, 4, 0.1)
    crowd = predicted_edge_probabilities(
        latest.edge_dst, _uniform_blend(ROUTE.control_counts(4, 2)), 0, 0.1
    )
    prior = predicted_edge_probabilities(latest.edge_dst, UNIFORM, 0, 0.1)
    steps = later.control_counts(4, 2).reshape(-1)
    blend = latest.edge_kind == EdgeKind.BLEND
    by_hand = {
        s: residual_error((1 - s) * crowd + s * prior, steps, latest.edge_err, blend, grown)
        for s in SHARES
    }
    assert fit.scores == pytest.approx(by_hand)
    assert fit.share == chosen
    least = min(by_hand.values())
    assert by_hand[chosen] == least and all(
        abs(s - UNSEEN_SHARE) >= abs(chosen - UNSEEN_SHARE) for s in SHARES if by_hand[s] == least
    )
    # the log score, for contrast, never stops rewarding weight where error was met
    assert fit_error_share(
        [(then, ROUTE), (latest, later)], _uniform_blend, UNIFORM, 4, 0.1
    ).share == (0.25 if latest_steps[-1] == [2, 0] else 0.9)


def test_without_a_later_publication_that_met_error_the_residual_share_is_mixeds() -> None:
    then = _blend_chain([0.0] * 8)
    assert fit_residual_share([(then, ROUTE)], _uniform_blend, UNIFORM, 4, 0.1) == ShareFit(
        UNSEEN_SHARE
    )


@pytest.mark.parametrize(
    ("kind", "best"), [(PlayerModelKind.MIXED_ERROR, max), (PlayerModelKind.MIXED_RESIDUAL, min)]
)
def test_the_share_choosing_models_rank_with_the_share_they_chose(
    kind: PlayerModelKind, best: Callable[..., float]
) -> None:
    mixed, chooser = toy_refiners(PlayerModelKind.MIXED, kind)
    first = PlayCounts.of_traces([np.array([[0, 1], [1, 1], [3, 1]]), np.array([[0, 1], [1, 1]])])
    for refiner in (mixed, chooser):
        refiner.learn_counts(first, freeze(refiner.graph))
    # one publication's players: nothing to choose on, the ranking is mixed's
    assert chooser.share_fit() == ShareFit(UNSEEN_SHARE)
    np.testing.assert_array_equal(chooser.weights().weights, mixed.weights().weights)
    # both grow alike (mixed's ranking), then later players walk into the tree's blends
    for refiner in (mixed, chooser):
        refiner.grow(expansions=2)
    published = freeze(chooser.graph)
    np.testing.assert_array_equal(published.edge_dst, freeze(mixed.graph).edge_dst)
    blends = np.flatnonzero(published.edge_err > 0)
    vertex, control = divmod(int(blends[0]), published.n_controls)
    path = PlayCounts.of_traces([np.array([[vertex, control]])] * 4, first=first.sessions)
    for refiner in (mixed, chooser):
        refiner.learn_counts(path, freeze(refiner.graph))
    fit = chooser.share_fit()
    assert set(fit.scores) == set(SHARES)
    assert fit.scores[fit.share] == best(fit.scores.values())
    assert mixed.share_fit() == ShareFit(UNSEEN_SHARE)
    np.testing.assert_array_equal(chooser.player_model(), mixed.player_model())
    restart = chooser.restart
    crowd = edge_weights(Strategy.SR_CROWD, chooser.graph, chooser.player_model(), restart=restart)
    heuristic = edge_weights(
        Strategy.SR_CROWD, chooser.graph, chooser.heuristic_model(), restart=restart
    )
    np.testing.assert_allclose(
        chooser.weights().weights, mixed_weights(crowd, heuristic, fit.share).weights, rtol=1e-6
    )


def test_mixed_error_needs_every_sessions_publication() -> None:
    (error,) = toy_refiners(PlayerModelKind.MIXED_ERROR)
    error.learn([np.array([[0, 1], [1, 1]])])
    with pytest.raises(ValueError, match="mixed-error model needs every session's publication"):
        error.weights()
