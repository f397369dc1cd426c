"""``srg db``, ``init``, ``grow``, ``publish``, ``play``, ``status``, ``gc``: persisted graphs.

Each command runs one service call in one transaction: it commits when the service
returns and rolls back (writing nothing) when it raises.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import asdict, is_dataclass
from typing import Any

import typer

from app.db import transaction

db_app = typer.Typer(help="The database schema (Alembic migrations).", no_args_is_help=True)


def emit(result: Any, as_json: bool) -> None:
    data = asdict(result) if is_dataclass(result) and not isinstance(result, type) else result
    if as_json:
        typer.echo(json.dumps(data, indent=2, default=str))
    else:
        typer.echo(" ".join(f"{k}={v}" for k, v in data.items()))


class RevisionError(ValueError):
    """Alembic refused the revision asked for (unknown, or not reachable that way)."""


def migrate(direction: str, revision: str) -> None:
    """``alembic upgrade|downgrade revision`` on the configured database, errors in one line."""
    from alembic.util import CommandError

    from alembic import command
    from app.config import get_settings
    from app.db import alembic_config, parse_database_url

    parse_database_url(get_settings().resolved_database_url)  # one line, before Alembic
    try:
        getattr(command, direction)(alembic_config(), revision)
    except CommandError as exc:
        raise RevisionError(f"cannot {direction} to {revision!r}: {exc}".splitlines()[0]) from None


@db_app.command("upgrade")
def db_upgrade(revision: str = typer.Argument("head", help="target revision")) -> None:
    """Migrate the configured database up to ``revision`` (default: the latest)."""
    from app.config import get_settings

    migrate("upgrade", revision)
    url = parse_url_for_display(get_settings().resolved_database_url)
    typer.echo(f"database at {revision}: {url}", err=True)


@db_app.command("downgrade")
def db_downgrade(
    revision: str = typer.Argument(..., help="target revision ('base': empty)"),
) -> None:
    """Migrate the configured database down to ``revision``."""
    migrate("downgrade", revision)


def parse_url_for_display(url: str) -> str:
    from app.db import parse_database_url

    return parse_database_url(url).render_as_string(hide_password=True)


def init(
    name: str = typer.Argument(..., help="name of the new graph"),
    dynamics: str = typer.Option("toy", help="toy or liquid"),
    preset: str | None = typer.Option(None, help="liquid preset: tiny, small or paper"),
    fluid: str | None = typer.Option(None, help="liquid fluid: low (default) or high"),
    strategy: str = typer.Option("sr-crowd", help="max-error, baseline, sr-heuristic, sr-crowd"),
    depth: int = typer.Option(2, help="depth of the initial simulation tree (>= 2)"),
    player_model: str | None = typer.Option(
        None, help="crowd model sr-crowd learns: eq2 or logit (default SRG_PLAYER_MODEL, eq2)"
    ),
    json_output: bool = typer.Option(False, "--json", help="print JSON"),
) -> None:
    """Create a graph: the initial tree of the dynamics, its leaves blended back."""
    from app.config import get_settings
    from app.core.player_models import parse_player_model
    from app.services.dynamics import check_fluid
    from app.services.graphs import init_graph

    if dynamics == "liquid" and preset is None:
        preset = "small"
    if fluid is not None:
        check_fluid(fluid)
    if player_model is not None:  # '' too: it names no model, not the default
        parse_player_model(player_model)
    with transaction() as session:
        summary = init_graph(
            session,
            get_settings(),
            name=name,
            dynamics=dynamics,
            preset=preset,
            fluid=fluid,
            strategy=strategy,
            depth=depth,
            player_model=player_model,
        )
    emit(summary, json_output)


def grow(
    name: str = typer.Argument(..., help="graph name or id"),
    strategy: str | None = typer.Option(None, help="override the graph's strategy"),
    frames: int | None = typer.Option(None, help="budget in simulated frames"),
    expansions: int | None = typer.Option(None, help="budget in expansions"),
    json_output: bool = typer.Option(False, "--json", help="print JSON"),
) -> None:
    """Grow a graph in-process (eagerly) by a budget of frames or expansions."""
    from app.cli.main import progress_bar
    from app.config import get_settings
    from app.core.strategies import parse_strategy
    from app.services.graphs import grow_graph

    if frames is not None and expansions is not None:
        raise ValueError("give --frames or --expansions, not both")
    for option, budget in (("--frames", frames), ("--expansions", expansions)):
        if budget is not None and budget <= 0:  # before the bar: it never shows 0/-5
            raise ValueError(f"{option} must be positive, got {budget}")
    if strategy is not None:
        parse_strategy(strategy)
    settings = get_settings()
    total = frames if frames is not None else expansions or settings.batch_size
    label = "frames" if frames is not None else "expansions"
    with progress_bar(total, label) as advance:
        result = grow_graph(
            transaction,
            settings,
            name=name,
            strategy=strategy,
            frames=frames,
            expansions=expansions,
            progress=advance,
        )
    emit(result, json_output)


def publish(
    name: str = typer.Argument(..., help="graph name or id"),
    json_output: bool = typer.Option(False, "--json", help="print JSON"),
) -> None:
    """Relink every blend, render what is missing, freeze a publication for players."""
    from app.cli.main import progress_bar
    from app.config import get_settings
    from app.services.graphs import count_missing_animations, publish_graph
    from app.store.graphs import get_graph_row

    with transaction() as session:
        missing = count_missing_animations(session, get_graph_row(session, name).id)
        with progress_bar(missing, "animations") as advance:
            result = publish_graph(session, get_settings(), name=name, progress=advance)
    emit(result, json_output)


def play(
    name: str = typer.Argument(..., help="graph name or id"),
    bot: str = typer.Option(
        "goal-directed", help="goal-directed, heuristic, random, hesitant or avoider"
    ),
    sessions: int = typer.Option(20, help="sessions to play"),
    mean_steps: int = typer.Option(90, help="mean session length in steps"),
    seed: int = typer.Option(0),
    url: str | None = typer.Option(None, help="play over HTTP against `srg serve` at this URL"),
    json_output: bool = typer.Option(False, "--json", help="print JSON"),
) -> None:
    """Bots play the latest publication; their traces are stored like players' uploads."""
    from app.config import get_settings

    if url is not None:
        from app.api.client import play_over_http

        emit(
            play_over_http(url, name, bot, sessions=sessions, mean_steps=mean_steps, seed=seed),
            json_output,
        )
        return
    from app.services.graphs import play_graph

    with transaction() as session:
        result = play_graph(
            session,
            get_settings(),
            name=name,
            bot=bot,
            sessions=sessions,
            mean_steps=mean_steps,
            seed=seed,
        )
    emit(result, json_output)


