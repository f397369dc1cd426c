"""``srg demo``: the main job of the README, on whatever database Settings names."""

from __future__ import annotations

import os
from functools import partial
from pathlib import Path

import typer

from app.cli.output import progress_bar, write_result
from app.services.dynamics import QUICK_LIQUID_PRESET


def demo(
    name: str = typer.Option("demo", help="the demo's name; run again to go on from where it was"),
    dynamics: str = typer.Option("liquid", help="liquid or toy"),
    preset: str = typer.Option(QUICK_LIQUID_PRESET, help="liquid preset: tiny, small or paper"),
    fluid: str | None = typer.Option(None, help="liquid fluid: low (default) or high"),
    checkpoints: str = typer.Option(
        "300,600,1000,1500", help="graph sizes (frames) where the bots play both graphs"
    ),
    sessions: int = typer.Option(30, help="bot sessions per checkpoint"),
    seed: int = typer.Option(0),
    out: Path | None = typer.Option(None, help="directory for report.md (default var/demo)"),
    result_path: Path | None = typer.Option(
        None, "--result", help="also write the JSON result to this file"
    ),
) -> None:
    """BASELINE and SR-CROWD graphs grown side by side; watch the error fall as bots play.

    Ends with the SR-CROWD graph published with its animations, ready to play.
    """
    from rich.console import Console
    from rich.table import Table

    from app.config import get_settings
    from app.core.player_models import parse_player_model
    from app.db.engines import require_intact
    from app.liquid.devices import LiquidDevices
    from app.services.demo import (
        demo_plan,
        demo_rows,
        publish_playable,
        run_demo,
        unrendered_edges,
        write_demo_report,
    )
    from app.services.dynamics import make_dynamics
    from app.services.experiment.plan import parse_checkpoints
    from app.services.experiment.runs import grow_in_process
    from app.services.loading import artifact_store

    settings = get_settings()
    require_intact(settings)
    plan = demo_plan(
        dynamics,
        preset,
        fluid,
        parse_checkpoints(checkpoints),
        sessions=sessions,
        seed=seed,
        player_model=parse_player_model(settings.growth.player_model),
    )
    devices = LiquidDevices.from_settings(settings)
    make_dynamics(plan.dynamics, plan.preset, plan.fluid, devices=devices)  # preset, calibration
    jobs = min(os.cpu_count() or 1, len(plan.runs))
    total = len(plan.runs) * plan.checkpoints[-1]
    with progress_bar(total, "baseline and sr-crowd: frames grown") as advance:
        result = run_demo(
            settings, name, plan, partial(grow_in_process, settings), jobs=jobs, progress=advance
        )
    with progress_bar(unrendered_edges(settings, name, plan), "animations rendered") as rendered:
        graph, published = publish_playable(settings, name, plan, rendered)
    table = Table(title=f"{name}: what goal-directed bots saw at each graph size")
    for column in (
        "frames",
        "baseline error",
        "sr-crowd error",
        "sr-crowd / baseline",
        "baseline high-error",
        "sr-crowd high-error",
    ):
        table.add_column(column, justify="right")
    for row in demo_rows(result):
        table.add_row(
            str(row.frames),
            f"{row.baseline_error:.4f}",
            f"{row.sr_crowd_error:.4f}",
            f"{row.ratio:.2f}",
            f"{row.baseline_high_error:.3f}",
            f"{row.sr_crowd_high_error:.3f}",
        )
    Console().print(table)
    report = write_demo_report(
        settings,
        result,
        graph,
        out or settings.var_dir / "demo",
        artifact_store(settings).get_arrays,
    )
    if result_path is not None:
        write_result(result_path, result)
    typer.echo(f"report: {report}")
    typer.echo(
        f"play it: srg serve, then open http://127.0.0.1:8000/?graph={graph} "
        f"(publication {published.number}, {published.size_frames} frames)"
    )
