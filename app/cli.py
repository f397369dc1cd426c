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
from typing import Any

import typer
from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

from app.cli_api import register_api_commands
from app.cli_bench import bench_app
from app.cli_demo import demo
from app.cli_graph import register_graph_commands
from app.cli_liquid import register_liquid_commands
from app.cli_runtime import register_runtime_commands

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
    """A progress bar on stderr; yields the ``advance(n)`` callback services take."""
    columns = (TextColumn(label), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn())
    with Progress(*columns, console=Console(stderr=True), transient=False) as bar:
        task = bar.add_task(label, total=total)
        yield lambda n: bar.advance(task, n)


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
    dynamics: str = typer.Option("toy", help="dynamics to grow"),
    quick: bool = typer.Option(False, "--quick", help="3 small checkpoints: minutes, not hours"),
    json_path: str | None = typer.Option(
        None, "--json", help="write the result here ('-': stdout)"
    ),
    out: Path = typer.Option(Path("var/experiment"), help="directory for plots and report.md"),
    seeds: str = typer.Option("0,1,2", help="comma-separated seeds"),
    checkpoints: str | None = typer.Option(None, help="comma-separated frame counts"),
) -> None:
    """Grow one graph per strategy through checkpoints and compare what bots see (paper 7)."""
    from app.reports.experiment import write_report
    from app.services.experiment import ExperimentPlan, parse_checkpoints, run_experiment

    base = ExperimentPlan.quick(dynamics) if quick else ExperimentPlan(dynamics=dynamics)
    try:
        seed_values = tuple(int(s) for s in seeds.split(","))
    except ValueError:
        raise UserError(f"seeds must be comma-separated integers, got {seeds!r}") from None
    plan = ExperimentPlan(
        dynamics=dynamics,
        strategies=base.strategies,
        seeds=seed_values,
        checkpoints=parse_checkpoints(checkpoints) if checkpoints else base.checkpoints,
        sessions=base.sessions,
        mean_steps=base.mean_steps,
        batch_size=base.batch_size,
    )
    with progress_bar(plan.total_frames, "frames grown") as advance:
        result = run_experiment(plan, advance)
    report = write_report(result, out)
    emit(result, json_path)
    summary = result["summary"]
    typer.echo(json.dumps(summary, indent=2), err=json_path == "-")
    typer.echo(f"report: {report}", err=True)


def main() -> None:
    import httpx
    from sqlalchemy.exc import OperationalError

    from app.api.client import ServerError

    try:
        app()
    except (UserError, ValueError, LookupError, ServerError) as exc:
        message = exc.args[0] if exc.args else exc
        typer.echo(f"srg: error: {message}", err=True)
        sys.exit(2)
    except OperationalError as exc:
        typer.echo(f"srg: error: cannot use the database: {exc.orig}".splitlines()[0], err=True)
        sys.exit(2)
    except httpx.TransportError as exc:
        typer.echo(f"srg: error: cannot reach the server: {exc}".splitlines()[0], err=True)
        sys.exit(2)
