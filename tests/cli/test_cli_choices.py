"""Choices and ranges as Typer means them: every choice an enum, listed in ``--help``,
refused by the parser in one ``srg: error:`` line and completed by the shell; every
number range-checked the same way; comma-separated lists checked element by element."""

from __future__ import annotations

from enum import StrEnum
from pathlib import Path
from typing import Any

import pytest
import typer.main
from cli_helpers import one_line_error, srg

from app.cli.choices import DynamicsName, Fluid, LiquidPreset, LogLevel
from app.cli.main import app
from app.core.growth.kinds import Strategy
from app.core.players.kinds import BotKind, PlayerModelKind, PlayerSelection
from app.services.dynamics import DYNAMICS_NAMES, LIQUID_FLUIDS, LIQUID_PRESETS


def test_the_cli_enums_name_what_the_services_know() -> None:
    assert tuple(DynamicsName) == DYNAMICS_NAMES
    assert tuple(LiquidPreset) == LIQUID_PRESETS
    assert tuple(Fluid) == LIQUID_FLUIDS


ONE_OF = "is not one of"
AT_LEAST = "Input should be greater than or equal to"
AT_MOST = "Input should be less than or equal to"
ABOVE_0 = "must be a finite number above 0"

BAD_VALUES = [
    (["init", "g", "--dynamics", "lava"], "--dynamics", f"'lava' {ONE_OF} 'toy', 'liquid'"),
    (["init", "g", "--preset", "huge"], "--preset", f"'huge' {ONE_OF}"),
    (["init", "g", "--fluid", "syrup"], "--fluid", f"'syrup' {ONE_OF}"),
    (["init", "g", "--strategy", "greedy"], "--strategy", f"'greedy' {ONE_OF}"),
    (["init", "g", "--player-model", "softmax"], "--player-model", f"'softmax' {ONE_OF}"),
    (["init", "g", "--player-model", ""], "--player-model", f"'' {ONE_OF}"),
    (["init", "g", "--depth", "1"], "--depth", f"{AT_LEAST} 2"),
    (["init", "g", "--world", "-1"], "--world", f"{AT_LEAST} 0"),
    (["init", "g", "--world", str(2**31)], "--world", AT_MOST),
    (["grow", "g", "--strategy", "greedy"], "--strategy", ONE_OF),
    (["grow", "g", "--frames", "0"], "--frames", f"{AT_LEAST} 1"),
    (["grow", "g", "--expansions", "-5"], "--expansions", f"{AT_LEAST} 1"),
    (["grow", "g", "--expansions", "1" + "0" * 30], "--expansions", AT_MOST),
    (["play", "g", "--bot", "cheater"], "--bot", f"'cheater' {ONE_OF}"),
    (["play", "g", "--sessions", "0"], "--sessions", f"{AT_LEAST} 1"),
    (["play", "g", "--mean-steps", "1"], "--mean-steps", f"{AT_LEAST} 2"),
    (["play", "g", "--seed", "-1"], "--seed", f"{AT_LEAST} 0"),
    (["gc", "--older-than", "-1"], "--older-than", f"{AT_LEAST} 0"),
    (["analytics", "g", "--players", "humans"], "--players", f"'humans' {ONE_OF}"),
    (["analytics", "g", "--threshold", "-1"], "--threshold", ABOVE_0),
    (["analytics", "g", "--threshold", "0"], "--threshold", ABOVE_0),
    (["analytics", "g", "--threshold", "nan"], "--threshold", ABOVE_0),
    (["analytics", "g", "--threshold", "inf"], "--threshold", ABOVE_0),
    (["analytics", "g", "--threshold", "high"], "--threshold", "valid number"),
    (["analytics", "g", "--top", "0"], "--top", f"{AT_LEAST} 1"),
    (["analytics", "g", "--player-model", "softmax"], "--player-model", ONE_OF),
    (["experiment", "--dynamics", "fluid"], "--dynamics", ONE_OF),
    (["experiment", "--preset", "huge"], "--preset", ONE_OF),
    (["experiment", "--fluid", "syrup"], "--fluid", ONE_OF),
    (["experiment", "--strategies", "baseline,best"], "--strategies", "unknown strategy 'best'"),
    (["experiment", "--bots", "goal-directed,cheater"], "--bots", "unknown bot 'cheater'"),
    (["experiment", "--judges", "nobody"], "--judges", "unknown bot 'nobody'"),
    (["experiment", "--player-model", "mystery"], "--player-model", ONE_OF),
    (["experiment", "--sessions", "0"], "--sessions", f"{AT_LEAST} 1"),
    (["experiment", "--fixed-graph-sessions", "0"], "--fixed-graph-sessions", AT_LEAST),
    (["experiment", "--jobs", "0"], "--jobs", f"{AT_LEAST} 1"),
    (["experiment", "--through", "0"], "--through", f"{AT_LEAST} 1"),
    (["demo", "--dynamics", "lava"], "--dynamics", ONE_OF),
    (["demo", "--preset", "huge"], "--preset", ONE_OF),
    (["demo", "--fluid", "syrup"], "--fluid", ONE_OF),
    (["demo", "--sessions", "0"], "--sessions", f"{AT_LEAST} 1"),
    (["demo", "--seed", "-1"], "--seed", f"{AT_LEAST} 0"),
    (["validate", "--preset", "huge"], "--preset", "'huge' is not one of 'tiny', 'small', 'paper'"),
    (["validate", "--fluid", "bogus"], "--fluid", "'bogus' is not one of 'low', 'high'"),
    (["calibrate", "--preset", "huge"], "--preset", ONE_OF),
    (["calibrate", "--preset", "tiny", "--fluid", "bogus"], "--fluid", ONE_OF),
    (["calibrate", "--preset", "tiny", "--only", "w_e"], "--only", f"'w_e' {ONE_OF} 'threshold'"),
    (["serve", "--port", "0"], "--port", f"{AT_LEAST} 1"),
    (["serve", "--port", "65536"], "--port", f"{AT_MOST} 65535"),
    (["flower", "--port", "-1"], "--port", AT_LEAST),
    (["worker", "--concurrency", "0"], "--concurrency", f"{AT_LEAST} 1"),
    (["worker", "--loglevel", "LOUD"], "--loglevel", f"'LOUD' {ONE_OF}"),
    (["beat", "--loglevel", "info"], "--loglevel", f"'info' {ONE_OF}"),
    (["bench", "rank", "--edges", "0"], "--edges", AT_LEAST),
    (["bench", "rank", "--controls", "0"], "--controls", AT_LEAST),
    (["bench", "rank", "--seed", "-1"], "--seed", AT_LEAST),
    (["bench", "grow", "--epochs", "0"], "--epochs", AT_LEAST),
    (["bench", "grow", "--batch", "0"], "--batch", AT_LEAST),
    (["bench", "grow", "--dynamics", "lava"], "--dynamics", ONE_OF),
    (["bench", "grow", "--preset", "huge"], "--preset", ONE_OF),
    (["bench", "ingest", "--clients", "0"], "--clients", AT_LEAST),
    (["bench", "ingest", "--uploads", "0"], "--uploads", AT_LEAST),
    (["bench", "ingest", "--mean-steps", "1"], "--mean-steps", AT_LEAST),
    (["bench", "sph", "--preset", "huge"], "--preset", ONE_OF),
    (["bench", "sph", "--fluid", "bogus"], "--fluid", ONE_OF),
    (["bench", "sph", "--steps", "0"], "--steps", AT_LEAST),
    (["bench", "clip", "--preset", "huge"], "--preset", ONE_OF),
    (["bench", "clip", "--fluid", "bogus"], "--fluid", ONE_OF),
    (["bench", "clip", "--settle", "0"], "--settle", ABOVE_0),
    (["bench", "clip", "--frames", "0"], "--frames", AT_LEAST),
    (["bench", "store", "--edges", "0"], "--edges", AT_LEAST),
    (["bench", "store", "--distinct-bundles", "0"], "--distinct-bundles", AT_LEAST),
    (["bench", "writer", "--frames", "0"], "--frames", AT_LEAST),
    (["bench", "writer", "--batch", "0"], "--batch", AT_LEAST),
    (["bench", "writer", "--clip-seconds", "0"], "--clip-seconds", ABOVE_0),
    (["bench", "writer", "--clip-seconds", "nan"], "--clip-seconds", ABOVE_0),
    (["bench", "writer", "--liquid-seconds", "-1"], "--liquid-seconds", AT_LEAST),
]


