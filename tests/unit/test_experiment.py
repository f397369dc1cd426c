"""The experiment's prediction and its plan checks (the CLI tests run it end to end)."""

from __future__ import annotations

import json
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from database_helpers import migrate

from app.config import get_settings
from app.core.errors import InvalidInput
from app.core.evaluation.metrics import CheckpointReport, evaluate_checkpoint
from app.core.graph.publication import Publication
from app.core.growth.kinds import Strategy
from app.core.players.bots import play_sessions
from app.core.players.kinds import BotKind, PlayerModelKind
from app.core.players.player_models import robust_session_length
from app.db.engines import dispose_engines
from app.services import play
from app.services.experiment import checkpoint
from app.services.experiment.ablation import eq2_ingredients
from app.services.experiment.plan import (
    SELECTION_SEEDS,
    ExperimentPlan,
    create_experiment,
    parse_checkpoints,
)
from app.services.experiment.results import PREDICTION_KEYS, prediction_summary
from app.services.experiment.runs import grow_in_process, run_experiment


@pytest.mark.parametrize("text", ["", "a,b", "300,200", "0,100", "100,100"])
def test_bad_checkpoints_are_refused(text: str) -> None:
    with pytest.raises(ValueError, match="checkpoints"):
        parse_checkpoints(text)


