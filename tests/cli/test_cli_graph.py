"""The `srg` command end to end: the happy path and its error paths.

Commands run in-process through ``app.cli.main`` (the console script's own entry, with
its error handling) against a SQLite file under a temp SRG_VAR_DIR; one test runs the
real console script in a subprocess. Errors must be one line on stderr, exit status 2,
and leave the database as it was.
"""

from __future__ import annotations

import json
import os
import subprocess
from pathlib import Path

import pytest
from cli_helpers import SRG, ok, one_line_error, srg
from sqlalchemy import func, select

from app.api.app import create_app
from app.api.local_server import serve_in_thread
from app.config import Settings
from app.db.engines import make_engine
from app.models import Trace


@pytest.fixture(scope="module")
def var(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A database with one toy graph grown, published and played."""
    var = tmp_path_factory.mktemp("var")
    ok(var, "db", "upgrade")
    ok(var, "init", "toy1")
    ok(var, "grow", "toy1", "--expansions", "6")
    ok(var, "publish", "toy1")
    ok(var, "play", "toy1", "--sessions", "5")
    return var


def status(var: Path) -> dict[str, object]:
    return dict(json.loads(ok(var, "status", "toy1", "--json")))


def test_the_graph_commands_grow_publish_and_play(var: Path) -> None:
    before = status(var)
    assert before["sim_edges"] == 3 + 6 and before["latest_publication"] == 1
    assert before["unrendered_edges"] == 0
    grown = json.loads(ok(var, "grow", "toy1", "--frames", "90", "--json"))
    assert grown["expansions"] == 3 and grown["size_frames"] == before["size_frames"] + 90
    played = json.loads(ok(var, "play", "toy1", "--sessions", "3", "--json"))
    assert played["traces"] == 3 and played["publication_id"] == 1


def test_an_unknown_graph_is_one_line_and_exit_2(var: Path) -> None:
    for command in (["grow", "nope"], ["publish", "nope"], ["play", "nope"], ["status", "nope"]):
        one_line_error(srg(var, *command), "no graph 'nope'")


def test_bad_strategy_bot_and_budget_write_nothing(var: Path) -> None:
    before = status(var)
    one_line_error(srg(var, "grow", "toy1", "--strategy", "greedy"), "'greedy' is not one of")
    one_line_error(srg(var, "grow", "toy1", "--expansions", "0"), "greater than or equal to 1")
    one_line_error(srg(var, "grow", "toy1", "--expansions", "1", "--frames", "30"), "not both")
    one_line_error(srg(var, "play", "toy1", "--bot", "cheater"), "'cheater' is not one of")
    one_line_error(srg(var, "init", "toy1"), "already exists")
    one_line_error(srg(var, "init", "x", "--dynamics", "lava"), "'lava' is not one of")
    assert status(var) == before


def test_init_counts_the_clips_of_its_tree_and_a_refusal_shows_no_bar(var: Path) -> None:
    done = srg(var, "init", "counted", "--depth", "3")
    assert done.returncode == 0, done.stderr
    assert "clips of the initial tree" in done.stderr and "39/39" in done.stderr  # 3 + 9 + 27
    refused = srg(var, "init", "counted")
    one_line_error(refused, "already exists")
    assert "clips of the initial tree" not in refused.stderr


def test_an_unpublished_graph_cannot_be_played(var: Path) -> None:
    ok(var, "init", "fresh")
    one_line_error(srg(var, "play", "fresh"), "no publication yet")


def test_the_console_script_reports_an_unreachable_database_in_one_line(tmp_path: Path) -> None:
    environment = {
        **os.environ,
        "SRG_VAR_DIR": str(tmp_path),
        "SRG_DATABASE_URL": "postgresql+psycopg://nobody@127.0.0.1:9/none",
    }
    done = subprocess.run(
        [str(SRG), "status"], capture_output=True, text=True, env=environment, timeout=120
    )
    one_line_error(done, "cannot use the database")


def test_an_unreachable_server_is_one_line(tmp_path: Path) -> None:
    done = srg(tmp_path, "play", "toy1", "--url", "http://127.0.0.1:9")
    one_line_error(done, "cannot reach the server")


def test_play_over_http_stores_traces_through_the_api(var: Path) -> None:
    settings = Settings(var_dir=var)
    before = _trace_count(settings)
    with serve_in_thread(create_app(settings)) as url:
        result = json.loads(ok(var, "play", "toy1", "--url", url, "--sessions", "4", "--json"))
        missing = srg(var, "play", "nope", "--url", url)
    assert result["created"] == 4 and result["replayed"] == 0
    assert _trace_count(settings) == before + 4
    one_line_error(missing, "404 no graph 'nope'")


def _trace_count(settings: Settings) -> int:
    engine = make_engine(settings.resolved_database_url)
    try:
        with engine.connect() as connection:
            return int(connection.scalar(select(func.count()).select_from(Trace)) or 0)
    finally:
        engine.dispose()


def test_the_demo_grows_three_graphs_side_by_side_and_publishes_one_to_play(
    tmp_path: Path,
) -> None:
    out = tmp_path / "report"
    result_json = tmp_path / "demo.json"
    ok(tmp_path, "db", "upgrade")
    args = ["demo", "--dynamics", "toy", "--checkpoints", "300,900", "--sessions", "6"]
    printed = ok(tmp_path, *args, "--out", str(out), "--result", str(result_json))
    result = json.loads(result_json.read_text())
    played = result["crowds"]["goal-directed"]["results"]
    assert set(played) == {"baseline", "sr-heuristic", "sr-crowd"}
    # sr-crowd / sr-heuristic (what the traces add) beside sr-crowd / baseline, per checkpoint
    compared = result["comparison"]["goal-directed"]
    assert [row["checkpoint_frames"] for row in compared] == [300, 900]
    assert all(row["crowd_vs_heuristic"]["per_seed"] for row in compared)
    assert "sr-heuristic" in printed
    sizes = [row["size_frames"] for row in played["sr-crowd"]["0"]]
    assert sizes == [300, 900]
    report = (out / "report.md").read_text()
    assert "demo.sr-crowd.0" in report and "srg serve" in printed
    assert (out / "goal-directed" / "error-per-step.png").stat().st_size > 0
    assert (out / "contact-sheet.png").stat().st_size > 0
    playable = json.loads(ok(tmp_path, "status", "demo.sr-crowd.0", "--json"))
    assert playable["unrendered_edges"] == 0 and playable["latest_publication"] == 3
    # run again: the demo is stored, so it grows nothing and only publishes again
    again = srg(tmp_path, *args, "--out", str(out), "--json")
    assert again.returncode == 0 and "report:" in again.stderr
    assert json.loads(again.stdout)["crowds"] == result["crowds"]
    one_line_error(srg(tmp_path, "demo", "--sessions", "0"), "greater than or equal to 1")
    one_line_error(srg(tmp_path, *args[:-1], "7"), "other settings")
