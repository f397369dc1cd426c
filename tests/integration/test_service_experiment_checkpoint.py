"""One checkpoint of an experiment's run (app.services.experiment.checkpoint): publish,
predict from earlier checkpoints' traces only, let the bots of each seed and player group
play, store a crowd's traces and never a judge's, measure (docs/experiment.md)."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from service_settings import session_settings
from sqlalchemy import func, select
from sqlalchemy.orm import Session

from app.config import Settings
from app.core.growth.kinds import Strategy
from app.core.players.kinds import BotKind
from app.models import Player, Trace
from app.services.creation import init_graph
from app.services.experiment.checkpoint import BOT_PLAYER, checkpoint_figures
from app.services.experiment.plan import ExperimentPlan, Run
from app.store.publications import graph_publications

EXPERIMENT = "x"
SESSIONS = 6
#: a toy plan of two checkpoints whose crowd has fresh judges and a judge of its own
PLAN = ExperimentPlan(
    dynamics="toy",
    seeds=(0,),
    checkpoints=(200, 300),
    sessions=SESSIONS,
    mean_steps=10,
    fixed_graph_sessions=SESSIONS,
    judges=(BotKind.RANDOM,),
    fresh_judges=True,
)
LABELS = [(0, "goal-directed"), (0, "fresh-goal-directed"), (0, "random")]
ARRAYS = {
    "step_errors",
    "predicted_density",
    "observed_density",
    "edge_dst",
    "edge_kind",
    "edge_err",
    "vertex_descriptors",
}


@pytest.fixture
def settings(db_url: str, tmp_path: Path) -> Iterator[Settings]:
    yield from session_settings(db_url, tmp_path)


def run_of(plan: ExperimentPlan, strategy: Strategy) -> Run:
    (run,) = [run for run in plan.runs if run.strategy is strategy]
    return run


def run_graph(session: Session, settings: Settings, plan: ExperimentPlan, run: Run) -> str:
    """The run's graph, made as the experiment makes it (its initial tree)."""
    name = plan.run_graph(EXPERIMENT, run)
    init_graph(
        session,
        settings,
        name=name,
        strategy=run.strategy.value,
        world=run.world,
        player_model=plan.player_model.value,
    )
    return name


def stored_keys(session: Session, publication_id: int) -> list[str]:
    return list(
        session.scalars(
            select(Trace.idempotency_key)
            .join(Player, Player.id == Trace.player_id)
            .where(Trace.publication_id == publication_id, Player.name == BOT_PLAYER)
        )
    )


def test_a_crowds_play_is_stored_and_its_judges_play_is_not(
    session: Session, settings: Settings
) -> None:
    run = run_of(PLAN, Strategy.SR_CROWD)
    graph = run_graph(session, settings, PLAN, run)
    measured = checkpoint_figures(session, settings, PLAN, graph, run, 0)
    assert [label for label, _, _ in measured] == LABELS
    (publication,) = graph_publications(session, measured[0][1]["graph_id"])
    for _, figures, arrays in measured:
        assert figures["publication_id"] == publication.id
        assert figures["checkpoint_frames"] == PLAN.checkpoints[0]
        assert figures["vertices"] == publication.n_vertices
        assert figures["size_frames"] == publication.size_frames
        assert set(arrays) == ARRAYS
        assert arrays["predicted_density"].sum() == pytest.approx(1.0)
    keys = stored_keys(session, publication.id)
    assert len(keys) == SESSIONS
    assert all(key.startswith(f"{publication.id}.0.goal-directed.") for key in keys)
    everyone = select(func.count()).where(Trace.publication_id == publication.id)
    assert session.scalar(everyone) == SESSIONS  # the judges' sessions were never stored


def crowd_of(
    session: Session, settings: Settings, graph: str, run: Run, index: int
) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """The figures and arrays of the run's crowd (its first group) at checkpoint ``index``."""
    _, figures, arrays = checkpoint_figures(session, settings, PLAN, graph, run, index)[0]
    return figures, arrays