def test_prediction_is_for_the_publication_played_from_earlier_traces(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    """Predict, then observe: STATERANK runs on the relinked publication the bots get,
    with rho (and the crowd model) from the traces of earlier publications only."""
    monkeypatch.setenv("SRG_VAR_DIR", str(tmp_path))
    monkeypatch.delenv("SRG_DATABASE_URL", raising=False)
    migrate(get_settings().resolved_database_url)
    played: list[Publication] = []
    sessions: list[list[np.ndarray]] = []
    predictions: list[np.ndarray] = []

    def recording_play(publication: Publication, *args: object, **kwargs: Any) -> list:
        played.append(publication)
        sessions.append(play_sessions(publication, *args, **kwargs))  # type: ignore[arg-type]
        return sessions[-1]

    def recording_evaluate(
        traces: Any, err: Any, n: int, predicted: Any, *a: Any, **k: Any
    ) -> CheckpointReport:
        predictions.append(np.asarray(predicted))
        return evaluate_checkpoint(traces, err, n, predicted, *a, **k)

    monkeypatch.setattr(play, "play_sessions", recording_play)
    monkeypatch.setattr(checkpoint, "evaluate_checkpoint", recording_evaluate)
    plan = ExperimentPlan(
        strategies=(Strategy.SR_CROWD,), seeds=(1,), checkpoints=(600, 1_500), sessions=10,
        mean_steps=30,
    )  # fmt: skip
    settings = get_settings()
    plan = create_experiment(settings, "prediction", plan)
    progress: list[int] = []
    grower = partial(grow_in_process, settings)
    result = run_experiment(settings, "prediction", plan, grower, progress=progress.append)
    rows = result["crowds"]["goal-directed"]["results"]["sr-crowd"]["1"]
    assert sum(progress) >= 1_500
    # sr-heuristic, sr-crowd's control, came with it and plays first at each checkpoint
    assert plan.strategies == (Strategy.SR_HEURISTIC, Strategy.SR_CROWD)
    played, sessions, predictions = played[1::2], sessions[1::2], predictions[1::2]
    assert any(int(row["relinked_before_publish"]) > 0 for row in rows)  # type: ignore[call-overload]
    for row, publication, prob in zip(rows, played, predictions, strict=True):
        # stationary on the publication's edges: pi = (1 - rho) inflow + rho at the start
        n = publication.n_controls
        rho = 1.0 / float(row["predicted_session_steps"])  # type: ignore[arg-type]
        pi = prob.reshape(-1, n).sum(axis=1)
        inflow = np.bincount(publication.edge_dst, weights=prob, minlength=pi.size)
        restart = np.zeros_like(pi)
        restart[publication.start] = rho
        np.testing.assert_allclose(pi, (1.0 - rho) * inflow + restart, atol=1e-8)
        assert row["predicted_expected_error"] == pytest.approx(float(prob @ publication.edge_err))
    # the second prediction knows the first publication's sessions, not its own
    growth = settings.growth
    first = robust_session_length(
        sessions[0], default=growth.restart_steps, ceiling=growth.max_session_steps
    )
    assert rows[1]["predicted_session_steps"] == pytest.approx(first)
    assert rows[1]["predicted_session_steps"] != pytest.approx(rows[1]["observed_session_steps"])
    assert rows[0]["predicted_mass_prior_only"] is None
    assert 0.0 <= float(rows[1]["predicted_mass_prior_only"]) <= 1.0  # type: ignore[arg-type]
    # where the second checkpoint's players met their error adds up to what they met
    assert "error_origin" not in rows[0]
    origin = rows[1]["error_origin"]
    assert sum(origin["observed"].values()) == pytest.approx(rows[1]["observed_mean_error"])
    assert sum(origin["predicted"].values()) == pytest.approx(rows[1]["predicted_expected_error"])


def test_every_run_reaches_a_checkpoint_before_any_grows_towards_the_next(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    """An experiment stopped anywhere then holds a complete comparison up to its last
    checkpoint."""
    monkeypatch.setenv("SRG_VAR_DIR", str(tmp_path))
    monkeypatch.delenv("SRG_DATABASE_URL", raising=False)
    migrate(get_settings().resolved_database_url)
    settings = get_settings()
    plan = ExperimentPlan(
        strategies=(Strategy.BASELINE, Strategy.SR_CROWD), seeds=(1,),
        checkpoints=(400, 700), sessions=4, mean_steps=10,
    )  # fmt: skip
    plan = create_experiment(settings, "waves", plan)
    grown: list[tuple[str, int]] = []

    def recording_grower(name: str, to_frames: int, batch: int, progress: Any) -> None:
        grown.append((name, to_frames))
        grow_in_process(settings, name, to_frames, batch, progress)

    run_experiment(settings, "waves", plan, recording_grower)
    # baseline, sr-heuristic (sr-crowd's control, added) and sr-crowd
    assert [frames for _, frames in grown] == [400, 400, 400, 700, 700, 700]
    assert {name for name, _ in grown[:3]} == {name for name, _ in grown[3:]}


@pytest.fixture(autouse=True)
def _fresh_settings() -> Any:
    yield
    dispose_engines()


# ---- the plan's player model, bots and fixed-graph setting --------------------------------
def test_plan_round_trips_through_its_stored_dict() -> None:
    plan = ExperimentPlan(
        strategies=(Strategy.BASELINE, Strategy.SR_CROWD),
        seeds=(3, 1),
        checkpoints=(500, 900),
        player_model=PlayerModelKind.SHRUNK,
        bots=(BotKind.HESITANT, BotKind.AVOIDER),
        fixed_graph_sessions=7,
        high_error_threshold=0.25,
    )
    stored = plan.to_dict()
    assert stored["player_model"] == "shrunk" and stored["bots"] == ["hesitant", "avoider"]
    assert stored["fixed_graph_sessions"] == 7
    assert json.loads(json.dumps(stored)) == stored  # plain JSON, as the database keeps it
    assert ExperimentPlan.from_dict(json.loads(json.dumps(stored))) == plan


def test_a_plan_stored_before_player_models_and_bots_loads_with_the_defaults() -> None:
    stored = ExperimentPlan(seeds=(4,), checkpoints=(700,), sessions=12).to_dict()
    for key in ("player_model", "bots", "fixed_graph_sessions"):
        del stored[key]
    plan = ExperimentPlan.from_dict(stored)
    assert plan.player_model is PlayerModelKind.EQ2
    assert plan.bots == (BotKind.GOAL_DIRECTED,)
    assert plan.fixed_graph_sessions == ExperimentPlan().fixed_graph_sessions
    assert (plan.seeds, plan.checkpoints, plan.sessions) == ((4,), (700,), 12)


def test_a_stored_plan_with_an_unknown_key_still_loads() -> None:
    stored = {**ExperimentPlan().to_dict(), "retired_setting": 1}
    assert ExperimentPlan.from_dict(stored) == ExperimentPlan()


@pytest.mark.parametrize("sessions", [0, -3])
def test_fixed_graph_sessions_must_be_positive(sessions: int) -> None:
    with pytest.raises(ValueError, match="positive"):
        ExperimentPlan(fixed_graph_sessions=sessions)


@pytest.mark.parametrize(
    ("key", "value", "message"),
    [
        ("player_model", "best", "eq2, shrunk"),
        ("bots", ["avoider", "cheater"], "cheater"),
        ("bot", "cheater", "cheater"),
    ],
)
def test_a_stored_plan_with_an_unknown_model_or_bot_is_refused(
    key: str, value: object, message: str
) -> None:
    stored = {k: v for k, v in ExperimentPlan().to_dict().items() if k != "bots" or key != "bot"}
    with pytest.raises(ValueError, match=message):
        ExperimentPlan.from_dict({**stored, key: value})


def test_a_plan_stored_with_one_bot_plays_that_crowd() -> None:
    stored = {k: v for k, v in ExperimentPlan().to_dict().items() if k != "bots"}
    plan = ExperimentPlan.from_dict({**stored, "bot": "avoider"})
    assert plan.bots == (BotKind.AVOIDER,)


def test_every_run_is_one_world_shared_by_crowds_unless_it_learns() -> None:
    plan = ExperimentPlan(
        strategies=(Strategy.BASELINE, Strategy.SR_CROWD),
        seeds=(0, 1),
        bots=(BotKind.GOAL_DIRECTED, BotKind.AVOIDER),
    )
    runs = {plan.run_graph("x", run): (run.seeds, run.crowds, run.world) for run in plan.runs}
    both = (BotKind.GOAL_DIRECTED, BotKind.AVOIDER)
    goal, avoider = (BotKind.GOAL_DIRECTED,), (BotKind.AVOIDER,)
    assert runs == {
        "x.baseline.0": ((0,), both, 0),
        "x.baseline.1": ((1,), both, 1),
        "x.sr-heuristic.0": ((0,), both, 0),
        "x.sr-heuristic.1": ((1,), both, 1),
        "x.sr-crowd.goal-directed.0": ((0,), goal, 0),
        "x.sr-crowd.goal-directed.1": ((1,), goal, 1),
        "x.sr-crowd.avoider.0": ((0,), avoider, 0),
        "x.sr-crowd.avoider.1": ((1,), avoider, 1),
    }
    alone = ExperimentPlan(strategies=(Strategy.SR_CROWD,), seeds=(0,))
    assert [alone.run_graph("x", run) for run in alone.runs] == [
        "x.sr-heuristic.0",
        "x.sr-crowd.0",
    ]


def test_a_plan_stored_before_worlds_resumes_with_its_old_runs() -> None:
    """One trace-blind graph per strategy from the canonical start, as it was grown, and
    no sr-heuristic added to what was stored."""
    stored = ExperimentPlan(
        strategies=(Strategy.BASELINE, Strategy.SR_CROWD),
        seeds=(0, 11),  # a mix of selection and evaluation seeds was allowed then
        bots=(BotKind.GOAL_DIRECTED, BotKind.AVOIDER),
        worlds=False,
    ).to_dict()
    for key in ("worlds", "selection_seeds"):
        del stored[key]
    stored["strategies"] = ["baseline", "sr-crowd"]
    plan = ExperimentPlan.from_dict(stored)
    assert not plan.worlds and plan.selection_seeds == SELECTION_SEEDS
    assert plan.strategies == (Strategy.BASELINE, Strategy.SR_CROWD)
    runs = {plan.run_graph("x", run): (run.seeds, run.world) for run in plan.runs}
    assert runs == {
        "x.baseline": ((0, 11), None),
        "x.sr-crowd.goal-directed.0": ((0,), None),
        "x.sr-crowd.goal-directed.11": ((11,), None),
        "x.sr-crowd.avoider.0": ((0,), None),
        "x.sr-crowd.avoider.11": ((11,), None),
    }
    assert ExperimentPlan.from_dict(json.loads(json.dumps(plan.to_dict()))) == plan


def test_sr_heuristic_runs_by_default_and_beside_sr_crowd_max_error_when_asked() -> None:
    assert ExperimentPlan().strategies == (
        Strategy.BASELINE,
        Strategy.SR_HEURISTIC,
        Strategy.SR_CROWD,
    )
    assert ExperimentPlan(strategies=(Strategy.MAX_ERROR, Strategy.SR_CROWD)).strategies == (
        Strategy.MAX_ERROR,
        Strategy.SR_HEURISTIC,
        Strategy.SR_CROWD,
    )
    assert ExperimentPlan(strategies=(Strategy.BASELINE,)).strategies == (Strategy.BASELINE,)


def test_the_plan_records_its_selection_seeds_and_role() -> None:
    evaluation = ExperimentPlan(seeds=(0, 1, 2))
    selection = ExperimentPlan(seeds=SELECTION_SEEDS[:3])
    assert (evaluation.role, selection.role) == ("evaluation", "selection")
    assert evaluation.to_dict()["selection_seeds"] == list(SELECTION_SEEDS)
    assert ExperimentPlan.from_dict(selection.to_dict()) == selection
    chosen_elsewhere = ExperimentPlan(seeds=(3,), selection_seeds=(3, 4))
    assert ExperimentPlan.from_dict(chosen_elsewhere.to_dict()).role == "selection"


def test_the_confirmation_worlds_are_selection_seeds_apart_from_the_evaluation_ones() -> None:
    """Worlds 15-19 confirm a choice made on 10-14 (docs/experiment.md): still selection."""
    assert ExperimentPlan(seeds=(15, 16, 17, 18, 19)).role == "selection"
    assert ExperimentPlan(seeds=(10, 19)).role == "selection"
    assert not set(SELECTION_SEEDS) & {0, 1, 2}


def test_a_plan_mixing_selection_and_evaluation_seeds_is_refused_in_one_line() -> None:
    with pytest.raises(InvalidInput, match="seeds 10, 12 are selection seeds") as refused:
        ExperimentPlan(seeds=(0, 10, 1, 12))
    assert "\n" not in str(refused.value) and "0, 1 are not" in str(refused.value)


def test_seeds_are_worlds_and_not_negative() -> None:
    with pytest.raises(InvalidInput, match="non-negative: got -1"):
        ExperimentPlan(seeds=(0, -1))
    # past the graphs' integer column: refused with the plan, before anything is stored
    with pytest.raises(InvalidInput, match="non-negative: got 2147483648"):
        ExperimentPlan(seeds=(2**31,))


@pytest.mark.parametrize("bots", [(), (BotKind.AVOIDER, BotKind.AVOIDER)])
def test_crowds_must_be_distinct_and_present(bots: tuple[BotKind, ...]) -> None:
    with pytest.raises(ValueError, match="distinct bots"):
        ExperimentPlan(bots=bots)


def prediction_row(value: float, *, fixed: float | None = None) -> dict[str, Any]:
    """A checkpoint's row whose prediction figures are ``value`` plus the key's index."""
    row: dict[str, Any] = {key: value + index for index, key in enumerate(PREDICTION_KEYS)}
    if fixed is not None:
        row["fixed_graph"] = {
            **{key: fixed + index for index, key in enumerate(PREDICTION_KEYS)},
            "observed_split_half_correlation": fixed + 0.5,
        }
    return row


def test_prediction_summary_lists_the_last_checkpoints_per_seed_in_seed_order() -> None:
    results = {
        "baseline": {
            "2": [prediction_row(-1.0), prediction_row(20.0, fixed=200.0)],
            "0": [prediction_row(-1.0), prediction_row(0.0, fixed=100.0)],
        },
        "sr-crowd": {  # fixed_graph only on an earlier row of one seed: not a last one
            "2": [prediction_row(-1.0, fixed=9.0), prediction_row(30.0)],
            "0": [prediction_row(-1.0), prediction_row(10.0)],
        },
        "sr-heuristic": {  # one seed of two has it: the setting is incomplete, left out
            "2": [prediction_row(50.0, fixed=500.0)],
            "0": [prediction_row(40.0)],
        },
    }
    summary = prediction_summary(results)
    grown = summary["grown_graph"]
    assert set(grown) == {"baseline", "sr-crowd", "sr-heuristic"}
    assert grown["baseline"]["seeds"] == ["2", "0"]
    assert grown["baseline"]["expected_error_relative_difference"] == [20.0, 0.0]
    assert grown["baseline"]["density_correlation"] == [21.0, 1.0]
    assert grown["sr-crowd"]["expected_error_relative_difference"] == [30.0, 10.0]
    assert grown["sr-heuristic"]["predicted_mass_unvisited"] == [54.0, 44.0]
    assert set(summary["fixed_graph"]) == {"baseline"}
    fixed = summary["fixed_graph"]["baseline"]
    assert fixed["seeds"] == ["2", "0"]
    assert fixed["expected_error_relative_difference"] == [200.0, 100.0]
    assert fixed["density_correlation"] == [201.0, 101.0]
    assert fixed["observed_split_half_correlation"] == [200.5, 100.5]


def test_prediction_summary_keeps_figures_a_row_lacks_as_none() -> None:
    row = prediction_row(1.0)
    del row["predicted_mass_unvisited"]  # baseline learns nothing: no unvisited mass
    summary = prediction_summary({"baseline": {"0": [row]}})
    assert summary["grown_graph"]["baseline"]["predicted_mass_unvisited"] == [None]
    assert summary["fixed_graph"] == {}


# ---- pooled crowds and judges -------------------------------------------------------------
def test_pooled_crowds_teach_one_learning_run_per_seed_and_judges_play_every_run() -> None:
    plan = ExperimentPlan(
        strategies=(Strategy.SR_CROWD,),
        seeds=(0, 1),
        bots=(BotKind.GOAL_DIRECTED, BotKind.HESITANT),
        pooled=True,
        judges=(BotKind.AVOIDER,),
    )
    both = (BotKind.GOAL_DIRECTED, BotKind.HESITANT)
    runs = {plan.run_graph("x", run): (run.seeds, run.crowds) for run in plan.runs}
    assert runs == {
        "x.sr-heuristic.0": ((0,), both),
        "x.sr-heuristic.1": ((1,), both),
        "x.sr-crowd.0": ((0,), both),
        "x.sr-crowd.1": ((1,), both),
    }
    assert plan.players == (*both, BotKind.AVOIDER)
    assert ExperimentPlan.from_dict(plan.to_dict()) == plan


@pytest.mark.parametrize(
    "changes",
    [
        {"judges": (BotKind.GOAL_DIRECTED,)},
        {"judges": (BotKind.AVOIDER, BotKind.AVOIDER)},
        {"judges": (BotKind.AVOIDER,), "bots": (BotKind.GOAL_DIRECTED, BotKind.HESITANT)},
    ],
)
def test_judges_are_other_bots_and_judge_one_learning_run_per_seed(
    changes: dict[str, Any],
) -> None:
    with pytest.raises(InvalidInput, match="judges"):
        ExperimentPlan(**changes)


def test_judges_measure_every_run_and_teach_none(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    """The judge's rows are there for every strategy; sr-crowd's graph learns only from
    its crowd's stored traces, so the judge's play leaves what it grows unchanged."""
    monkeypatch.setenv("SRG_VAR_DIR", str(tmp_path))
    monkeypatch.delenv("SRG_DATABASE_URL", raising=False)
    migrate(get_settings().resolved_database_url)
    settings = get_settings()
    common = {
        "strategies": (Strategy.SR_CROWD,), "seeds": (1,), "checkpoints": (400, 700),
        "sessions": 4, "mean_steps": 10,
    }  # fmt: skip
    plans = {
        "judged": create_experiment(
            settings, "judged", ExperimentPlan(**common, judges=(BotKind.AVOIDER,))
        ),
        "unjudged": create_experiment(settings, "unjudged", ExperimentPlan(**common)),
    }
    results = {
        name: run_experiment(settings, name, plan, partial(grow_in_process, settings))
        for name, plan in plans.items()
    }
    crowds = results["judged"]["crowds"]
    assert set(crowds) == {"goal-directed", "avoider"}
    for strategy in ("sr-heuristic", "sr-crowd"):
        assert len(crowds["avoider"]["results"][strategy]["1"]) == 2
    sizes = {
        name: [row["observed_mean_error"] for row in result["crowds"]["goal-directed"]
               ["results"]["sr-crowd"]["1"]]
        for name, result in results.items()
    }  # fmt: skip
    assert sizes["judged"] == sizes["unjudged"]
    assert results["judged"]["comparison"]["avoider"][0]["crowd_vs_heuristic"]["per_seed"]
    # the crowd model's ablation reads the crowd's rows and passes over the judge's
    ablation = eq2_ingredients(settings, "judged", plans["judged"])
    assert ablation and {row["bot"] for row in ablation} == {"goal-directed"}
