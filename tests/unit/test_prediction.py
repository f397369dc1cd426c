"""Prediction figures of a player model against held-out play (Figs. 8 and 9)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from app.core.evaluation.metrics import observed_mean_error
from app.core.evaluation.prediction import (
    PlayedSessions,
    prediction_figures,
    split_half_correlation,
)
from app.core.graph.clipbank import MemoryClipBank
from app.core.graph.publication import Publication
from app.core.graph.staterank import predicted_edge_probabilities
from app.core.graph.toy import ToyDynamics
from app.core.growth.expansion import initial_tree
from app.core.growth.kinds import Strategy
from app.core.growth.refinement import Refiner, RefinerConfig
from app.core.players.bots import play_sessions
from app.core.players.crowd_play import PlayCounts
from app.core.players.kinds import BotKind
from app.core.players.player_models import (
    mean_session_length,
    observed_control_counts,
    observed_player_model,
)

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


def judged(
    publication: Publication,
    model: np.ndarray,
    restart: float,
    played: list[np.ndarray],
    learned_from: list[np.ndarray],
) -> dict[str, float]:
    """The prediction figures of sessions in memory."""
    return prediction_figures(
        publication,
        model,
        restart,
        PlayedSessions.of_traces(played, publication),
        learned_from=PlayCounts.of_traces(learned_from),
    )


def uniform(publication: Publication) -> np.ndarray:
    return np.full((publication.n_vertices, publication.n_controls), 1.0 / publication.n_controls)


def test_the_per_vertex_model_of_the_judged_play_reaches_the_bound(
    publication: Publication, played: list[np.ndarray]
) -> None:
    n = publication.n_controls
    counts = observed_control_counts(played, publication.n_vertices, n)
    model = observed_player_model(counts, fallback=uniform(publication))
    restart = 1.0 / mean_session_length(played)
    figures = judged(publication, model, restart, played, played)
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
    figures = judged(publication, uniform(publication), 1 / 30, played, played)
    assert figures["predicted_expected_error"] != pytest.approx(
        figures["per_vertex_bound_expected_error"]
    )
    own = observed_player_model(
        observed_control_counts(played, publication.n_vertices, publication.n_controls),
        fallback=uniform(publication),
    )
    fitted = judged(publication, own, 1.0 / mean_session_length(played), played, played)
    assert fitted["density_correlation"] > figures["density_correlation"]


def test_predicted_mass_unvisited_is_the_mass_off_the_learnt_vertices(
    publication: Publication, played: list[np.ndarray]
) -> None:
    n, v = publication.n_controls, publication.n_vertices
    model = uniform(publication)
    restart = 1 / 30

    def unvisited(learned_from: list[np.ndarray]) -> float:
        figures = judged(publication, model, restart, played, learned_from)
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
        judged(publication, uniform(publication), 1 / 30, [], [])


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
    few = play_sessions(publication, BotKind.RANDOM, sessions=10, mean_steps=30, seed=5)
    many = play_sessions(publication, BotKind.RANDOM, sessions=400, mean_steps=30, seed=5)
    se_few, se_many = (
        PlayedSessions.of_traces(few, publication).error_relative_se(),
        PlayedSessions.of_traces(many, publication).error_relative_se(),
    )
    assert 0.0 < se_many < se_few / 3  # about sqrt(40) times smaller
    # seeded: the same every time
    assert PlayedSessions.of_traces(few, publication).error_relative_se() == se_few
    errorless = replace(publication, edge_err=np.zeros_like(publication.edge_err))
    assert np.isnan(PlayedSessions.of_traces(few, errorless).error_relative_se())


def test_the_sessions_errors_are_their_steps_errors(
    publication: Publication, played: list[np.ndarray]
) -> None:
    sessions = PlayedSessions.of_traces([*played, np.empty((0, 2))], publication)
    n = publication.n_controls
    assert sessions.lengths.tolist() == [len(t) for t in played]  # the empty one is no session
    for trace, error in zip(played, sessions.errors, strict=True):
        assert error == pytest.approx(sum(publication.edge_err[v * n + c] for v, c in trace))
    assert sessions.observed_mean_error() == pytest.approx(
        observed_mean_error(played, publication.edge_err, n), rel=1e-12
    )
