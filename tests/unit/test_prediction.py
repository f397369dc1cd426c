"""Prediction figures of a player model against held-out play (Figs. 8 and 9)."""

from __future__ import annotations

import numpy as np
import pytest

from app.core.bots import BotKind, play_sessions
from app.core.clipbank import MemoryClipBank
from app.core.growth import initial_tree
from app.core.metrics import predicted_edge_probabilities
from app.core.player_models import (
    mean_session_length,
    observed_control_counts,
    observed_player_model,
)
from app.core.prediction import (
    observed_error_relative_se,
    prediction_figures,
    split_half_correlation,
)
from app.core.publication import Publication
from app.core.refinement import Refiner, RefinerConfig
from app.core.strategies import Strategy
from app.core.toy import ToyDynamics

DYN = ToyDynamics()


@pytest.fixture(scope="module")
def publication() -> Publication:
    bank = MemoryClipBank()
    r = Refiner(initial_tree(DYN, bank), bank, DYN, Strategy.SR_HEURISTIC, RefinerConfig())
    r.grow(expansions=30)
    return r.publish()[0]


@pytest.fixture(scope="module")
def played(publication: Publication) -> list[np.ndarray]:
    return play_sessions(publication, BotKind.GOAL_DIRECTED, sessions=40, mean_steps=30, seed=4)


def uniform(publication: Publication) -> np.ndarray:
    return np.full((publication.n_vertices, publication.n_controls), 1.0 / publication.n_controls)


def test_the_per_vertex_model_of_the_judged_play_reaches_the_bound(
    publication: Publication, played: list[np.ndarray]
) -> None:
    n = publication.n_controls
    counts = observed_control_counts(played, publication.n_vertices, n)
    model = observed_player_model(counts, fallback=uniform(publication))
    restart = 1.0 / mean_session_length(played)
    figures = prediction_figures(publication, model, restart, played, learned_from=played)
    assert figures["predicted_expected_error"] == pytest.approx(
        figures["per_vertex_bound_expected_error"], rel=1e-9
    )
    assert figures["expected_error_relative_difference"] == pytest.approx(
        figures["per_vertex_bound_relative_difference"], rel=1e-9, abs=1e-12
    )
    assert figures["observed_mean_error"] > 0.0
    assert figures["expected_error_relative_difference"] == pytest.approx(
        figures["predicted_expected_error"] / figures["observed_mean_error"] - 1.0
    )
    assert 0.0 <= figures["density_tv_distance"] <= 1.0
    assert figures["density_correlation"] > 0.5  # its own play, up to the session ends


def test_another_model_misses_the_bound(publication: Publication, played: list[np.ndarray]) -> None:
    figures = prediction_figures(
        publication, uniform(publication), 1 / 30, played, learned_from=played
    )
    assert figures["predicted_expected_error"] != pytest.approx(
        figures["per_vertex_bound_expected_error"]
    )
    own = observed_player_model(
        observed_control_counts(played, publication.n_vertices, publication.n_controls),
        fallback=uniform(publication),
    )
    fitted = prediction_figures(
        publication, own, 1.0 / mean_session_length(played), played, learned_from=played
    )
    assert fitted["density_correlation"] > figures["density_correlation"]


def test_predicted_mass_unvisited_is_the_mass_off_the_learnt_vertices(
    publication: Publication, played: list[np.ndarray]
) -> None:
    n, v = publication.n_controls, publication.n_vertices
    model = uniform(publication)
    restart = 1 / 30

    def unvisited(learned_from: list[np.ndarray]) -> float:
        figures = prediction_figures(publication, model, restart, played, learned_from=learned_from)
        return figures["predicted_mass_unvisited"]

    everywhere = [np.array([[vertex, 0]]) for vertex in range(v)]
    assert unvisited(everywhere) == pytest.approx(0.0, abs=1e-12)
    assert unvisited([]) == pytest.approx(1.0, abs=1e-9)
    vertex_mass = (
        predicted_edge_probabilities(publication.edge_dst, model, publication.start, restart)
        .reshape(-1, n)
        .sum(axis=1)
    )
    assert vertex_mass[publication.start] >= restart - 1e-12  # every session starts there
    start_only = [np.array([[publication.start, 2]])]
    assert unvisited(start_only) == pytest.approx(1.0 - vertex_mass[publication.start])
    assert unvisited(everywhere[: v // 2]) == pytest.approx(vertex_mass[v // 2 :].sum())


def test_prediction_of_no_play_is_an_error(publication: Publication) -> None:
    with pytest.raises(ValueError):
        prediction_figures(publication, uniform(publication), 1 / 30, [], learned_from=[])


def test_split_half_correlation_is_one_for_identical_halves_and_less_otherwise(
    publication: Publication, played: list[np.ndarray]
) -> None:
    first, second = played[0::2], played[1::2]
    assert split_half_correlation(first, first, publication) == pytest.approx(1.0)
    # a half played twice over has the same densities (they are normalised)
    assert split_half_correlation(first, first + first, publication) == pytest.approx(1.0)
    between = split_half_correlation(first, second, publication)
    assert between == pytest.approx(split_half_correlation(second, first, publication))
    assert -1.0 <= between < 1.0 - 1e-6
    other = play_sessions(publication, BotKind.RANDOM, sessions=20, mean_steps=30, seed=9)
    assert split_half_correlation(first, other, publication) < between


def test_the_observed_errors_standard_error_shrinks_with_more_sessions(
    publication: Publication,
) -> None:
    err, n = publication.edge_err, publication.n_controls
    few = play_sessions(publication, BotKind.RANDOM, sessions=10, mean_steps=30, seed=5)
    many = play_sessions(publication, BotKind.RANDOM, sessions=400, mean_steps=30, seed=5)
    se_few, se_many = (
        observed_error_relative_se(few, err, n),
        observed_error_relative_se(many, err, n),
    )
    assert 0.0 < se_many < se_few / 3  # about sqrt(40) times smaller
    assert observed_error_relative_se(few, err, n) == se_few  # seeded: the same every time
    assert np.isnan(observed_error_relative_se(few, np.zeros_like(err), n))
