"""People and bots apart: who played is said at registration, `srg analytics --players`
computes every figure from their sessions only and warns where a figure rests on too few,
and `srg play` draws a fresh seed unless given one (and says which)."""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

import httpx
import pytest
from cli_helpers import ok, one_line_error, srg
from sqlalchemy.orm import Session

from app.api.app import create_app
from app.api.client import publication_from_json
from app.api.local_server import serve_in_thread
from app.config import Settings
from app.core.players.bots import play_sessions
from app.core.players.kinds import BotKind
from app.db.engines import make_engine
from app.store.traces import load_traces

#: sessions of people on the first publication (the web client's requests, over HTTP)
PEOPLE_SESSIONS = 3
#: bot sessions on each of the two publications
BOT_SESSIONS = 12


def play_as_people(url: str, graph: str, sessions: int) -> None:
    """Each session a new person registering and uploading as the web client does."""
    with httpx.Client(base_url=url) as http:
        data = http.get(f"/api/graphs/{graph}/publication").json()
        publication = publication_from_json(data)
        traces = play_sessions(
            publication, BotKind.RANDOM, sessions=sessions, mean_steps=30, seed=7
        )
        for i, trace in enumerate(traces):
            registered = http.post("/api/players", json={"kind": "person"})
            assert registered.status_code == 201 and registered.json()["kind"] == "person"
            token = registered.json()["token"]
            body = {
                "publication_id": data["publication_id"],
                "idempotency_key": f"person-{i}",
                "steps": trace.tolist(),
            }
            reply = http.post(
                "/api/traces", json=body, headers={"Authorization": f"Bearer {token}"}
            )
            assert reply.status_code == 201, reply.text