def test_the_prediction_comes_before_the_crowd_plays(session: Session, settings: Settings) -> None:
    """sr-crowd predicts its first checkpoint as sr-heuristic does (no earlier traces: the
    crowd's own play of it comes after), and its second from the first one's traces."""
    crowd, heuristic = run_of(PLAN, Strategy.SR_CROWD), run_of(PLAN, Strategy.SR_HEURISTIC)
    crowd_graph = run_graph(session, settings, PLAN, crowd)
    heuristic_graph = run_graph(session, settings, PLAN, heuristic)

    unlearned, crowd_first = crowd_of(session, settings, crowd_graph, crowd, 0)
    _, heuristic_first = crowd_of(session, settings, heuristic_graph, heuristic, 0)
    np.testing.assert_array_equal(
        crowd_first["predicted_density"], heuristic_first["predicted_density"]
    )
    assert unlearned["predicted_mass_unvisited"] is None
    assert "unexpected_step_share" not in unlearned

    learned, crowd_second = crowd_of(session, settings, crowd_graph, crowd, 1)
    _, heuristic_second = crowd_of(session, settings, heuristic_graph, heuristic, 1)
    assert not np.allclose(crowd_second["predicted_density"], heuristic_second["predicted_density"])
    assert 0.0 <= learned["predicted_mass_unvisited"] <= 1.0
    assert 0.0 <= learned["unexpected_step_share"] <= 1.0
    assert 0.0 <= learned["unexpected_error_share"] <= 1.0


def test_the_fixed_graph_setting_is_measured_on_the_baselines_last_checkpoint(
    session: Session, settings: Settings
) -> None:
    baseline, crowd = run_of(PLAN, Strategy.BASELINE), run_of(PLAN, Strategy.SR_CROWD)
    baseline_graph = run_graph(session, settings, PLAN, baseline)
    crowd_graph = run_graph(session, settings, PLAN, crowd)
    early = checkpoint_figures(session, settings, PLAN, baseline_graph, baseline, 0)
    last = checkpoint_figures(session, settings, PLAN, baseline_graph, baseline, 1)
    assert ["fixed_graph" in figures for _, figures, _ in early] == [False] * 3
    # the crowd's own sessions only: its judges play no fixed-graph setting
    assert ["fixed_graph" in figures for _, figures, _ in last] == [True, False, False]
    assert last[0][1]["checkpoint_frames"] == PLAN.checkpoints[1]
    crowd_last = checkpoint_figures(session, settings, PLAN, crowd_graph, crowd, 1)
    assert not any("fixed_graph" in figures for _, figures, _ in crowd_last)


def test_a_run_that_several_seeds_play_is_predicted_once_and_each_seed_stores_its_own(
    session: Session, settings: Settings
) -> None:
    """A plan stored before world seeds plays one baseline graph with every seed's bots."""
    plan = ExperimentPlan(
        dynamics="toy",
        strategies=(Strategy.BASELINE,),
        seeds=(0, 1),
        checkpoints=(200, 300),
        sessions=SESSIONS,
        mean_steps=10,
        fixed_graph_sessions=SESSIONS,
        worlds=False,
    )
    (run,) = plan.runs
    assert run.seeds == (0, 1)
    graph = run_graph(session, settings, plan, run)
    measured = checkpoint_figures(session, settings, plan, graph, run, 0)
    assert [label for label, _, _ in measured] == [(0, "goal-directed"), (1, "goal-directed")]
    (_, seed0, arrays0), (_, seed1, arrays1) = measured
    np.testing.assert_array_equal(arrays0["predicted_density"], arrays1["predicted_density"])
    publication = seed0["publication_id"]
    assert seed1["publication_id"] == publication
    keys = stored_keys(session, publication)
    for seed in (0, 1):
        assert sum(key.startswith(f"{publication}.{seed}.goal-directed.") for key in keys) == (
            SESSIONS
        )
