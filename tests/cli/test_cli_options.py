"""`--json` means one thing in every command: a flag printing the JSON result on stdout.

A result file has its own option (``--result FILE``); benchmarks always print JSON and
take no ``--json``. The commands are read off the Typer app as Click builds them.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import typer.main

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
        "clip",
        "dedup",
        "experiment",
        "grow",
        "ingest",
        "look",
        "rank",
        "sph",
        "store",
        "writer",
    }
    assert [name for name in benches if "--json" in options_of(ALL[name])] == []


def test_result_files_are_one_option_everywhere() -> None:
    files = {name for name, c in ALL.items() if "--result" in options_of(c)}
    assert files == {"experiment", "demo", "validate"}
