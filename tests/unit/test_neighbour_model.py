"""Eq. 2 with a nearest-neighbour bandwidth: it reaches every state, and cross-validation
chooses its neighbour count from held-out sessions."""

from __future__ import annotations

import numpy as np
import pytest

from app.core.bots import BotKind, play_sessions
from app.core.clipbank import MemoryClipBank
from app.core.crowd_play import PlayCounts
from app.core.growth import initial_tree
from app.core.neighbour_model import (
    NEIGHBOURS,
    choose_neighbours,
    nearest_visited_distance,
    neighbour_counts,
    neighbour_player_model,
)
from app.core.player_models import PlayerModelKind, crowd_player_model, observed_control_counts
from app.core.refinement import Refiner, RefinerConfig
from app.core.strategies import Strategy
from app.core.toy import ToyDynamics


def test_the_k_nearest_visited_count_from_one_down_to_a_half() -> None:
    descriptors = np.array([[0.0], [1.0], [3.0], [10.0]])
    control = np.zeros(4, dtype=np.int64)
    counts = np.array([[2.0, 0.0], [0.0, 4.0], [0.0, 0.0], [0.0, 0.0]])
    scores = neighbour_counts(descriptors, control, counts, neighbours=2)
    # vertex 0: itself (weight 1) and vertex 1 at the radius' half (weight 1/2)
    np.testing.assert_allclose(scores[0], [2.0, 2.0])
    # vertex 3, far from both: r = 2 * 10, weights 1 - 10/20 and 1 - 9/20
    np.testing.assert_allclose(scores[3], [2.0 * 0.5, 4.0 * (1 - 9 / 20)])
    # one neighbour: a visited vertex is its own and only evidence
    np.testing.assert_allclose(neighbour_counts(descriptors, control, counts, 1)[1], [0.0, 4.0])


def test_groups_do_not_mix_and_an_unvisited_group_has_no_support() -> None:
    descriptors = np.array([[0.0], [0.1], [5.0]])
    control = np.array([0, 1, 1])
    counts = np.array([[3.0, 1.0], [0.0, 0.0], [0.0, 0.0]])
    scores = neighbour_counts(descriptors, control, counts, neighbours=4)
    assert scores[1:].sum() == 0.0
    fallback = np.full((3, 2), 0.5)
    model = neighbour_player_model(descriptors, control, counts, 4, 1e-3, fallback=fallback)
    np.testing.assert_allclose(model[0], [0.75, 0.25])
    np.testing.assert_allclose(model[1:], fallback[1:])


def test_neighbours_must_be_positive() -> None:
    with pytest.raises(ValueError, match="neighbours"):
        neighbour_counts(np.zeros((2, 1)), np.zeros(2, dtype=np.int64), np.ones((2, 2)), 0)


def smooth_crowd(seed: int, sessions: int = 40) -> tuple[np.ndarray, np.ndarray, list]:
    """Players tilt towards the water: control 1 where x > 0, else 2, with some noise;
    each session visits a few neighbouring states of its own region."""
    rng = np.random.default_rng(seed)
    descriptors = rng.uniform(-1.0, 1.0, size=(400, 2))
    control = np.zeros(400, dtype=np.int64)
    traces = []
    for _ in range(sessions):
        centre = rng.integers(0, 400)
        near = np.argsort(np.linalg.norm(descriptors - descriptors[centre], axis=1))[:6]
        chosen = np.where(descriptors[near, 0] > 0.0, 1, 2)
        noisy = rng.random(near.size) < 0.1
        chosen[noisy] = rng.integers(0, 3, size=int(noisy.sum()))
        traces.append(np.column_stack([near, chosen]))
    return descriptors, control, traces


