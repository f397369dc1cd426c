"""The ``srg`` command. Thin: parse, call a service, print (``--json`` where scripts read it).

Bad input ends with one line on stderr (``srg: error: ...``) and exit status 2; the
services raise before they write anything.
"""

from __future__ import annotations

import json
import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Any

import typer
from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

from app.cli.api import register_api_commands
from app.cli.bench import bench_app
from app.cli.demo import demo
from app.cli.graph import register_graph_commands
from app.cli.liquid import register_liquid_commands
from app.cli.runtime import register_runtime_commands

if TYPE_CHECKING:
    from sqlalchemy.exc import DBAPIError

    from app.services.experiment import ExperimentPlan

app = typer.Typer(
    help="Self-refining games: grow, publish and play precomputed state graphs.",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    add_completion=False,
)
app.add_typer(bench_app, name="bench")
app.command()(demo)
register_graph_commands(app)
register_api_commands(app, bench_app)
register_liquid_commands(app, bench_app)
register_runtime_commands(app, bench_app)


class UserError(Exception):
    """Bad input the user can fix; printed as one line."""


@contextmanager
def progress_bar(total: int, label: str) -> Iterator[Callable[[int], None]]:
    """A progress bar on stderr; yields the ``advance(n)`` callback services take.

    What it shows stays within 0 and ``total`` (itself at least 0): a service may count
    past its estimate (a frame budget is grown in whole expansions), never below 0.
    """
    total = max(total, 0)
    done = 0
    columns = (TextColumn(label), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn())
    with Progress(*columns, console=Console(stderr=True), transient=False) as bar:
        task = bar.add_task(label, total=total)

        def advance(n: int) -> None:
            nonlocal done
            done = min(max(done + n, 0), total)
            bar.update(task, completed=done)

        yield advance


def emit(data: dict[str, Any], json_path: str | None) -> None:
    """Write ``data`` as JSON to a file, or to stdout with ``-``."""
    text = json.dumps(data, indent=2, default=str)
    if json_path == "-":
        typer.echo(text)
    elif json_path:
        Path(json_path).parent.mkdir(parents=True, exist_ok=True)
        Path(json_path).write_text(text + "\n")


@app.command()
def experiment(
    dynamics: str | None = typer.Option(None, help="dynamics to grow: toy (default) or liquid"),
    preset: str | None = typer.Option(None, help="liquid preset: tiny, small or paper"),
    fluid: str | None = typer.Option(None, help="liquid fluid: low (default) or high"),
    quick: bool = typer.Option(False, "--quick", help="3 small checkpoints: minutes, not hours"),
    strategies: str | None = typer.Option(
        None, help="comma-separated strategies (default: all four)"
    ),
    seeds: str | None = typer.Option(None, help="comma-separated seeds (default 0,1,2)"),
    checkpoints: str | None = typer.Option(None, help="comma-separated frame counts"),
    sessions: int | None = typer.Option(None, help="bot sessions per checkpoint (default 30)"),
    player_model: str | None = typer.Option(
        None, help="crowd model sr-crowd learns: eq2 (default, the paper's) or logit"
    ),
    bot: str | None = typer.Option(
        None,
        help="bots that play every checkpoint: goal-directed (default), heuristic, random, "
        "hesitant or avoider",
    ),
    fixed_graph_sessions: int | None = typer.Option(
        None, help="bot sessions per half of the fixed-graph prediction setting (default 100)"
    ),
    name: str | None = typer.Option(
        None, help="experiment name (default: from dynamics, preset and fluid)"
    ),
    resume: bool = typer.Option(
        False, "--resume", help="finish the stored experiment NAME from its last checkpoint"
    ),
    jobs: int | None = typer.Option(
        None, help="runs at once (default: the cores in-process; every run on workers)"
    ),
    json_path: str | None = typer.Option(
        None, "--json", help="write the result here ('-': stdout)"
    ),
    out: Path | None = typer.Option(
        None, help="directory for plots and report.md (default var/experiment/NAME)"
    ),
) -> None:
    """Grow one graph per strategy and seed through checkpoints; compare what bots see.

    The paper's section 7 (docs/experiment.md). Graphs, traces and every checkpoint's
    figures are stored, so an interrupted experiment continues with ``--resume``. With
    SRG_BROKER_URL set, growth runs on the Celery workers.
    """
    import os

    from app.config import get_settings
    from app.core.strategies import Strategy
    from app.reports.experiment import write_report
    from app.services.experiment import (
        create_experiment,
        grow_in_process,
        run_experiment,
        stored_plan,
    )
    from app.services.graphs import artifact_store
    from app.services.ingredients import eq2_ingredients

    if jobs is not None and jobs < 1:
        raise UserError(f"--jobs must be positive, got {jobs}")
    options = (dynamics, preset, fluid, strategies, seeds, checkpoints, sessions)
    model_options = (player_model, bot, fixed_graph_sessions)
    name = name or "-".join(x for x in ("experiment", dynamics or "toy", preset, fluid) if x)
    if resume:
        if quick or any(option is not None for option in (*options, *model_options)):
            raise UserError("--resume runs the stored plan: give only --name, --jobs, --json")
        plan = stored_plan(name)
    else:
        plan = _experiment_plan(dynamics or "toy", quick, *options[1:], *model_options)
        plan = create_experiment(name, plan)
    settings = get_settings()
    if settings.eager:
        grower = grow_in_process
        jobs = jobs or min(os.cpu_count() or 1, len(plan.runs))
    else:
        from app.tasks.growth import grow_on_workers

        grower = grow_on_workers
        jobs = jobs or len(plan.runs)
    total = len(plan.runs) * plan.checkpoints[-1]
    with progress_bar(total, f"{name}: frames grown") as advance:
        result = run_experiment(name, grower, jobs=jobs, progress=advance)
    crowd = Strategy.SR_CROWD in plan.strategies and result["complete"]
    report = write_report(
        result,
        out or settings.var_dir / "experiment" / name,
        artifact_store(settings).get_arrays,
        ingredients=eq2_ingredients(name) if crowd else None,
    )
    emit(result, json_path)
    typer.echo(json.dumps(result["summary"], indent=2), err=json_path == "-")
    typer.echo(f"report: {report}", err=True)


