"""``srg demo``: the main job of the README, on whatever database Settings names."""

from __future__ import annotations

import json
from pathlib import Path

import typer


def demo(
    name: str = typer.Option("demo", help="graph to build, or to go on refining if it exists"),
    dynamics: str = typer.Option("liquid", help="liquid or toy"),
    preset: str = typer.Option("small", help="liquid preset: tiny, small or paper"),
    rounds: int = typer.Option(3, help="self-refining rounds (publish, play, learn, grow)"),
    budget: int = typer.Option(3, help="expansions grown per round"),
    sessions: int = typer.Option(20, help="bot sessions per round"),
    seed: int = typer.Option(0),
    out: Path = typer.Option(Path("var/demo"), help="directory for report.md and its plots"),
    json_path: str | None = typer.Option(None, "--json", help="also write the rounds as JSON"),
) -> None:
    """Build a graph, then refine it in rounds from bots' play; print and report the error."""
    from rich.console import Console
    from rich.progress import Progress, SpinnerColumn, TextColumn, TimeElapsedColumn
    from rich.table import Table

    from app.config import get_settings
    from app.db import session_factory
    from app.services.demo import DemoPlan, rounds_as_dicts, run_demo, write_demo_report

    plan = DemoPlan(
        name=name,
        dynamics=dynamics,
        preset=preset if dynamics == "liquid" else None,
        rounds=rounds,
        budget=budget,
        sessions=sessions,
        seed=seed,
    )
    plan.check()
    settings = get_settings()
    sessions_ = session_factory()
    columns = (SpinnerColumn(), TextColumn("{task.description}"), TextColumn("{task.completed}"))
    with Progress(*columns, TimeElapsedColumn(), console=Console(stderr=True)) as bar:
        task = bar.add_task("starting", total=None)

        def stage(what: str, number: int) -> None:
            label = f"round {number}/{plan.rounds + 1}: {what}" if number else what
            bar.update(task, description=label, completed=0)

        def advance(n: int) -> None:
            bar.advance(task, n)

        rounds_done = run_demo(sessions_, settings, plan, stage, advance)
    table = Table(title=f"{plan.name}: observed error per round (goal-directed bots)")
    for column in ("round", "frames", "mean error", "high-error", "score/step"):
        table.add_column(column, justify="right")
    for r in rounds_done:
        table.add_row(
            str(r.round),
            str(r.size_frames),
            f"{r.observed_mean_error:.4f}",
            f"{r.high_error_fraction:.3f}",
            f"{r.mean_score_per_step:.4g}",
        )
    Console().print(table)
    with sessions_() as session:
        report = write_demo_report(session, settings, plan, rounds_done, out)
    if json_path:
        Path(json_path).write_text(json.dumps(rounds_as_dicts(rounds_done), indent=2) + "\n")
    typer.echo(f"report: {report}")
    typer.echo("play it: srg serve, then open http://127.0.0.1:8000/ in a browser")