@pytest.mark.parametrize(("args", "option", "says"), BAD_VALUES)
def test_each_bad_value_is_one_line_naming_its_option_and_nothing_is_written(
    tmp_path: Path, args: list[str], option: str, says: str
) -> None:
    done = srg(tmp_path, *args)
    one_line_error(done, f"Invalid value for '{option}': ")
    one_line_error(done, says)
    assert done.stdout == ""
    assert list(tmp_path.iterdir()) == []  # refused by the parser: not even a database


def _commands() -> dict[str, Any]:
    """Every command as click builds it, by its path (``bench sph``)."""
    found = {}

    def walk(group: Any, path: tuple[str, ...]) -> None:
        for name, command in group.commands.items():
            if hasattr(command, "commands"):
                walk(command, (*path, name))
            else:
                found[" ".join((*path, name))] = command

    walk(typer.main.get_command(app), ())
    return found


COMMANDS = _commands()


def _numeric_options() -> list[tuple[str, str]]:
    return [
        (name, param.opts[0])
        for name, command in COMMANDS.items()
        for param in command.params
        if getattr(param.type_descriptor, "annotation", None) in (int, float)
    ]


@pytest.mark.parametrize(("command", "option"), _numeric_options())
def test_every_numeric_option_has_a_range(command: str, option: str) -> None:
    """min/max, or a callback for what they cannot say (a float above 0 and finite)."""
    param = next(p for p in COMMANDS[command].params if option in p.opts)
    assert param.min is not None or param.max is not None or param.callback is not None


