"""The crowd player model from the command line: chosen at `srg init` and in an
experiment's plan, and judged by `srg analytics` on the latest publication's play."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import pytest
from cli_helpers import ok, one_line_error, srg

#: the figures of a prediction, every one a finite number
PREDICTION_FIGURES = (
    "density_correlation",
    "density_tv_distance",
    "predicted_expected_error",
    "observed_mean_error",
    "expected_error_relative_difference",
    "per_vertex_bound_expected_error",
    "per_vertex_bound_relative_difference",
    "predicted_mass_unvisited",
)


@pytest.fixture(scope="module")
def var(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A toy graph played on two publications (grown in between), and one played on one;
    both learn eq. 2, the paper's model."""
    var = tmp_path_factory.mktemp("var")
    ok(var, "db", "upgrade")
    for name in ("twice", "once"):
        ok(var, "init", name, "--player-model", "eq2")
        ok(var, "grow", name, "--expansions", "6")
        ok(var, "publish", name)
        ok(var, "play", name, "--sessions", "8", "--seed", "0")
    ok(var, "grow", "twice", "--expansions", "6")
    ok(var, "publish", "twice")
    ok(var, "play", "twice", "--sessions", "8", "--seed", "1", "--bot", "heuristic")
    return var


def analytics(var: Path, *args: str) -> dict[str, Any]:
    return dict(json.loads(ok(var, "analytics", *args, "--json")))


def graph_count(var: Path) -> int:
    return len(json.loads(ok(var, "status", "--json")))


# ---- srg init --player-model ------------------------------------------------------------
def test_init_stores_the_player_model_chosen_else_the_setting(tmp_path: Path) -> None:
    ok(tmp_path, "db", "upgrade")
    assert json.loads(ok(tmp_path, "init", "plain", "--json"))["player_model"] == "mixed-error"
    chosen = json.loads(ok(tmp_path, "init", "chosen", "--player-model", "shrunk", "--json"))
    assert chosen["player_model"] == "shrunk"
    done = srg(tmp_path, "init", "configured", "--json", SRG_PLAYER_MODEL="shrunk")
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout)["player_model"] == "shrunk"
    status = json.loads(ok(tmp_path, "status", "chosen", "--json"))
    assert status["player_model"] == "shrunk"


@pytest.mark.parametrize(
    ("model", "env", "fragment"),
    [
        ("softmax", {}, "'--player-model': 'softmax' is not one of 'eq2', 'shrunk'"),
        # a candidate that lost its selection is no choice of the product
        ("logit", {}, "'--player-model': 'logit' is not one of 'eq2', 'shrunk'"),
        ("", {}, "'--player-model': '' is not one of"),
        (None, {"SRG_PLAYER_MODEL": "softmax"}, "SRG_PLAYER_MODEL: Input should be"),
    ],
)
def test_init_refuses_an_unknown_player_model_in_one_line_and_writes_nothing(
    tmp_path: Path, model: str | None, env: dict[str, str], fragment: str
) -> None:
    ok(tmp_path, "db", "upgrade")
    args = ("init", "g") if model is None else ("init", "g", "--player-model", model)
    one_line_error(srg(tmp_path, *args, **env), fragment)
    assert graph_count(tmp_path) == 0


# ---- srg analytics: the prediction ------------------------------------------------------
def test_analytics_says_how_well_the_model_predicted_the_latest_play(var: Path) -> None:
    report = analytics(var, "twice")
    prediction = report["prediction"]
    assert prediction["player_model"] == "eq2"  # the graph's
    assert prediction["publications_learned_from"] == 1
    assert prediction["sessions_learned_from"] == 8 and prediction["sessions_predicted"] == 8
    assert prediction["model_fit"] is None
    assert all(math.isfinite(prediction[key]) for key in PREDICTION_FIGURES)
    # the observed error of the latest publication is the analytics' own (the same steps)
    latest = report["observed_error"][-1]
    assert prediction["observed_mean_error"] == pytest.approx(latest["mean_error"])


def test_analytics_evaluates_another_model_when_asked(var: Path) -> None:
    eq2 = analytics(var, "twice")["prediction"]
    shrunk = analytics(var, "twice", "--player-model", "shrunk")["prediction"]
    assert shrunk["player_model"] == "shrunk" and shrunk["model_fit"]["prior_weight"] > 0.0
    assert all(math.isfinite(shrunk[key]) for key in PREDICTION_FIGURES)
    assert shrunk["observed_mean_error"] == eq2["observed_mean_error"]  # the same play
    assert shrunk["predicted_expected_error"] != eq2["predicted_expected_error"]
    text = ok(var, "analytics", "twice", "--player-model", "shrunk")
    assert "prediction of the latest publication's play" in text
    assert "predicted expected error" in text and "model fit:" in text
    # every model's fit prints (the mixed one named a radius the table once did not know)
    assert "kernel radius" in ok(var, "analytics", "twice", "--player-model", "mixed")
    # learnt from one publication: nothing chosen, mixed's share
    error = analytics(var, "twice", "--player-model", "mixed-error")["prediction"]["model_fit"]
    assert error["unseen_share"] == 0.5 and error["share_scores"] == {}
    text = ok(var, "analytics", "twice", "--player-model", "mixed-error")
    assert "share of heuristic players ranked for 0.5" in text


def test_analytics_before_two_played_publications_says_so_in_one_line(var: Path) -> None:
    assert analytics(var, "once")["prediction"] is None
    text = ok(var, "analytics", "once")
    lines = [line for line in text.splitlines() if line.startswith("prediction:")]
    assert lines == ["prediction: fewer than two publications played, nothing to compare yet"]


def test_analytics_refuses_an_unknown_player_model_in_one_line(var: Path) -> None:
    done = srg(var, "analytics", "twice", "--player-model", "softmax")
    one_line_error(done, "'--player-model': 'softmax' is not one of")
    assert done.stdout == ""


# ---- srg experiment: the plan's player model, bot and fixed-graph sessions --------------
def test_an_experiment_plans_the_player_model_bot_and_fixed_graph_sessions(
    tmp_path: Path,
) -> None:
    ok(tmp_path, "db", "upgrade")
    args = ("--seeds", "0", "--checkpoints", "300", "--sessions", "3", "--strategies", "baseline")
    chosen = ("--player-model", "shrunk", "--bots", "hesitant", "--fixed-graph-sessions", "4")
    ok(tmp_path, "experiment", *args, *chosen, "--result", str(tmp_path / "result.json"))
    result = json.loads((tmp_path / "result.json").read_text())
    plan = result["plan"]
    assert (plan["player_model"], plan["bots"], plan["fixed_graph_sessions"]) == (
        "shrunk",
        ["hesitant"],
        4,
    )
    # resumed, it keeps its stored plan: these options are refused like every plan option
    for option in (chosen[0:2], chosen[2:4], chosen[4:6]):
        one_line_error(
            srg(tmp_path, "experiment", "--resume", "--name", result["name"], *option),
            "--resume runs the stored plan",
        )
    ok(tmp_path, "experiment", "--resume", "--name", result["name"], "--json")
