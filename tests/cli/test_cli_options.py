"""`--json` means one thing in every command: a flag printing the JSON result on stdout.

A result file has its own option (``--result FILE``); benchmarks always print JSON and
take no ``--json``. The commands are read off the Typer app as Click builds them.
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
import typer.main
from cli_helpers import srg

from app.cli.main import app


def commands(group: Any, path: tuple[str, ...] = ()) -> Iterator[tuple[str, Any]]:
    for name, command in group.commands.items():
        if hasattr(command, "commands"):
            yield from commands(command, (*path, name))
        else:
            yield " ".join((*path, name)), command


def options_of(command: Any) -> dict[str, Any]:
    return {opt: param for param in command.params for opt in getattr(param, "opts", ())}


ALL = dict(commands(typer.main.get_command(app)))


#: the commands that print no result: the servers, Celery's programs, the migrations
PRINT_NO_RESULT = {"serve", "worker", "beat", "flower", "db upgrade", "db downgrade"}


def test_every_command_that_prints_a_result_takes_json() -> None:
    printing = {name for name in ALL if not name.startswith("bench ")} - PRINT_NO_RESULT
    assert {name for name in printing if "--json" not in options_of(ALL[name])} == set()


def test_every_json_option_is_a_flag() -> None:
    with_json = {
        name: options_of(c)["--json"] for name, c in ALL.items() if "--json" in options_of(c)
    }
    assert {"status", "init", "grow", "publish", "play", "gc", "analytics"} <= set(with_json)
    for name, param in with_json.items():
        assert param.is_flag, name
        assert param.secondary_opts == [], name  # no --no-json: the human form is the default


def test_benchmarks_take_no_json_option() -> None:
    benches = [name for name in ALL if name.startswith("bench ")]
    assert {name.split()[1] for name in benches} == {
        "bytes",
        "client",
        "clip",
        "completion",
        "dedup",
        "epoch-traces",
        "experiment",
        "gpu",
        "grow",
        "ingest",
        "look",
        "rank",
        "serve",
        "sph",
        "store",
        "writer",
    }
    assert [name for name in benches if "--json" in options_of(ALL[name])] == []


def test_result_files_are_one_option_everywhere() -> None:
    files = {name for name, c in ALL.items() if "--result" in options_of(c)}
    assert files == {"experiment", "demo", "validate"}


#: a broker no worker of the tests consumes from (tests/api/test_admin.py sends there too)
IDLE_BROKER = "redis://127.0.0.1:6379/15"


@pytest.fixture(scope="module")
def var(tmp_path_factory: pytest.TempPathFactory) -> Path:
    var = tmp_path_factory.mktemp("var")
    assert srg(var, "init", "g").returncode == 0
    return var


@pytest.mark.parametrize(
    "args",
    [
        ["init", "h"],
        ["grow", "g", "--expansions", "2"],
        ["publish", "g", "--no-render"],
        ["play", "g", "--sessions", "2", "--seed", "0"],
        ["status"],
        ["status", "g"],
        ["analytics", "g"],
        ["set-growing", "g", "--off"],
        ["gc"],
        ["fsck"],
    ],
)
def test_json_is_the_whole_of_stdout(var: Path, args: list[str]) -> None:
    """In this order: each command runs on what the ones before it made. ``experiment``,
    ``demo``, ``validate`` and ``calibrate`` are held to their result files in their own
    tests (tests/cli/test_cli_experiment.py, test_cli_graph.py, tests/unit/test_cli_liquid.py)."""
    done = srg(var, *args, "--json")
    assert done.returncode == 0, done.stderr
    assert isinstance(json.loads(done.stdout), dict | list)


def test_grow_epoch_prints_its_task_as_json(var: Path) -> None:
    import redis

    done = srg(var, "grow-epoch", "g", "--json", SRG_BROKER_URL=IDLE_BROKER)
    assert done.returncode == 0, done.stderr
    sent = json.loads(done.stdout)
    assert set(sent) == {"graph_id", "task_id"}
    redis.Redis.from_url(IDLE_BROKER).delete("celery")  # the task nobody will run
