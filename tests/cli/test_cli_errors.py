"""Bad input, bad configuration and broken files: one ``srg: error:`` line, exit 2.

Each test re-tries a finding that used to print a traceback (or a half-truth) and checks
that it is one line on stderr now and that nothing was written, on SQLite (names also on
PostgreSQL, whose bounded columns used to fail where SQLite stored anything).
"""

from __future__ import annotations

import json
import os
import re
import socket
import sqlite3
import subprocess
import uuid
from collections.abc import Iterator
from pathlib import Path

import pytest
from cli_helpers import SRG, ok, one_line_error, srg
from database_helpers import postgres_base_url, postgres_database
from sqlalchemy import select
from sqlalchemy.engine import make_url
from trace_helpers import looping_trace

from app.cli.output import progress_bar, user_error_message
from app.config import Settings
from app.core.errors import InvalidInput, NotFound
from app.db.engines import make_engine
from app.db.sessions import session_factory
from app.models import Graph
from app.store.publications import latest_publication, load_publication
from app.store.traces import bot_player, record_trace

HUGE_ID = "99999999999999999999"


@pytest.fixture(scope="module")
def var(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The embedded default with one toy graph."""
    var = tmp_path_factory.mktemp("var")
    ok(var, "init", "toy1")
    return var


def graph_names(url: str) -> list[str]:
    engine = make_engine(url)
    try:
        with engine.connect() as connection:
            return list(connection.scalars(select(Graph.name).order_by(Graph.id)))
    finally:
        engine.dispose()


def embedded_url(var: Path) -> str:
    return Settings(var_dir=var).resolved_database_url


# ---- the database ----------------------------------------------------------------------
def test_a_fresh_var_directory_gets_its_embedded_database_on_first_use(tmp_path: Path) -> None:
    """It used to fail with "no such table: graphs" and leave an empty database file."""
    var = tmp_path / "fresh"
    assert "no graphs yet" in ok(var, "status")
    ok(var, "init", "first")
    assert graph_names(embedded_url(var)) == ["first"]


def test_a_configured_sqlite_file_that_does_not_exist_is_neither_made_nor_used(
    tmp_path: Path,
) -> None:
    path = tmp_path / "elsewhere" / "srg.sqlite3"
    done = srg(tmp_path / "var", "status", SRG_DATABASE_URL=f"sqlite:///{path}")
    one_line_error(done, "run `srg db upgrade`")
    assert not path.exists()
    done = srg(tmp_path / "var", "db", "upgrade", SRG_DATABASE_URL=f"sqlite:///{path}")
    assert done.returncode == 0, done.stderr
    ok_status = srg(tmp_path / "var", "status", SRG_DATABASE_URL=f"sqlite:///{path}")
    assert "no graphs yet" in ok_status.stdout


def test_a_configured_database_without_tables_says_to_upgrade(tmp_path: Path) -> None:
    path = tmp_path / "empty.sqlite3"
    make_engine(f"sqlite:///{path}").dispose()
    engine = make_engine(f"sqlite:///{path}")
    with engine.begin() as connection:  # a database, but not srg's: no tables
        connection.exec_driver_sql("CREATE TABLE other (x INTEGER)")
    engine.dispose()
    for command in (["status"], ["init", "g"], ["analytics", "g"]):
        done = srg(tmp_path / "var", *command, SRG_DATABASE_URL=f"sqlite:///{path}")
        one_line_error(done, "run `srg db upgrade`")


@pytest.mark.postgres
def test_a_postgresql_database_without_tables_says_to_upgrade(tmp_path: Path) -> None:
    for url in postgres_database(postgres_base_url()):
        one_line_error(srg(tmp_path, "status", SRG_DATABASE_URL=url), "run `srg db upgrade`")


@pytest.mark.postgres
def test_a_postgresql_database_that_does_not_exist_says_to_create_it(tmp_path: Path) -> None:
    """The finding: the operator read "(unreachable)" and the server's "does not exist",
    with no word of how to make it (``srg db upgrade`` cannot: a server's databases are
    its operator's to make)."""
    base = make_url(postgres_base_url())
    name = f"srg_missing_{uuid.uuid4().hex[:10]}"
    url = base.set(port=base.port or 5432, database=name)
    create = f"createdb -h {url.host} -p {url.port} -U {url.username} {name}"
    hint = f"does not exist: create it with `{create}`, then run `srg db upgrade`"
    for command in (["status"], ["init", "g"], ["db", "upgrade"]):
        done = srg(tmp_path, *command, SRG_DATABASE_URL=url.render_as_string(hide_password=False))
        one_line_error(done, hint)


@pytest.mark.parametrize(
    ("url", "fragment"),
    [
        ("garbage", "SRG_DATABASE_URL"),
        ("nosuchdialect://user@host/db", "SRG_DATABASE_URL"),
    ],
)
def test_a_garbage_database_url_is_one_line(tmp_path: Path, url: str, fragment: str) -> None:
    for command in (["status"], ["init", "g"], ["db", "upgrade"]):
        one_line_error(srg(tmp_path, *command, SRG_DATABASE_URL=url), fragment)


def test_a_corrupted_sqlite_file_is_one_line_and_left_as_it_was(tmp_path: Path) -> None:
    path = tmp_path / "var" / "srg.sqlite3"
    path.parent.mkdir()
    garbage = b"SQLite format 3\x00" + bytes(range(256)) * 20
    path.write_bytes(garbage)
    for command in (["status"], ["init", "g"], ["status", "--json"]):
        one_line_error(srg(tmp_path / "var", *command), "not a database")
    assert path.read_bytes() == garbage


def test_an_unknown_revision_is_one_line(var: Path) -> None:
    one_line_error(srg(var, "db", "downgrade", "bogus"), "bogus")
    one_line_error(srg(var, "db", "upgrade", "bogus"), "bogus")
    assert graph_names(embedded_url(var)) == ["toy1"]


@pytest.mark.parametrize("command", ["status", "analytics", "grow", "publish", "play"])
def test_an_id_past_the_integer_range_names_no_graph(var: Path, command: str) -> None:
    one_line_error(srg(var, command, HUGE_ID), f"no graph '{HUGE_ID}'")


# ---- files and ports -------------------------------------------------------------------
def test_an_artifact_directory_that_is_a_file_is_one_line_and_writes_nothing(
    tmp_path: Path,
) -> None:
    var = tmp_path / "var"
    ok(var, "init", "kept")
    blocker = tmp_path / "not-a-directory"
    blocker.write_text("a file where the artifacts would go\n")
    for command in (["init", "g"], ["grow", "kept"], ["publish", "kept"], ["gc"]):
        done = srg(var, *command, SRG_ARTIFACT_DIR=str(blocker))
        one_line_error(done, "is not a directory")
    assert graph_names(embedded_url(var)) == ["kept"]
    assert json.loads(ok(var, "status", "kept", "--json"))["epochs"] == 0


@pytest.mark.parametrize("port", ["-1", "65536", "100000"])
def test_serve_refuses_a_port_out_of_range(tmp_path: Path, port: str) -> None:
    one_line_error(srg(tmp_path, "serve", "--port", port), "--port")


# ---- names -----------------------------------------------------------------------------
BAD_NAMES = [
    ("x" * 201, "at most 200 characters"),
    ("x" * 300, "at most 200 characters"),
    ("a/b", "no '/'"),
    ("../up", "no '/'"),
    ("two words", "no spaces"),
    (".hidden", "starts with a letter or a digit"),
    ("-flag-like", "starts with a letter or a digit"),
    ("12345", "all digits"),
    ("", "cannot be empty"),
]


@pytest.fixture(
    scope="module", params=["sqlite", pytest.param("postgresql", marks=pytest.mark.postgres)]
)
def backend_url(
    request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory
) -> Iterator[str]:
    """A migrated database of each backend, for names."""
    if request.param == "sqlite":
        var = tmp_path_factory.mktemp("names")
        yield f"sqlite:///{var / 'srg.sqlite3'}"
    else:
        yield from postgres_database(postgres_base_url(), migrated=True)


@pytest.mark.parametrize(("name", "fragment"), BAD_NAMES)
def test_bad_graph_names_are_refused_alike_on_every_backend(
    backend_url: str, tmp_path: Path, name: str, fragment: str
) -> None:
    ok_upgrade = srg(tmp_path, "db", "upgrade", SRG_DATABASE_URL=backend_url)
    assert ok_upgrade.returncode == 0, ok_upgrade.stderr
    done = srg(tmp_path, "init", "--", name, SRG_DATABASE_URL=backend_url)
    one_line_error(done, fragment)
    assert name not in graph_names(backend_url)


def test_the_longest_name_and_every_allowed_character_are_taken(
    backend_url: str, tmp_path: Path
) -> None:
    srg(tmp_path, "db", "upgrade", SRG_DATABASE_URL=backend_url)
    for name in ("y" * 200, "Tank_2.low-viscosity"):
        done = srg(tmp_path, "init", name, SRG_DATABASE_URL=backend_url)
        assert done.returncode == 0, done.stderr
    assert {"y" * 200, "Tank_2.low-viscosity"} <= set(graph_names(backend_url))


@pytest.mark.parametrize(("name", "fragment"), BAD_NAMES[2:5])
def test_bad_experiment_names_are_refused_by_the_same_rule(
    tmp_path: Path, name: str, fragment: str
) -> None:
    one_line_error(srg(tmp_path, "experiment", "--quick", f"--name={name}"), fragment)


@pytest.mark.parametrize(
    ("args", "fragment"),
    [
        (["--judges", "nobody"], "unknown bot 'nobody'"),
        (["--judges", "goal-directed"], "judges must be distinct bots"),
        (["--judges", "avoider", "--bots", "goal-directed,hesitant"], "pool the crowds"),
        (["--seeds", "0,10"], "selection seeds"),
        (["--seeds", "-1"], "non-negative"),
        (["--player-model", "mystery"], "'--player-model': 'mystery' is not one of"),
        (["--shares", "0.5,0.5", "--bots", "goal-directed,hesitant"], "pooled crowds"),
        (["--shares", "half", "--pooled"], "comma-separated numbers"),
        (["--bots", "goal-directed,hesitant", "--pooled", "--shares", "0.7,0.7"], "sum to 1"),
        (["--preregistration", "/nonexistent/plan.md"], "No such file or directory"),
    ],
)
def test_bad_experiment_plans_are_one_line_and_store_nothing(
    tmp_path: Path, args: list[str], fragment: str
) -> None:
    srg(tmp_path, "db", "upgrade")
    one_line_error(srg(tmp_path, "experiment", "--quick", *args), fragment)
    assert "experiment" not in srg(tmp_path, "status").stdout


def test_a_scoreboard_of_nothing_or_of_a_bad_judge_file_is_one_line(tmp_path: Path) -> None:
    srg(tmp_path, "db", "upgrade")
    one_line_error(srg(tmp_path, "results", "scoreboard", "nothing"), "no experiment named")
    ok(tmp_path, "experiment", "--quick", "--checkpoints", "200", "--seeds", "0,1")
    name = "experiment-toy"
    bad = tmp_path / "judge.jsonl"
    bad.write_text('{"publication_id": 999999, "mean_error": 0.1, "high_share": 0}\n')
    args = ("results", "scoreboard", name, "--outside")
    one_line_error(srg(tmp_path, *args, str(bad)), "line 1: not a judged publication")
    one_line_error(srg(tmp_path, *args, str(tmp_path / "none")), "No such file")
    one_line_error(
        srg(tmp_path, "results", "scoreboard", name, "--primary-players", "nobody"),
        "no players 'nobody'",
    )
    junk = tmp_path / "junk.npz"
    junk.write_text("not a play")
    from_junk = ("results", "scoreboard", name, "--from", str(junk))
    one_line_error(srg(tmp_path, *from_junk), "not a play file of srg")
    one_line_error(srg(tmp_path, *from_junk, "--outside", str(bad)), "--outside is read when")
    play = tmp_path / "play.npz"
    ok(tmp_path, "results", "export", name, str(play))
    one_line_error(
        srg(tmp_path, "results", "scoreboard", "other", "--from", str(play)),
        "holds the experiment 'experiment-toy', not 'other'",
    )
    judged = ("results", "scoreboard", name, "--json")
    assert ok(tmp_path, *judged, "--from", str(play)) == ok(tmp_path, *judged)
    one_line_error(
        srg(tmp_path, "results", "export", name, str(play), "--only-seeds", "0,7"),
        "--only-seeds must name seeds of the plan (0, 1)",
    )
    ok(tmp_path, "results", "export", name, str(tmp_path / "0.npz"), "--only-seeds", "0")
    ok(tmp_path, "results", "export", name, str(tmp_path / "1.npz"), "--only-seeds", "1")
    parts = ("--from", str(tmp_path / "1.npz"), "--from", str(tmp_path / "0.npz"))
    assert ok(tmp_path, *judged, *parts) == ok(tmp_path, *judged)


# ---- init options ----------------------------------------------------------------------
@pytest.mark.parametrize(
    ("args", "fragment"),
    [
        (["--depth", "50"], "at most depth 6"),
        (["--depth", "99999999999999999999"], "at most depth 6"),
        (["--depth", "1"], "'--depth': Input should be greater than or equal to 2"),
        (["--depth", "-3"], "'--depth': Input should be greater than or equal to 2"),
        (["--preset", "tiny"], "preset"),
        (["--dynamics", "toy", "--preset", "paper"], "preset"),
    ],
)
def test_init_refuses_a_deep_tree_and_a_preset_for_the_toy(
    var: Path, args: list[str], fragment: str
) -> None:
    one_line_error(srg(var, "init", "refused", *args), fragment)
    assert graph_names(embedded_url(var)) == ["toy1"]


def test_init_takes_a_deeper_tree_within_the_bound(tmp_path: Path) -> None:
    summary = json.loads(ok(tmp_path, "init", "deep", "--depth", "3", "--json"))
    assert summary["sim_edges"] == 3 + 9 and summary["blend_edges"] == 27


# ---- progress bars ---------------------------------------------------------------------
def test_a_frame_budget_that_is_not_a_whole_expansion_never_overshoots_its_bar(
    tmp_path: Path,
) -> None:
    ok(tmp_path, "init", "g")
    done = srg(tmp_path, "grow", "g", "--frames", "27")
    assert done.returncode == 0, done.stderr
    assert "27/27" in done.stderr and "30/27" not in done.stderr


@pytest.mark.parametrize("budget", [["--frames", "-5"], ["--expansions", "-5"], ["--frames", "0"]])
def test_a_negative_budget_is_refused_before_any_bar(tmp_path: Path, budget: list[str]) -> None:
    ok(tmp_path, "init", "g")
    done = srg(tmp_path, "grow", "g", *budget)
    one_line_error(done, "Input should be greater than or equal to 1")
    assert "/-5" not in done.stderr and "0/0" not in done.stderr


def test_a_budget_beyond_what_a_graph_can_number_is_refused(tmp_path: Path) -> None:
    ok(tmp_path, "init", "g")
    one_line_error(
        srg(tmp_path, "grow", "g", "--expansions", "1" + "0" * 30),
        "Input should be less than or equal to 2147483647",
    )


def test_an_id_of_thousands_of_digits_names_no_graph_in_one_short_line(tmp_path: Path) -> None:
    ok(tmp_path, "init", "g")
    done = srg(tmp_path, "status", "9" * 5000)
    one_line_error(done, "no graph '9999")
    assert "(5000 characters)" in done.stderr and len(done.stderr) < 200


def test_the_progress_bar_stays_within_zero_and_its_total(
    capsys: pytest.CaptureFixture[str],
) -> None:
    with progress_bar(-5, "negative") as advance:
        advance(3)
    with progress_bar(27, "over") as advance:
        for _ in range(4):
            advance(10)
    with progress_bar(10, "backwards") as advance:
        advance(-4)
    err = capsys.readouterr().err
    assert "0/0" in err and "27/27" in err and "0/10" in err
    assert "-5" not in err and "40/27" not in err and "-4/10" not in err
    assert err.count(" left ") == 3  # every bar says how long it has to go


# ---- growth after huge traces (STATERANK's non-convergence) ---------------------------
def test_grow_goes_on_after_two_huge_looping_traces(tmp_path: Path) -> None:
    """The graph that stalled STATERANK: two 85,000-step looping sessions of one player."""
    ok(tmp_path, "init", "looped", "--strategy", "sr-crowd")
    ok(tmp_path, "grow", "looped", "--expansions", "2")
    ok(tmp_path, "publish", "looped")
    engine = make_engine(embedded_url(tmp_path))
    try:
        with session_factory(engine)() as session:
            graph_id = session.scalars(select(Graph.id).where(Graph.name == "looped")).one()
            row = latest_publication(session, graph_id)
            assert row is not None
            publication = load_publication(session, row.id)
            player = bot_player(session, "looper")
            for key in ("a", "b"):
                trace = looping_trace(publication, 1, 85_000)
                record_trace(session, row.id, player, key, trace, publication=publication)
            session.commit()
    finally:
        engine.dispose()
    grown = json.loads(ok(tmp_path, "grow", "looped", "--expansions", "4", "--json"))
    assert grown["expansions"] == 4
    status = json.loads(ok(tmp_path, "status", "looped", "--json"))
    assert status["play"]["traces"] == 2 and status["play"]["steps"] == 170_000


# ---- status shows play -----------------------------------------------------------------
def test_status_shows_play_traces_players_and_the_last_upload(tmp_path: Path) -> None:
    ok(tmp_path, "init", "played")
    fresh = json.loads(ok(tmp_path, "status", "played", "--json"))
    assert fresh["play"] == {"traces": 0, "steps": 0, "players": 0, "last_upload": None}
    ok(tmp_path, "publish", "played")
    ok(tmp_path, "play", "played", "--sessions", "3")
    ok(tmp_path, "play", "played", "--sessions", "2", "--bot", "random")
    play = json.loads(ok(tmp_path, "status", "played", "--json"))["play"]
    assert play["traces"] == 5 and play["players"] == 2 and play["steps"] >= 5
    assert play["last_upload"] is not None
    engine = make_engine(embedded_url(tmp_path))
    try:
        with engine.connect() as connection:
            steps = connection.exec_driver_sql("SELECT count(*) FROM trace_steps").scalar()
    finally:
        engine.dispose()
    assert play["steps"] == steps
    table = ok(tmp_path, "status", "played")
    for figure, value in (("traces", "5"), ("players", "2"), ("last upload", play["last_upload"])):
        assert re.search(rf"^\s*{figure}\s+{re.escape(value)}\s*$", table, re.MULTILINE), table


def test_a_setting_of_the_wrong_type_is_named_in_one_line(tmp_path: Path) -> None:
    done = srg(tmp_path, "status", SRG_BATCH_SIZE="abc")
    one_line_error(done, "SRG_BATCH_SIZE: Input should be a valid integer")


def test_bad_settings_of_several_groups_are_named_in_the_same_line(tmp_path: Path) -> None:
    done = srg(tmp_path, "status", SRG_BATCH_SIZE="0", SRG_TASK_TIME_LIMIT="x", SRG_ALPHA="2")
    for named in (
        "SRG_BATCH_SIZE: Input should be greater than or equal to 1",
        "SRG_ALPHA: Input should be less than or equal to 1",
        "SRG_TASK_TIME_LIMIT: Input should be a valid integer",
    ):
        one_line_error(done, named)


@pytest.mark.parametrize(
    ("variable", "value", "says"),
    [
        ("SRG_PREFILTER_K", "-1", "greater than or equal to 1"),
        ("SRG_ALPHA", "2", "less than or equal to 1"),
        ("SRG_BATCH_SIZE", "0", "greater than or equal to 1"),
        ("SRG_BATCH_SIZE", "-3", "greater than or equal to 1"),
        ("SRG_CROWD_EPS", "-1", "greater than 0"),
        ("SRG_RESTART_STEPS", "0", "greater than or equal to 1"),
        ("SRG_MAX_TRACE_BYTES", "-1", "greater than or equal to 1"),
        ("SRG_UPLOADS_PER_MINUTE", "0", "greater than or equal to 1"),
        ("SRG_HIGH_ERROR_THRESHOLD", "nan", "finite number"),
        ("SRG_BEAT_INTERVAL", "inf", "finite number"),
        ("SRG_PUBLISH_EVERY", "-600", "greater than or equal to 0"),
        ("SRG_PLAYER_MODEL", "bogus", "'eq2', 'shrunk', 'mixed' or 'mixed-error'"),
    ],
)
def test_a_setting_out_of_its_range_is_named_in_one_line_before_anything_runs(
    tmp_path: Path, variable: str, value: str, says: str
) -> None:
    done = srg(tmp_path, "init", "g", "--dynamics", "toy", **{variable: value})
    one_line_error(done, f"{variable}: Input should be")
    assert says in done.stderr
    assert not (tmp_path / "srg.sqlite3").exists()


@pytest.mark.parametrize(
    ("variable", "value"),
    [
        ("SRG_TRUSTED_PROXIES", "10.0.0.300"),
        ("SRG_REGISTRATION_RATE", "often"),
        ("SRG_RATE_LIMIT_STORAGE", "bogus://nowhere"),
    ],
)
def test_serve_names_a_setting_it_cannot_read_in_one_line(
    tmp_path: Path, variable: str, value: str
) -> None:
    one_line_error(srg(tmp_path, "serve", **{variable: value}), variable)


# ---- what is the user's to fix, and what is a bug --------------------------------------
def test_only_srg_errors_and_the_mapped_library_errors_are_the_users() -> None:
    assert user_error_message(InvalidInput("a bad name")) == "a bad name"
    assert user_error_message(NotFound("no graph 'x'")) == "no graph 'x'"
    for bug in (ValueError("a bug"), LookupError("a bug"), RuntimeError("a bug")):
        assert user_error_message(bug) is None


def test_a_bug_keeps_its_traceback(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import app.db.sessions

    def broken(settings: object) -> None:
        raise ValueError("a bug, not the user's")

    # the command imports it as it runs (the CLI is declared without the database)
    monkeypatch.setattr(app.db.sessions, "transaction", broken)
    with pytest.raises(ValueError, match="a bug"):
        srg(tmp_path, "status")


# ---- usage, the machine's errors, a broker, a port: one line each -----------------------
@pytest.mark.parametrize(
    ("args", "says"),
    [
        (["grow"], "Missing argument 'name'. (see srg grow --help)"),
        (["grow", "g", "--bogus"], "No such option: --bogus (see srg grow --help)"),
        (["nosuch"], "No such command 'nosuch'. (see srg --help)"),
        (["grow", "g", "--expansions", "abc"], "Invalid value for '--expansions'"),
        (["analytics", "g", "--top", "-1"], "'--top': Input should be greater than or equal to 1"),
    ],
)
def test_usage_errors_are_one_line(tmp_path: Path, args: list[str], says: str) -> None:
    one_line_error(srg(tmp_path, *args), says)


def test_an_unusable_var_dir_is_one_line(tmp_path: Path) -> None:
    blocker = tmp_path / "file"
    blocker.write_text("not a directory")
    done = srg(blocker / "var", "init", "g")
    one_line_error(done, f"SRG_VAR_DIR: Value error, {blocker / 'var'} is not a directory")


@pytest.mark.parametrize(
    ("broker", "says"),
    [
        ("redis://127.0.0.1:1/0", "cannot reach the broker"),
        ("bogus://nowhere", "SRG_BROKER_URL: "),  # tests/cli/test_cli_broker_url.py
    ],
)
def test_an_unreachable_broker_is_one_line_before_anything_is_written(
    tmp_path: Path, broker: str, says: str
) -> None:
    ok(tmp_path, "db", "upgrade")
    done = srg(
        tmp_path, "experiment", "--seeds", "0", "--checkpoints", "300", SRG_BROKER_URL=broker
    )
    one_line_error(done, says)
    with sqlite3.connect(tmp_path / "srg.sqlite3") as db:
        assert db.execute("SELECT count(*) FROM experiments").fetchone() == (0,)


def test_serve_on_a_port_in_use_or_a_host_of_no_interface_is_one_line(tmp_path: Path) -> None:
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = str(taken.getsockname()[1])
        one_line_error(srg(tmp_path, "serve", "--port", port), "Address already in use")
    one_line_error(srg(tmp_path, "serve", "--host", "999.1.1.1"), "cannot listen on 999.1.1.1")


def test_a_var_dir_that_is_a_file_is_named_in_its_error(tmp_path: Path) -> None:
    in_the_way = tmp_path / "var"
    in_the_way.write_text("not a directory")
    for var in (in_the_way, in_the_way / "below"):
        one_line_error(srg(var, "status"), f"SRG_VAR_DIR: Value error, {var} is not a directory")
    assert in_the_way.read_text() == "not a directory"


def test_an_unknown_revision_is_the_only_line_migrate_prints(tmp_path: Path) -> None:
    """Alembic's set-up lines used to come first; a run's own lines still show."""
    env = {**os.environ, "SRG_VAR_DIR": str(tmp_path)}
    env.pop("SRG_DATABASE_URL", None)
    done = subprocess.run(
        [str(SRG), "db", "upgrade", "nonsense"], capture_output=True, text=True, env=env
    )
    assert done.returncode == 2
    assert done.stderr.splitlines() == [
        "srg: error: cannot upgrade to 'nonsense': Can't locate revision identified by 'nonsense'"
    ]
    done = subprocess.run([str(SRG), "db", "upgrade"], capture_output=True, text=True, env=env)
    assert done.returncode == 0 and "Running upgrade  -> 0001" in done.stderr


def test_a_resume_under_an_edited_preregistration_is_refused(tmp_path: Path) -> None:
    """The plan file's digest is stored with the experiment: once it changed, the runs
    do not go on under it (studies are never edited after their first run)."""
    plan = tmp_path / "plan.md"
    plan.write_text("# plan\n")
    args = ("experiment", "--quick", "--checkpoints", "200", "--seeds", "0,1")
    ok(tmp_path, *args, "--name", "bound", "--through", "200", "--preregistration", str(plan))
    plan.write_text("# plan, edited after the first run\n")
    one_line_error(
        srg(tmp_path, "experiment", "--resume", "--name", "bound"),
        f"the pre-registered plan {plan} changed since the experiment started",
    )
    plan.unlink()
    one_line_error(srg(tmp_path, "experiment", "--resume", "--name", "bound"), "is missing")
