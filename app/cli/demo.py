"""``srg demo``: the main job of the README, on whatever database Settings names."""

from __future__ import annotations

import os
from functools import partial
from pathlib import Path
from typing import Any

import typer

from app.cli.choices import DynamicsName, Fluid, LiquidPreset, value_of
from app.cli.output import JSON_HELP, emit, progress_bar, write_result
from app.core.liquid.defaults import QUICK_LIQUID_PRESET


def demo(
    name: str = typer.Option("demo", help="the demo's name; run again to go on from where it was"),
    dynamics: DynamicsName = typer.Option(DynamicsName.LIQUID, help="the dynamics grown"),
    preset: LiquidPreset = typer.Option(LiquidPreset(QUICK_LIQUID_PRESET), help="liquid preset"),
    fluid: Fluid | None = typer.Option(None, help="liquid fluid (default low)"),
    checkpoints: str = typer.Option(
        "300,600,1000,1500", help="graph sizes (frames) where the bots play the graphs"
    ),
    sessions: int = typer.Option(30, min=1, help="bot sessions per checkpoint"),
    seed: int = typer.Option(0, min=0, help="seed of the world and of the bots"),
    out: Path | None = typer.Option(None, help="directory for report.md (default var/demo)"),
    result_path: Path | None = typer.Option(
        None, "--result", help="also write the JSON result to this file"
    ),
    json_output: bool = typer.Option(False, "--json", help=JSON_HELP),
) -> None:
    """BASELINE, SR-HEURISTIC and SR-CROWD graphs grown side by side from one initial
    tree; watch the error fall as bots play, and what the traces add (sr-crowd /
    sr-heuristic) beside what STATERANK and traces add together (sr-crowd / baseline).

    Ends with the SR-CROWD graph published with its animations, ready to play.
    """
    from app.config import get_settings
    from app.core.players.kinds import parse_player_model
    from app.db.engines import require_intact
    from app.liquid.devices import LiquidDevices
    from app.reports.provenance import with_provenance
    from app.services.demo import (
        DEMO_STRATEGIES,
        demo_plan,
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
        dynamics.value,
        preset.value,
        value_of(fluid),
        parse_checkpoints(checkpoints),
        sessions=sessions,
        seed=seed,
        player_model=parse_player_model(settings.growth.player_model),
    )
    devices = LiquidDevices.from_settings(settings)
    make_dynamics(plan.dynamics, plan.preset, plan.fluid, devices=devices)  # preset, calibration
    jobs = min(os.cpu_count() or 1, len(plan.runs))
    total = len(plan.runs) * plan.checkpoints[-1]
    strategies = [s.value for s in DEMO_STRATEGIES]
    with progress_bar(total, f"{', '.join(strategies)}: frames grown") as advance:
        result = run_demo(
            settings, name, plan, partial(grow_in_process, settings), jobs=jobs, progress=advance
        )
    result = with_provenance(result, settings)
    with progress_bar(unrendered_edges(settings, name, plan), "animations rendered") as rendered:
        graph, published = publish_playable(settings, name, plan, rendered)
    if result_path is not None:
        write_result(result_path, result)
    if json_output:
        emit(result, as_json=True)
    else:
        _print_tables(name, result, strategies)
    report = write_demo_report(
        settings,
        result,
        graph,
        out or settings.var_dir / "demo",
        artifact_store(settings).get_arrays,
    )
    typer.echo(f"report: {report}", err=json_output)
    typer.echo(
        f"play it: srg serve, then open http://127.0.0.1:8000/?graph={graph} "
        f"(publication {published.number}, {published.size_frames} frames)",
        err=json_output,
    )


def _print_tables(name: str, result: dict[str, Any], strategies: list[str]) -> None:
    """The demo's figures: the error bots met and the share of steps visibly wrong."""
    from rich.console import Console
    from rich.table import Table

    from app.services.demo import demo_rows

    rows = demo_rows(result)
    errors = Table(title=f"{name}: mean error per step that goal-directed bots met")
    shares = Table(title=f"{name}: share of steps visibly wrong (error above the threshold)")
    for column in ("frames", *strategies, "sr-crowd / sr-heuristic", "sr-crowd / baseline"):
        errors.add_column(column, justify="right")
    for column in ("frames", *strategies):
        shares.add_column(column, justify="right")
    for row in rows:
        ratios = (row.crowd_vs_heuristic, row.crowd_vs_baseline)
        errors.add_row(
            str(row.frames),
            *(f"{row.error[s]:.4f}" for s in strategies),
            *("n/a" if ratio is None else f"{ratio:.2f}" for ratio in ratios),
        )
        shares.add_row(str(row.frames), *(f"{row.high_error[s]:.3f}" for s in strategies))
    Console().print(errors)
    Console().print(shares)