def status(
    name: str | None = typer.Argument(None, help="graph name or id (default: all graphs)"),
    json_output: bool = typer.Option(False, "--json", help="print JSON"),
) -> None:
    """Sizes, publications, epochs and play (traces, players, last upload) of one graph or all."""
    from app.services.graphs import graph_summary, list_graphs

    with transaction() as session:
        rows = [graph_summary(session, name)] if name is not None else list_graphs(session)
    if json_output:
        typer.echo(json.dumps(rows if name is None else rows[0], indent=2))
        return
    if not rows:
        typer.echo("no graphs yet: srg init NAME")
    for row in rows:
        play = row.pop("play")
        assert isinstance(play, dict)
        emit({**row, **play}, False)


def gc(
    older_than: float | None = typer.Option(
        None,
        "--older-than",
        help="grace period in seconds: newer files and rows are kept "
        "(default SRG_ARTIFACT_GC_GRACE, 3600)",
    ),
    dry_run: bool = typer.Option(False, "--dry-run", help="count what would go; delete nothing"),
    json_output: bool = typer.Option(False, "--json", help="print JSON"),
) -> None:
    """Delete artifact files and rows that nothing references (what an interrupted grow left).

    Only files last modified and rows created more than ``--older-than`` seconds ago are
    collected, so that what a running step (``srg grow``, a worker) wrote and is about to
    reference survives: keep it above the longest step. Safe to run while graphs grow;
    ``srg beat`` also runs it every SRG_ARTIFACT_GC_INTERVAL seconds.
    """
    from app.cli.main import progress_bar
    from app.config import get_settings
    from app.services.artifact_gc import collect_artifacts
    from app.services.graphs import artifact_store
    from app.store.artifact_gc import count_fanout_directories

    settings = get_settings()
    directories = count_fanout_directories(artifact_store(settings))
    with progress_bar(directories, "artifact directories") as advance:
        result = collect_artifacts(
            settings, older_than=older_than, dry_run=dry_run, progress=advance
        )
    emit(result, json_output)


def register_graph_commands(app: typer.Typer) -> None:
    """Attach the graph commands to the main app."""
    app.add_typer(db_app, name="db")
    commands: list[Callable[..., None]] = [init, grow, publish, play, status, gc]
    for command in commands:
        app.command(command.__name__)(command)