def _experiment_plan(
    dynamics: str,
    quick: bool,
    preset: str | None,
    fluid: str | None,
    strategies: str | None,
    seeds: str | None,
    checkpoints: str | None,
    sessions: int | None,
    player_model: str | None,
    bot: str | None,
    fixed_graph_sessions: int | None,
) -> ExperimentPlan:
    from app.core.bots import parse_bot
    from app.core.player_models import parse_player_model
    from app.core.strategies import parse_strategy
    from app.services.experiment import ExperimentPlan, parse_checkpoints

    changes: dict[str, Any] = {"preset": preset, "fluid": fluid}
    if strategies is not None:
        changes["strategies"] = tuple(parse_strategy(s.strip()) for s in strategies.split(","))
    if seeds is not None:
        try:
            changes["seeds"] = tuple(int(s) for s in seeds.split(","))
        except ValueError:
            raise UserError(f"seeds must be comma-separated integers, got {seeds!r}") from None
    if checkpoints is not None:
        changes["checkpoints"] = parse_checkpoints(checkpoints)
    if sessions is not None:
        changes["sessions"] = sessions
    if player_model is not None:
        changes["player_model"] = parse_player_model(player_model)
    if bot is not None:
        changes["bot"] = parse_bot(bot)
    if fixed_graph_sessions is not None:
        if fixed_graph_sessions < 1:
            raise UserError(f"--fixed-graph-sessions must be positive, got {fixed_graph_sessions}")
        changes["fixed_graph_sessions"] = fixed_graph_sessions
    if quick:
        return ExperimentPlan.quick(dynamics, **changes)
    return ExperimentPlan(dynamics=dynamics, **changes)


def main() -> None:
    import httpx
    from sqlalchemy.exc import DBAPIError, OperationalError

    from app.api.client import ServerError

    try:
        try:
            app()
        except DBAPIError as exc:
            mapped = database_user_error(exc)
            if mapped is exc:
                raise
            raise mapped from exc
    except (UserError, ValueError, LookupError, ServerError) as exc:
        typer.echo(f"srg: error: {error_line(exc)}".splitlines()[0], err=True)
        sys.exit(2)
    except OperationalError as exc:
        typer.echo(f"srg: error: cannot use the database: {exc.orig}".splitlines()[0], err=True)
        sys.exit(2)
    except httpx.TransportError as exc:
        typer.echo(f"srg: error: cannot reach the server: {exc}".splitlines()[0], err=True)
        sys.exit(2)


def error_line(exc: Exception) -> str:
    """The message of a user error; a setting pydantic refused is named by its variable."""
    from pydantic import ValidationError

    if isinstance(exc, ValidationError):
        return "; ".join(
            f"SRG_{'_'.join(str(part) for part in error['loc']).upper()}: {error['msg']}"
            for error in exc.errors()
        )
    return str(exc.args[0] if exc.args else exc)


def database_user_error(exc: DBAPIError) -> Exception:
    """What a database error means to the user, when it is theirs to fix; else ``exc``.

    A database without srg's tables (never upgraded: "no such table", undefined_table)
    and a file that is no database are; a constraint violated or a wrong statement is a
    bug and keeps its traceback.
    """
    from app.config import get_settings
    from app.db import (
        UPGRADE_HINT,
        DatabaseNotReady,
        parse_database_url,
        raise_if_unusable,
        schema_missing,
    )

    url = parse_database_url(get_settings().resolved_database_url)
    shown = url.render_as_string(hide_password=True)
    if schema_missing(exc):
        return DatabaseNotReady(
            f"the database {shown} has no srg schema (or an older one): {UPGRADE_HINT}"
        )
    try:
        raise_if_unusable(exc, url.database if url.get_backend_name() == "sqlite" else shown)
    except ValueError as unusable:
        return unusable
    return exc
