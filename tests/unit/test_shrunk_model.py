"""Eq. 2's evidence shrunk toward the heuristic model: the data rule where players went,
the heuristic where nobody did, and cross-validation picks how much to trust each."""

from __future__ import annotations

import numpy as np
import pytest
from refiner_helpers import toy_refiners

from app.core.graph.clipbank import MemoryClipBank
from app.core.graph.toy import ToyDynamics
from app.core.growth.expansion import initial_tree
from app.core.growth.kinds import Strategy
from app.core.growth.refinement import Refiner, RefinerConfig
from app.core.players.crowd_models.shrunk import FittedShrunk, fit_shrunk_model, shrunk_player_model
from app.core.players.crowd_play import PlayCounts
from app.core.players.kinds import PlayerModelKind
from app.core.players.player_models import heuristic_player_model
from app.core.players.session_folds import SessionFolds


def test_evidence_against_pseudo_steps_of_the_prior_by_hand() -> None:
    descriptors = np.array([[0.0], [0.5], [9.0]])
    control = np.zeros(3, dtype=np.int64)
    counts = np.array([[4.0, 0.0], [0.0, 0.0], [0.0, 0.0]])
    prior = np.array([[0.5, 0.5], [0.9, 0.1], [0.2, 0.8]])
    model = shrunk_player_model(descriptors, control, counts, 1.0, 2.0, prior=prior)
    # vertex 0: its own 4 steps of control 0 against 2 pseudo-steps of (0.5, 0.5)
    np.testing.assert_allclose(model[0], [(4 + 1) / 6, 1 / 6])
    # vertex 1: the kernel gives vertex 0's steps weight 1 - 0.5/1
    np.testing.assert_allclose(model[1], [(2 + 1.8) / 4, 0.2 / 4])
    # vertex 2: out of reach, so the prior exactly
    np.testing.assert_allclose(model[2], prior[2])


@pytest.mark.parametrize(
    ("radius", "weight", "message"),
    [(0.0, 1.0, "radius"), (1.0, 0.0, "prior_weight")],
)
def test_bad_hyper_parameters_are_refused(radius: float, weight: float, message: str) -> None:
    prior = np.full((2, 2), 0.5)
    with pytest.raises(ValueError, match=message):
        shrunk_player_model(
            np.zeros((2, 1)),
            np.zeros(2, dtype=np.int64),
            np.ones((2, 2)),
            radius,
            weight,
            prior=prior,
        )


def test_a_prior_that_is_no_distribution_is_refused() -> None:
    with pytest.raises(ValueError, match="prior rows"):
        shrunk_player_model(
            np.zeros((2, 1)),
            np.zeros(2, dtype=np.int64),
            np.ones((2, 2)),
            1.0,
            1.0,
            prior=np.ones((2, 2)),
        )


def test_cross_validation_trusts_consistent_players_and_doubts_random_ones() -> None:
    """Players who always take control 1 are best predicted with little prior; players
    who pick uniformly, against a prior that says 'keep control 0', with much."""
    rng = np.random.default_rng(3)
    n_vertices = 30
    descriptors = rng.uniform(0.0, 1.0, size=(n_vertices, 2))
    control = np.zeros(n_vertices, dtype=np.int64)
    prior = heuristic_player_model(control, 3, 0.8)
    vertices = rng.integers(0, n_vertices, size=(40, 15))
    steady = [np.column_stack([v, np.ones_like(v)]) for v in vertices]
    erratic = [np.column_stack([v, rng.integers(0, 3, size=v.size)]) for v in vertices]
    trusting = fit_shrunk_model(descriptors, control, PlayCounts.of_traces(steady), prior, 0.05)
    doubting = fit_shrunk_model(descriptors, control, PlayCounts.of_traces(erratic), prior, 0.05)
    assert trusting.prior_weight < doubting.prior_weight
    assert len(trusting.cv_scores) == 20


def test_session_folds_score_a_model_on_the_sessions_it_did_not_learn() -> None:
    """Two sessions, one per fold: each is scored by a model of the other's counts."""
    folds = SessionFolds.of(
        PlayCounts.of_traces([np.array([[0, 1]]), np.array([[0, 0]])]), 1, 2, folds=5
    )
    # learned from one step of the other control: P = 3/4 for it, 1/4 for the held-out one
    score = folds.score(lambda counts: (counts + 1.0) / (counts.sum(axis=1, keepdims=True) + 2.0))
    assert score == pytest.approx(np.log(1 / 3))
    with pytest.raises(ValueError, match="no trace"):
        SessionFolds.of(PlayCounts.of_traces([np.empty((0, 2))]), 1, 2)


def test_the_refiner_learns_the_shrunk_model_and_keeps_the_heuristic_before_traces() -> None:
    dyn = ToyDynamics()
    bank = MemoryClipBank()
    graph = initial_tree(dyn, bank, depth=3, prefilter_k=10)
    config = RefinerConfig(crowd_radius=0.5, player_model=PlayerModelKind.SHRUNK)
    refiner = Refiner(graph, bank, dyn, Strategy.SR_CROWD, config)
    np.testing.assert_array_equal(refiner.player_model(), refiner.heuristic_model())
    refiner.learn([np.array([[0, 1], [1, 1]]), np.array([[0, 1], [1, 2]])])
    model = refiner.player_model()
    np.testing.assert_allclose(model.sum(axis=1), 1.0)
    assert model[0, 1] > refiner.heuristic_model()[0, 1]
    fitted = refiner.crowd_model()
    assert isinstance(fitted, FittedShrunk) and fitted.chosen.prior_weight > 0.0
    assert fitted.unseen_share is None  # it ranks for its crowd alone


def test_mixed_ranks_half_the_mass_as_the_heuristic_model_once_traces_exist() -> None:
    shrunk, mixed = toy_refiners(PlayerModelKind.SHRUNK, PlayerModelKind.MIXED)
    (heuristic,) = toy_refiners(PlayerModelKind.SHRUNK, strategy=Strategy.SR_HEURISTIC)
    # before any trace every sr-crowd ranking is sr-heuristic's
    np.testing.assert_array_equal(mixed.weights().weights, heuristic.weights().weights)
    traces = [np.array([[0, 1], [1, 1], [3, 1]]), np.array([[0, 1], [1, 1], [3, 0]])]
    for refiner in (shrunk, mixed, heuristic):
        refiner.learn(traces)
    np.testing.assert_array_equal(mixed.player_model(), shrunk.player_model())
    crowd, unseen = shrunk.weights().weights, heuristic.weights().weights
    assert not np.allclose(crowd, unseen)
    np.testing.assert_allclose(mixed.weights().weights, 0.5 * crowd + 0.5 * unseen, rtol=1e-9)
    assert mixed.weights().weights.sum() == pytest.approx(1.0)
