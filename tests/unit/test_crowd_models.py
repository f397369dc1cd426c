"""The checks every registered crowd model passes (scikit-learn's ``parametrize_with_checks``
in spirit): one registry for every kind, rows that are distributions, the heuristic where
nothing was seen, the same fit twice, answers for a graph grown since the fit, and a
refiner that fits once per sessions learnt. The import contract is tests/unit/test_layers.py's.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from app.core.graph.clipbank import MemoryClipBank
from app.core.graph.publication import Publication
from app.core.graph.toy import ToyDynamics
from app.core.growth.expansion import initial_tree
from app.core.growth.kinds import Strategy
from app.core.growth.refinement import Refiner, RefinerConfig
from app.core.players.bots import play_sessions
from app.core.players.crowd_models import candidates
from app.core.players.crowd_models.candidates import candidate_models
from app.core.players.crowd_models.eq2 import Eq2
from app.core.players.crowd_models.estimator import CrowdGraph, CrowdModel, CrowdPlay
from app.core.players.crowd_models.registry import CROWD_MODELS, by_kind, crowd_model
from app.core.players.crowd_models.shrunk import Shrunk
from app.core.players.crowd_play import PlayCounts
from app.core.players.kinds import BotKind, PlayerModelKind

DYN = ToyDynamics()
#: the control group no session of :func:`played` visits
UNSEEN_GROUP = 2


def test_every_kind_has_one_registered_class_and_every_class_a_kind() -> None:
    assert set(CROWD_MODELS) == set(PlayerModelKind)
    assert all(model.kind is kind for kind, model in CROWD_MODELS.items())
    with pytest.raises(ValueError, match="Eq2 and Shrunk are both eq2"):
        by_kind([Eq2, type("Shrunk", (Shrunk,), {"kind": PlayerModelKind.EQ2})])


def test_a_candidate_is_one_module_in_the_candidates_package(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    assert candidate_models() == []  # none on trial today
    (tmp_path / "mixed_trial.py").write_text(
        "from app.core.players.crowd_models.shrunk import Shrunk\n\n\n"
        "class MixedTrial(Shrunk):\n    pass\n\n\nCANDIDATE = MixedTrial\n"
    )
    monkeypatch.setattr(candidates, "__path__", [str(tmp_path)])
    (found,) = candidate_models()
    assert found.__name__ == "MixedTrial"
    assert found.__module__ == "app.core.players.crowd_models.candidates.mixed_trial"


class Played:
    """A toy graph grown after two publications, each played by goal-directed bots who
    never hold control :data:`UNSEEN_GROUP`'s vertices, and the graph at the second one."""

    def __init__(self) -> None:
        bank = MemoryClipBank()
        refiner = Refiner(initial_tree(DYN, bank), bank, DYN, Strategy.SR_HEURISTIC)
        self.played: list[tuple[Publication | None, PlayCounts]] = []
        for seed in range(2):
            refiner.grow(expansions=12)
            publication = refiner.publish()[0]
            traces = play_sessions(
                publication, BotKind.GOAL_DIRECTED, sessions=12, mean_steps=20, seed=seed
            )
            control = np.asarray(refiner.graph.vertex_control)
            kept = [t[control[t[:, 0]] != UNSEEN_GROUP] for t in traces]
            first = sum(play.sessions for _, play in self.played)
            self.played.append((publication, PlayCounts.of_traces(kept, first=first)))
        self.graph = graph_of(refiner)
        refiner.grow(expansions=8)
        self.grown = graph_of(refiner)
        self.play = CrowdPlay(tuple(self.played), refiner.restart)


def graph_of(refiner: Refiner) -> CrowdGraph:
    return CrowdGraph(
        refiner.graph.vertex_descriptors(),
        np.asarray(refiner.graph.vertex_control),
        refiner.heuristic_model(),
        radius=0.5,
        eps=1e-3,
    )


@pytest.fixture(scope="module")
def played() -> Played:
    return Played()


@pytest.fixture(params=sorted(CROWD_MODELS), ids=str)
def model(request: pytest.FixtureRequest) -> CrowdModel:
    return crowd_model(request.param)


def test_rows_are_distributions_and_the_heuristic_where_nothing_was_seen(
    played: Played, model: CrowdModel
) -> None:
    graph = played.graph
    answer = model.fit(graph, played.play).player_model(graph)
    assert answer.shape == (graph.n_vertices, graph.n_controls) and np.all(answer >= 0.0)
    np.testing.assert_allclose(answer.sum(axis=1), 1.0, rtol=0, atol=1e-12)
    unseen = graph.vertex_control == UNSEEN_GROUP
    assert unseen.any() and not np.allclose(answer[~unseen], graph.heuristic[~unseen])
    np.testing.assert_allclose(answer[unseen], graph.heuristic[unseen], rtol=0, atol=1e-15)


def test_one_fit_twice_gives_one_model(played: Played, model: CrowdModel) -> None:
    first, again = model.fit(played.graph, played.play), model.fit(played.graph, played.play)
    np.testing.assert_array_equal(
        first.player_model(played.graph), again.player_model(played.graph)
    )
    assert first.figures() == again.figures() and first.unseen_share == again.unseen_share


def test_a_fitted_model_answers_for_the_graph_grown_since(
    played: Played, model: CrowdModel
) -> None:
    fitted = model.fit(played.graph, played.play)
    grown = fitted.player_model(played.grown)
    assert grown.shape[0] > played.graph.n_vertices
    np.testing.assert_allclose(grown.sum(axis=1), 1.0, rtol=0, atol=1e-12)


def test_a_model_that_reads_publications_refuses_sessions_without_theirs(
    played: Played, model: CrowdModel
) -> None:
    blind = CrowdPlay([(None, play) for _, play in played.played], played.play.restart)
    if not model.reads_publications:
        model.fit(played.graph, blind)
        return
    with pytest.raises(ValueError, match="needs every session's publication"):
        model.fit(played.graph, blind)


def test_the_refiner_fits_its_model_once_per_sessions_learnt(
    played: Played, model: CrowdModel
) -> None:
    bank = MemoryClipBank()
    config = RefinerConfig(crowd_radius=0.5, player_model=model.kind)
    refiner = Refiner(initial_tree(DYN, bank), bank, DYN, Strategy.SR_CROWD, config)
    publication = refiner.publish()[0]
    # sessions without a step teach nothing: the heuristic model
    refiner.learn([np.empty((0, 2), dtype=np.int64)], publication)
    np.testing.assert_array_equal(refiner.player_model(), refiner.heuristic_model())
    traces = play_sessions(publication, BotKind.GOAL_DIRECTED, sessions=6, mean_steps=10, seed=1)
    refiner.learn(traces, publication)
    fitted = refiner.crowd_model()
    assert refiner.crowd_model() is fitted
    assert not np.allclose(refiner.player_model(), refiner.heuristic_model())
    refiner.learn(traces[:2], publication)
    assert refiner.crowd_model() is not fitted
