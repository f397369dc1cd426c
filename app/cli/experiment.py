"""``srg experiment``: the paper's evaluation, one stored graph per strategy and seed."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import typer

from app.cli.choices import DynamicsName, Fluid, LiquidPreset, choice_list, seed_list, value_of
from app.cli.output import JSON_HELP, emit, progress_bar, write_result
from app.core.errors import InvalidInput
from app.core.growth.kinds import Strategy
from app.core.players.kinds import BotKind, PlayerModelKind

if TYPE_CHECKING:
    from app.services.experiment.plan import ExperimentPlan


def experiment(
    dynamics: DynamicsName | None = typer.Option(None, help="dynamics to grow (default toy)"),
    preset: LiquidPreset | None = typer.Option(None, help="liquid preset (default small)"),
    fluid: Fluid | None = typer.Option(None, help="liquid fluid (default low)"),
    quick: bool = typer.Option(False, "--quick", help="3 small checkpoints: minutes, not hours"),
    strategies: Sequence[Strategy] | None = choice_list(
        Strategy,
        what="strategy",
        help="strategies grown (default: baseline, sr-heuristic, sr-crowd; max-error only "
        "when named; sr-crowd brings sr-heuristic, its control)",
    ),
    seeds: str | None = typer.Option(
        None,
        help="comma-separated seeds, each a world and its bots (default 0,1,2); "
        "all or none of the selection seeds 10-14",
    ),
    checkpoints: str | None = typer.Option(None, help="comma-separated frame counts"),
    sessions: int | None = typer.Option(
        None, min=1, help="bot sessions per checkpoint (default 30)"
    ),
    player_model: PlayerModelKind | None = typer.Option(
        None, help="crowd model sr-crowd learns; eq2 is the paper's (default SRG_PLAYER_MODEL)"
    ),
    bots: Sequence[BotKind] | None = choice_list(
        BotKind,
        what="bot",
        help="crowds (bots) that play, each growing its own sr-crowd runs (default goal-directed)",
    ),
    pooled: bool = typer.Option(
        False,
        "--pooled",
        help="the crowds play as one: sr-crowd learns from all their traces, one run per seed",
    ),
    judges: Sequence[BotKind] | None = choice_list(
        BotKind,
        what="bot",
        help="bots that play every run at every checkpoint and teach none (their traces are "
        "not stored); not among --bots",
    ),
    shares: str | None = typer.Option(
        None,
        help="comma-separated share of --sessions each pooled crowd plays at every "
        "checkpoint, in --bots' order (e.g. 0.5,0.3,0.2); whole sessions each",
    ),
    fresh_judges: bool = typer.Option(
        False,
        "--fresh-judges",
        help="each crowd's kind also plays as many sessions on new seeds, never stored: "
        "players the model never learned from",
    ),
    preregistration: Path | None = typer.Option(
        None,
        help="the study's pre-registered plan file: stored with its digest, and a resume "
        "refuses it once changed",
    ),
    fixed_graph_sessions: int | None = typer.Option(
        None,
        min=1,
        help="bot sessions per half of the fixed-graph prediction setting (default 100)",
    ),
    name: str | None = typer.Option(
        None, help="experiment name (default: from dynamics, preset and fluid)"
    ),
    resume: bool = typer.Option(
        False, "--resume", help="finish the stored experiment NAME from its last checkpoint"
    ),
    jobs: int | None = typer.Option(
        None, min=1, help="runs at once (default: the cores in-process; every run on workers)"
    ),
    through: int | None = typer.Option(
        None,
        min=1,
        help="stop after this checkpoint (frames, one of the plan's) and report up to it; "
        "--resume goes on later",
    ),
    only_seeds: str | None = typer.Option(
        None,
        help="grow only the runs of these comma-separated seeds of the plan now, the rest on "
        "a later --resume (a study longer than one machine's stay, world by world)",
    ),
    json_output: bool = typer.Option(False, "--json", help=JSON_HELP),
    result_path: Path | None = typer.Option(
        None, "--result", help="also write the JSON result to this file"
    ),
    out: Path | None = typer.Option(
        None, help="directory for plots and report.md (default var/experiment/NAME)"
    ),
) -> None:
    """Grow one graph per strategy and seed through checkpoints; compare what bots see.

    The paper's section 7 (docs/experiment.md). Graphs, traces and every checkpoint's
    figures are stored, so an interrupted experiment continues with --resume. With
    SRG_BROKER_URL set, growth runs on the Celery workers.
    """
    from app.config import get_settings
    from app.db.engines import require_intact
    from app.reports.experiment import RATIO_LABELS, interval_text
    from app.services.experiment.conduct import conduct_experiment
    from app.services.experiment.runs import Grower

    options = (dynamics, preset, fluid, strategies, seeds, checkpoints, sessions)
    model_options = (player_model, bots, judges, shares, preregistration, fixed_graph_sessions)
    scene = (value_of(dynamics) or DynamicsName.TOY.value, value_of(preset), value_of(fluid))
    name = name or "-".join(x for x in ("experiment", *scene) if x)
    settings = get_settings()
    report_dir = out or settings.var_dir / "experiment" / name
    _require_makeable("--out", report_dir, directory=True)
    if result_path is not None:
        _require_makeable("--result", result_path, directory=False)
    require_intact(settings)
    plan = None
    if resume:
        flags = (quick, pooled, fresh_judges)
        if any(flags) or any(option is not None for option in (*options, *model_options)):
            raise InvalidInput(
                "--resume runs the stored plan: give only --name, --jobs, --through, "
                "--only-seeds, --json, --result, --out"
            )
    else:
        plan = _experiment_plan(
            scene[0],
            quick,
            *scene[1:],
            strategies,
            seeds,
            checkpoints,
            sessions,
            value_of(player_model) or settings.growth.player_model,
            bots,
            fixed_graph_sessions,
            pooled=pooled,
            judges=judges,
            shares=shares,
            fresh_judges=fresh_judges,
            preregistration=preregistration,
        )
        plan.checkpoint_index(through)  # refused before the broker is asked
    workers: Grower | None = None
    if not settings.eager:
        from app.tasks.celery_app import require_broker
        from app.tasks.growth import grow_on_workers

        require_broker(settings)
        workers = grow_on_workers
    conducted = conduct_experiment(
        settings,
        name,
        plan,
        report_dir=report_dir,
        workers=workers,
        jobs=jobs,
        through=through,
        only_seeds=None if only_seeds is None else seed_list(only_seeds, "--only-seeds"),
        progress=lambda total: progress_bar(total, f"{name}: frames grown"),
    )
    result = conducted.result
    if result_path is not None:
        write_result(result_path, result)
    if json_output:
        emit(result, as_json=True)
    for bot, rows in result["comparison"].items():
        for row in rows:
            ratios = [
                f"{label} {interval_text(row[key], 3)} ({row[key]['verdict']})"
                for key, label in RATIO_LABELS.items()
                if key in row
            ]
            typer.echo(
                f"{bot} at {row['checkpoint_frames']} frames, error: {'; '.join(ratios)}",
                err=json_output,
            )
        judged = [target for row in rows for target in row.get("targets", [])]
        measured = [target for target in judged if target["value"] is not None]
        if judged:
            met = sum(target["met"] for target in measured)
            waiting = len(judged) - len(measured)
            unmeasured = f", {waiting} not measured" if waiting else ""
            if len(conducted.plan.seeds) < 2 and waiting:
                unmeasured = f", {waiting} need an interval over worlds"
            typer.echo(f"{bot}: {met} of {len(judged)} targets met{unmeasured}", err=json_output)
    typer.echo(f"report: {conducted.report}", err=True)


def _require_makeable(option: str, path: Path, *, directory: bool) -> None:
    """Refuse now a directory or file that cannot be made at ``path`` (a regular file on
    its way, a directory where the file goes), rather than when it is written after hours
    of growth."""
    existing = next(part for part in (path, *path.parents) if part.exists())
    if existing == path and not directory:
        if path.is_dir():
            raise InvalidInput(f"{option} {path} is a directory")
    elif not existing.is_dir():
        raise InvalidInput(f"{option} {path}: {existing} is not a directory")


def _experiment_plan(
    dynamics: str,
    quick: bool,
    preset: str | None,
    fluid: str | None,
    strategies: Sequence[Strategy] | None,
    seeds: str | None,
    checkpoints: str | None,
    sessions: int | None,
    player_model: str | None,
    bots: Sequence[BotKind] | None,
    fixed_graph_sessions: int | None,
    *,
    pooled: bool = False,
    judges: Sequence[BotKind] | None = None,
    shares: str | None = None,
    fresh_judges: bool = False,
    preregistration: Path | None = None,
) -> ExperimentPlan:
    from app.core.players.kinds import parse_player_model
    from app.services.experiment.plan import ExperimentPlan, parse_checkpoints
    from app.services.experiment.preregistration import preregistration_of

    changes: dict[str, Any] = {"preset": preset, "fluid": fluid}
    if strategies is not None:
        changes["strategies"] = tuple(strategies)
    if seeds is not None:
        changes["seeds"] = seed_list(seeds, "--seeds")
    if checkpoints is not None:
        changes["checkpoints"] = parse_checkpoints(checkpoints)
    if sessions is not None:
        changes["sessions"] = sessions
    if player_model is not None:
        changes["player_model"] = parse_player_model(player_model)
    if bots is not None:
        changes["bots"] = tuple(bots)
    if judges is not None:
        changes["judges"] = tuple(judges)
    if pooled:
        changes["pooled"] = True
    if shares is not None:
        try:
            changes["shares"] = tuple(float(s) for s in shares.split(","))
        except ValueError:
            raise InvalidInput(f"shares must be comma-separated numbers, got {shares!r}") from None
    if fresh_judges:
        changes["fresh_judges"] = True
    if preregistration is not None:
        changes["preregistration"] = preregistration_of(preregistration)
    if fixed_graph_sessions is not None:
        changes["fixed_graph_sessions"] = fixed_graph_sessions
    if quick:
        return ExperimentPlan.quick(dynamics, **changes)
    return ExperimentPlan(dynamics=dynamics, **changes)