#: every choice option and the values its help lists
CHOICES: list[tuple[list[str], str, type[StrEnum]]] = [
    (["init"], "--dynamics", DynamicsName),
    (["init"], "--preset", LiquidPreset),
    (["init"], "--fluid", Fluid),
    (["init"], "--strategy", Strategy),
    (["init"], "--player-model", PlayerModelKind),
    (["grow"], "--strategy", Strategy),
    (["play"], "--bot", BotKind),
    (["analytics"], "--players", PlayerSelection),
    (["analytics"], "--player-model", PlayerModelKind),
    (["experiment"], "--strategies", Strategy),
    (["experiment"], "--bots", BotKind),
    (["experiment"], "--judges", BotKind),
    (["experiment"], "--player-model", PlayerModelKind),
    (["demo"], "--fluid", Fluid),
    (["validate"], "--preset", LiquidPreset),
    (["calibrate"], "--fluid", Fluid),
    (["worker"], "--loglevel", LogLevel),
    (["bench", "sph"], "--preset", LiquidPreset),
    (["bench", "grow"], "--dynamics", DynamicsName),
]


@pytest.mark.parametrize(("command", "option", "kind"), CHOICES)
def test_help_lists_every_choice(
    tmp_path: Path, command: list[str], option: str, kind: type[StrEnum]
) -> None:
    done = srg(tmp_path, *command, "--help", COLUMNS="400")  # one line an option
    assert done.returncode == 0, done.stderr
    line = next(line for line in done.stdout.splitlines() if line.lstrip("│ ").startswith(option))
    # one choice as "[a | b]"; a comma-separated list in its help "(comma-separated: a, b)"
    assert f"[{' | '.join(kind)}]" in line or f"comma-separated: {', '.join(kind)})" in line


@pytest.mark.parametrize(
    ("words", "offered"),
    [
        ("srg init g --dynamics ", ["toy", "liquid"]),
        ("srg play g --bot h", ["heuristic", "hesitant"]),
        ("srg analytics g --players b", ["bots"]),
        ("srg experiment --strategies sr-", ["sr-heuristic", "sr-crowd"]),
        (
            "srg experiment --bots goal-directed,h",
            ["goal-directed,heuristic", "goal-directed,hesitant"],
        ),
        ("srg experiment --judges ", list(BotKind)),
    ],
)
def test_the_shell_completes_choices_and_each_element_of_a_list(
    tmp_path: Path, words: str, offered: list[str]
) -> None:
    """What bash's completion script asks srg (``srg --show-completion bash``)."""
    cword = len(words.split()) - (0 if words.endswith(" ") else 1)
    done = srg(tmp_path, _SRG_COMPLETE="complete_bash", COMP_WORDS=words, COMP_CWORD=str(cword))
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == offered


def test_completion_is_installable(tmp_path: Path) -> None:
    done = srg(tmp_path, "--show-completion", "bash")
    assert done.returncode == 0, done.stderr
    assert "_SRG_COMPLETE=complete_bash" in done.stdout
    assert "--install-completion" in srg(tmp_path, "--help", COLUMNS="200").stdout


def test_no_help_text_shows_markup_of_restructured_text() -> None:
    for name, command in COMMANDS.items():
        for text in (command.help or "", *(getattr(p, "help", None) or "" for p in command.params)):
            assert "``" not in text, name