def test_cross_validation_scores_every_candidate_and_picks_the_best() -> None:
    descriptors, control, traces = smooth_crowd(0)
    fit = choose_neighbours(descriptors, control, PlayCounts.of_traces(traces), 3, 1e-3)
    assert set(fit.cv_scores) == set(NEIGHBOURS)
    assert fit.cv_scores[fit.neighbours] == max(fit.cv_scores.values())
    with pytest.raises(ValueError, match="no trace"):
        choose_neighbours(descriptors, control, PlayCounts.of_traces([np.empty((0, 2))]), 3, 1e-3)


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_the_chosen_model_predicts_unvisited_states_better_than_a_short_radius(
    seed: int,
) -> None:
    """Learned from some sessions, judged on new sessions' steps at states none of those
    visited: the neighbour model carries the crowd's choices there, eq. 2 with a radius
    shorter than the gaps falls back to its group prior."""
    descriptors, control, traces = smooth_crowd(seed, sessions=60)
    learn, judge = traces[:30], traces[30:]
    counts = observed_control_counts(learn, 400, 3)
    fresh = np.concatenate(judge)
    fresh = fresh[counts[fresh[:, 0]].sum(axis=1) == 0]
    assert fresh.shape[0] > 20
    uniform = np.full((400, 3), 1.0 / 3.0)
    fit = choose_neighbours(descriptors, control, PlayCounts.of_traces(learn), 3, 1e-3)
    knn = neighbour_player_model(
        descriptors, control, counts, fit.neighbours, 1e-3, fallback=uniform
    )
    eq2 = crowd_player_model(descriptors, control, counts, 0.01, 1e-3, fallback=uniform)

    def log_likelihood(model: np.ndarray) -> float:
        return float(np.mean(np.log(model[fresh[:, 0], fresh[:, 1]])))

    assert log_likelihood(knn) > log_likelihood(eq2) + 0.1


def test_a_knn_refiner_answers_from_the_crowd_where_eq2_has_only_its_prior() -> None:
    """On a toy graph grown past what bots played, eq. 2 (its radius) gives most new
    vertices the group prior; the knn model answers each from its nearest played states,
    keeps its chosen count until new sessions come, and reports what it chose."""
    dynamics = ToyDynamics()
    bank = MemoryClipBank()
    config = RefinerConfig(batch_size=4, player_model=PlayerModelKind.KNN)
    r = Refiner(initial_tree(dynamics, bank), bank, dynamics, Strategy.SR_CROWD, config)
    r.grow(expansions=20)
    first = r.publish()[0]
    r.learn(play_sessions(first, BotKind.GOAL_DIRECTED, sessions=12, mean_steps=30, seed=2))
    r.grow(expansions=12)
    model = r.player_model()
    assert model.shape == (r.graph.n_vertices, 3)
    np.testing.assert_allclose(model.sum(axis=1), 1.0, rtol=0, atol=1e-12)
    eq2 = Refiner(r.graph, r.bank, dynamics, Strategy.SR_CROWD, RefinerConfig(), played=r.played)
    visited = r.play.control_counts(r.graph.n_vertices, 3).sum(axis=1) > 0
    control = np.asarray(r.graph.vertex_control)
    # eq. 2: all unvisited vertices of a group beyond its radius share one row (the prior)
    rows = {tuple(np.round(row, 9)) for row in eq2.player_model()[~visited & (control == 0)]}
    knn_rows = {tuple(np.round(row, 9)) for row in model[~visited & (control == 0)]}
    assert len(knn_rows) > len(rows)
    fit = r.neighbour_fit()
    assert r.neighbour_fit() is fit and fit.neighbours in NEIGHBOURS
    assert fit.reference_score is not None
    second = r.publish()[0]
    r.learn(play_sessions(second, BotKind.RANDOM, sessions=6, mean_steps=20, seed=3))
    assert r.neighbour_fit() is not fit


def test_the_distance_to_the_nearest_visited_vertex_of_the_group() -> None:
    descriptors = np.array([[0.0], [3.0], [1.0], [7.0]])
    distance = nearest_visited_distance(
        descriptors, np.array([0, 0, 1, 1]), np.array([True, False, False, False])
    )
    np.testing.assert_array_equal(distance, [0.0, 3.0, np.inf, np.inf])
