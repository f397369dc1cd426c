"""``--help`` read in a terminal of 80 columns: no ``<bool>`` on a flag, which takes no
value; no choice list folded mid-word; every command's summary wraps as one sentence."""

from __future__ import annotations

import os
import subprocess
from typing import Any

import pytest
from cli_helpers import SRG

from app.cli.main import click_command


def help_text(*args: str) -> str:
    env = {**os.environ, "COLUMNS": "80", "TERM": "dumb"}
    done = subprocess.run([str(SRG), *args, "--help"], capture_output=True, text=True, env=env)
    assert done.returncode == 0, done.stderr
    return done.stdout


def paths(command: Any, path: tuple[str, ...] = ()) -> list[tuple[str, ...]]:
    found = [path]
    for name, sub in getattr(command, "commands", {}).items():
        found += paths(sub, (*path, name))
    return found


@pytest.mark.parametrize("args", [(), ("experiment",), ("init",), ("bench",), ("db", "upgrade")])
def test_help_has_no_bool_metavar(args: tuple[str, ...]) -> None:
    assert "<bool>" not in help_text(*args)


def test_every_choice_list_has_room_to_wrap_between_choices() -> None:
    """A table wraps at spaces: "[tiny|small|paper]" has none, so a narrow column cut it
    mid-word; "[tiny | small | paper]" breaks between two choices."""
    command = click_command()
    choices = 0
    for path in paths(command):
        sub = command
        for name in path:
            sub = sub.commands[name]
        for param in sub.params:
            if listed := getattr(param.type_descriptor, "choices", None):
                choices += 1
                assert param.metavar.count(" | ") == len(listed) - 1, (path, param.name)
    assert choices > 10
    assert "[tiny | small |" in help_text("init")


def test_every_summary_is_one_line_of_its_docstring() -> None:
    """The summaries ``srg --help`` lists are their docstring's first paragraph, joined:
    the table wraps them at its own width, never at the docstring's line breaks."""
    command = click_command()
    for path in paths(command)[1:]:
        sub = command
        for name in path:
            sub = sub.commands[name]
        if sub.help:
            assert "\n" not in sub.short_help, path
            assert sub.short_help == " ".join(sub.help.split("\n\n")[0].split()), path
    listed = help_text()
    assert "stored like players' uploads, under a bot player." in " ".join(
        line.strip("│ ") for line in listed.splitlines()
    )
