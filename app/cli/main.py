"""The ``srg`` command: the root app and where each command lives.

Every command is a thin shell (parse, call a service, print) in the module of its group;
:mod:`app.cli.output` holds what they all print and how an error ends a command.
"""

from __future__ import annotations

import sys
from collections.abc import Callable
from typing import Any

import typer

from app.cli import (
    analytics,
    bench,
    db,
    demo,
    experiment,
    graph,
    liquid,
    results,
    runtime,
    serve,
)
from app.cli.output import user_errors_in_one_line

app = typer.Typer(
    help="Self-refining games: grow, publish and play precomputed state graphs.",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    add_completion=True,
)


def _print_version(asked: bool) -> None:
    """``srg --version``: the installed distribution's version, as pip shows it."""
    from importlib.metadata import version

    if asked:
        typer.echo(f"srg {version('srg')}")
        raise typer.Exit()


@app.callback()
def root(
    _version: bool = typer.Option(
        False, "--version", callback=_print_version, is_eager=True, help="print the version"
    ),
) -> None:
    """Self-refining games: grow, publish and play precomputed state graphs."""


app.add_typer(db.app, name="db")
app.add_typer(bench.app, name="bench")
app.add_typer(results.app, name="results")
COMMANDS: dict[str, Callable[..., None]] = {
    "init": graph.init,
    "grow": graph.grow,
    "publish": graph.publish,
    "play": graph.play,
    "status": graph.status,
    "gc": graph.gc,
    "fsck": graph.fsck,
    "experiment": experiment.experiment,
    "demo": demo.demo,
    "serve": serve.serve,
    "analytics": analytics.analytics,
    "validate": liquid.validate,
    "calibrate": liquid.calibrate,
    "worker": runtime.worker,
    "beat": runtime.beat,
    "flower": runtime.flower,
    "set-growing": runtime.set_growing,
    "grow-epoch": runtime.grow_epoch,
}
for name, command in COMMANDS.items():
    app.command(name)(command)


def click_command() -> Any:
    """``srg`` as the console script runs it: Typer's click command, its help made for a
    terminal of any width (:func:`_tidy_help`)."""
    command = typer.main.get_command(app)
    _tidy_help(command)
    return command


def _tidy_help(command: Any) -> None:
    """No metavar on a flag (click 8.5 writes ``<bool>``, but a flag takes no value);
    spaces in a choice list, so that a narrow help table wraps it between choices, not
    mid-word; each summary on one line, so that it wraps at the table's width instead of
    at the docstring's line breaks, mid-sentence."""
    for param in command.params:
        if getattr(param, "is_flag", False):
            param.metavar = ""
        elif choices := getattr(param.type_descriptor, "choices", None):
            param.metavar = "[" + " | ".join(str(getattr(c, "value", c)) for c in choices) + "]"
    command.get_help_option = _without_metavar(command.get_help_option)
    if command.help and not command.short_help:
        command.short_help = " ".join(command.help.split("\n\n")[0].split())
    for sub in getattr(command, "commands", {}).values():
        _tidy_help(sub)


def _without_metavar(make_option: Callable[[Any], Any]) -> Callable[[Any], Any]:
    """``--help``, made per context, without the metavar of a value it does not take."""

    def made(ctx: Any) -> Any:
        option = make_option(ctx)
        if option is not None:
            option.metavar = ""
        return option

    return made


def main() -> None:
    """The console script: run a command; a user's error, usage included, ends it in one
    line, exit 2 (click's own handling, ``standalone_mode``, would print usage boxes)."""
    command = click_command()
    with user_errors_in_one_line():
        code = command.main(prog_name="srg", standalone_mode=False)
    sys.exit(code if isinstance(code, int) else 0)
