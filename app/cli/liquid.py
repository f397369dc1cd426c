"""``srg validate``, ``srg calibrate`` and ``srg bench sph|clip|store``: the liquid's CLI.

Each command checks its arguments before it imports the liquid (PyOpenCL, Mitsuba) or
starts a simulation, so bad input fails at once with a ``ValueError``: ``app.cli.main``
prints it as one line and exits 2. Results are JSON on stdout; progress goes to stderr.
"""

from __future__ import annotations

import json
from dataclasses import asdict
from pathlib import Path
from typing import Any

import typer

from app.services.dynamics import (
    DEFAULT_FLUID,
    DEFAULT_LIQUID_PRESET,
    check_fluid,
    check_liquid_preset,
)

PRESET_HELP = "tilt-tank preset: tiny, small or paper"
FLUID_HELP = "fluid: low or high viscosity"


def register_liquid_commands(app: typer.Typer, bench_app: typer.Typer) -> None:
    """Attach the liquid commands to the main app and the bench group."""
    app.command("validate")(validate_command)
    app.command("calibrate")(calibrate_command)
    bench_app.command("sph")(bench_sph_command)
    bench_app.command("clip")(bench_clip_command)
    bench_app.command("store")(bench_store_command)


def _dumps(data: dict[str, Any]) -> str:
    return json.dumps(data, indent=2, default=str)


def _flat(data: dict[str, Any], prefix: str = "") -> dict[str, Any]:
    """Nested dicts as one level of dotted keys, for the ``key=value`` line of ``--no-json``."""
    out: dict[str, Any] = {}
    for key, value in data.items():
        if isinstance(value, dict):
            out.update(_flat(value, f"{prefix}{key}."))
        else:
            out[f"{prefix}{key}"] = f"{value:.4g}" if isinstance(value, float) else value
    return out


def _print(result: dict[str, Any], json_output: bool) -> None:
    if json_output:
        typer.echo(_dumps(result))
    else:
        typer.echo(" ".join(f"{k}={v}" for k, v in _flat(result).items()))


def _positive(name: str, value: int) -> int:
    if value <= 0:
        raise ValueError(f"{name} must be positive, got {value}")
    return value


def _verdict(check: dict[str, Any]) -> str:
    if "skipped" in check:
        return f"skipped ({check['skipped']})"
    return "passed" if check["passed"] else "FAILED"


def validate_command(
    preset: str = typer.Option(DEFAULT_LIQUID_PRESET, help=PRESET_HELP),
    fluid: str = typer.Option(DEFAULT_FLUID, help=FLUID_HELP),
    json_path: str | None = typer.Option(
        None, "--json", help="write the JSON to this file ('-' or absent: stdout)"
    ),
) -> None:
    """Physical checks of the PCISPH liquid (minutes on small); exit 1 if one fails.

    Runs the kernel/NumPy twins, bit-reproducibility, a hydrostatic tank, Martin and
    Moyce's dam break (water: skipped for the high-viscosity fluid) and the settling
    after a tilt. With ``--json FILE`` the JSON goes to the file and one line per check
    to stdout.
    """
    check_liquid_preset(preset)
    check_fluid(fluid)
    from app.liquid.validation import validate

    typer.echo(f"validating tilt-tank/{preset} with the {fluid} fluid (minutes) ...", err=True)
    report = validate(preset, fluid)
    if json_path and json_path != "-":
        Path(json_path).parent.mkdir(parents=True, exist_ok=True)
        Path(json_path).write_text(_dumps(report) + "\n")
        for name, check in report["checks"].items():
            typer.echo(f"{name}: {_verdict(check)}")
        typer.echo(f"all passed: {report['passed']} (details: {json_path})")
    else:
        typer.echo(_dumps(report))
    if not report["passed"]:
        raise typer.Exit(1)