@pytest.fixture(scope="module")
def var(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A toy graph played by people on its first publication and by bots on both."""
    var = tmp_path_factory.mktemp("var")
    ok(var, "db", "upgrade")
    ok(var, "init", "mixed", "--player-model", "eq2")
    ok(var, "grow", "mixed", "--expansions", "6")
    ok(var, "publish", "mixed")
    with serve_in_thread(create_app(Settings(var_dir=var))) as url:
        play_as_people(url, "mixed", PEOPLE_SESSIONS)
    ok(var, "play", "mixed", "--sessions", str(BOT_SESSIONS), "--seed", "0")
    ok(var, "grow", "mixed", "--expansions", "6")
    ok(var, "publish", "mixed")
    ok(var, "play", "mixed", "--sessions", str(BOT_SESSIONS), "--seed", "1")
    ok(var, "init", "seeds")
    ok(var, "grow", "seeds", "--expansions", "3")
    ok(var, "publish", "seeds")
    return var


def analytics(var: Path, *args: str, graph: str = "mixed") -> dict[str, Any]:
    return dict(json.loads(ok(var, "analytics", graph, *args, "--json")))


def stored_traces(var: Path, publication_id: int) -> list[list[list[int]]]:
    """Every trace of the publication, oldest first."""
    engine = make_engine(Settings(var_dir=var).resolved_database_url)
    try:
        with Session(engine) as session:
            return [trace.tolist() for trace in load_traces(session, [publication_id])]
    finally:
        engine.dispose()


# ---- srg analytics --players ------------------------------------------------------------
def test_every_figure_is_computed_from_the_players_chosen(var: Path) -> None:
    everyone, people, bots = (
        analytics(var),
        *(analytics(var, "--players", p) for p in ("people", "bots")),
    )
    assert (everyone["players"], people["players"], bots["players"]) == ("all", "people", "bots")
    kinds = {"person": PEOPLE_SESSIONS, "bot": 2 * BOT_SESSIONS}
    assert everyone["sessions_by_kind"] == people["sessions_by_kind"] == kinds

    def sessions(report: dict[str, Any]) -> list[int]:
        return [row["sessions"] for row in report["observed_error"]]

    assert sessions(people) == [PEOPLE_SESSIONS]  # on the first publication only
    assert sessions(bots) == [BOT_SESSIONS, BOT_SESSIONS]
    assert sessions(everyone) == [PEOPLE_SESSIONS + BOT_SESSIONS, BOT_SESSIONS]
    lengths = [r["session_lengths"]["sessions"] for r in (people, bots, everyone)]
    assert lengths == [PEOPLE_SESSIONS, 2 * BOT_SESSIONS, PEOPLE_SESSIONS + 2 * BOT_SESSIONS]

    def visits(report: dict[str, Any]) -> dict[int, int]:
        return {row["vertex"]: row["visits"] for row in report["visit_counts"]}

    pooled = {v: visits(people).get(v, 0) + visits(bots).get(v, 0) for v in visits(everyone)}
    assert pooled == visits(everyone)
    steps = [sum(r["n"] for r in report["control_probabilities"]) for report in (people, bots)]
    assert sum(steps) == sum(r["n"] for r in everyone["control_probabilities"])
    # the prediction too: people played one publication, nothing to predict; bots two
    assert people["prediction"] is None
    assert bots["prediction"]["sessions_learned_from"] == BOT_SESSIONS
    assert everyone["prediction"]["sessions_learned_from"] == PEOPLE_SESSIONS + BOT_SESSIONS


def test_players_default_to_all_and_a_bad_choice_is_one_line(var: Path) -> None:
    assert analytics(var)["players"] == "all"
    done = srg(var, "analytics", "mixed", "--players", "humans")
    one_line_error(done, "'--players': 'humans' is not one of 'people', 'bots', 'all'")
    assert done.stdout == ""


# ---- warnings and readable tables -------------------------------------------------------
def test_a_figure_on_too_few_sessions_is_warned_of_in_json_and_text(var: Path) -> None:
    warnings = analytics(var, "--players", "people")["warnings"]
    figures = {w["figure"]: w for w in warnings}
    assert {
        "mean error of publication 1",
        "high-error share of publication 1",
        "mean session length",
    } <= set(figures)
    for warning in warnings:
        assert warning["sessions"] == PEOPLE_SESSIONS and warning["sessions_needed"] >= 9
        assert warning["message"].startswith(f"{warning['figure']} rests on 3 sessions")
    text = ok(var, "analytics", "mixed", "--players", "people")
    lines = [line for line in text.splitlines() if line.startswith("warning: ")]
    assert [line.removeprefix("warning: ") for line in lines] == [w["message"] for w in warnings]
    # the figures themselves carry their spread
    row = analytics(var, "--players", "bots")["observed_error"][0]
    assert row["mean_error_relative_se"] > 0 and row["high_error_fraction_relative_se"] > 0


def test_tables_are_headed_in_words_with_one_precision_per_column(var: Path) -> None:
    text = ok(var, "analytics", "mixed")
    for header in ("publication", "mean", "high-error", "median", "steps from it", "probability"):
        assert header in text
    assert "predicted expected error" in text and "visit density correlation" in text
    assert not re.search(r"\b[a-z0-9]+_[a-z0-9_]+\b", text), text  # no snake_case key
    probabilities = re.findall(r"^\s+\d+\s+\d\s+[\d,]+\s+(\d+\.\d+)\s*$", text, re.MULTILINE)
    assert len(probabilities) > 3
    assert {len(p.split(".")[1]) for p in probabilities} == {3}


# ---- srg play's seed --------------------------------------------------------------------
def test_play_draws_a_fresh_seed_unless_given_and_says_which(var: Path) -> None:
    first, second = (
        json.loads(ok(var, "play", "seeds", "--sessions", "3", "--json")) for _ in range(2)
    )
    assert first["seed"] != second["seed"]
    played = stored_traces(var, first["publication_id"])
    assert played[:3] != played[3:]  # two runs, two crowds' play
    again = json.loads(
        ok(var, "play", "seeds", "--sessions", "3", "--seed", str(first["seed"]), "--json")
    )
    assert again["seed"] == first["seed"]
    assert stored_traces(var, first["publication_id"])[6:] == played[:3]  # repeated exactly
    assert re.search(r"^\s*seed\s+\d+\s*$", ok(var, "play", "seeds", "--sessions", "1"), re.M)
    one_line_error(srg(var, "play", "seeds", "--seed", "-1"), "greater than or equal to 0")


def test_play_over_http_registers_a_bot_and_reports_its_seed(var: Path) -> None:
    before = analytics(var, graph="seeds")["sessions_by_kind"]
    with serve_in_thread(create_app(Settings(var_dir=var))) as url:
        args = ("play", "seeds", "--url", url, "--sessions", "2", "--json")
        chosen = json.loads(ok(var, *args, "--seed", "5"))
        drawn = json.loads(ok(var, *args))
    assert chosen["seed"] == 5 and isinstance(drawn["seed"], int)
    after = analytics(var, graph="seeds")["sessions_by_kind"]
    assert after == {"person": before["person"], "bot": before["bot"] + 4}