def calibrate_command(
    preset: str = typer.Option(..., help=PRESET_HELP),
    fluid: str = typer.Option(DEFAULT_FLUID, help=FLUID_HELP),
    only: str | None = typer.Option(
        None, help="re-measure just this constant ('threshold'), keep the others stored"
    ),
    figures: Path | None = typer.Option(
        None, help="with --only threshold: write the study's PNG figures to this directory"
    ),
    records: Path | None = typer.Option(
        None, help="with --only threshold: write every measured blend to this JSON file"
    ),
) -> None:
    """Measure T0, w_e, the crowd radius and the high-error threshold of a preset.

    Stores them in ``app/data/calibration/<preset>.json`` (``<preset>-high.json`` for
    the high-viscosity fluid; read by ``LiquidDynamics``) and prints them. The threshold
    (``docs/threshold.md``) is most of the time: 4-8 min on tiny, about 18 min on small
    at a load of 11 on 2 cores; the paper preset takes hours.
    """
    check_liquid_preset(preset)
    check_fluid(fluid)
    if only not in (None, "threshold"):
        raise ValueError(f"--only takes 'threshold', got {only!r}")
    if only is None and (figures or records):
        raise ValueError("--figures and --records go with --only threshold")

    def progress(message: str) -> None:
        typer.echo(message, err=True)

    if only == "threshold":
        from app.liquid.calibration import calibrate_threshold

        typer.echo(f"threshold of tilt-tank/{preset}, {fluid} fluid (minutes) ...", err=True)
        stored, study = calibrate_threshold(preset, fluid, progress)
        if records:
            records.parent.mkdir(parents=True, exist_ok=True)
            records.write_text(_dumps({**stored, "blends": study.records()}) + "\n")
        if figures:
            from app.reports.threshold import write_threshold_figures

            name = preset if fluid == DEFAULT_FLUID else f"{preset}-{fluid}"
            old = stored.get("percentile_threshold")
            for path in write_threshold_figures(study, figures, name, old):
                typer.echo(f"wrote {path}", err=True)
        typer.echo(_dumps(stored))
        return
    from app.liquid.calibration import calibrate

    typer.echo(f"calibrating tilt-tank/{preset} with the {fluid} fluid ...", err=True)
    typer.echo(_dumps(calibrate(preset, fluid, progress)))


def bench_sph_command(
    preset: str = typer.Option(DEFAULT_LIQUID_PRESET, help=PRESET_HELP),
    fluid: str = typer.Option(DEFAULT_FLUID, help=FLUID_HELP),
    steps: int = typer.Option(300, help="substeps timed (rounded down to whole frames)"),
    splishsplash: bool = typer.Option(
        True, "--splishsplash/--no-splishsplash", help="also time SPlisHSPlasH's PCISPH"
    ),
    json_output: bool = typer.Option(True, "--json/--no-json", help="print JSON (default)"),
) -> None:
    """Particle-substeps per second of the PCISPH kernels (converged and at 3 iterations)."""
    check_liquid_preset(preset)
    check_fluid(fluid)
    _positive("--steps", steps)
    from app.bench.sph import bench_sph

    _print(bench_sph(preset, steps, compare_splishsplash=splishsplash, fluid=fluid), json_output)


def bench_clip_command(
    preset: str = typer.Option(DEFAULT_LIQUID_PRESET, help=PRESET_HELP),
    fluid: str = typer.Option(DEFAULT_FLUID, help=FLUID_HELP),
    settle: float = typer.Option(1.0, help="seconds of settling first (half damped)"),
    frames: int | None = typer.Option(
        None, help="simulate this many frames of each clip and scale (default: all)"
    ),
    json_output: bool = typer.Option(True, "--json/--no-json", help="print JSON (default)"),
) -> None:
    """Seconds per clip of each stage of a liquid edge (SPH to WebP) and its bytes."""
    check_liquid_preset(preset)
    check_fluid(fluid)
    if settle <= 0:
        raise ValueError(f"--settle must be positive, got {settle}")
    if frames is not None:
        _positive("--frames", frames)
    from app.bench.clip import bench_clip

    _print(bench_clip(preset, fluid, settle=settle, frames=frames), json_output)


def bench_store_command(
    edges: int = typer.Option(100_000, help="edges of the synthetic graph"),
    database_url: str | None = typer.Option(
        None, help="a migrated database (default: a temporary SQLite file)"
    ),
    distinct_bundles: int | None = typer.Option(
        None, help="clips share this many bundles (default: one per clip)"
    ),
    json_output: bool = typer.Option(True, "--json/--no-json", help="print JSON (default)"),
) -> None:
    """Seconds to save and to load a whole graph of N edges (the work is rolled back)."""
    _positive("--edges", edges)
    if distinct_bundles is not None:
        _positive("--distinct-bundles", distinct_bundles)
    from app.bench.store import bench_store

    result = asdict(
        bench_store(edges, database_url=database_url, distinct_bundles=distinct_bundles)
    )
    result["save_edges_per_s"] = result["n_edges"] / max(result["save_seconds"], 1e-12)
    result["load_edges_per_s"] = result["n_edges"] / max(result["load_seconds"], 1e-12)
    _print(result, json_output)
