"""``srg validate`` and ``srg calibrate``: the liquid's physics checked and measured.

Each command checks its arguments before it imports the liquid (PyOpenCL, Mitsuba) or
starts a simulation, so bad input fails at once: a preset or fluid srg does not have in
the parser, the rest with an :class:`~app.core.errors.InvalidInput`. Progress goes to
stderr.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Literal

import typer

from app.cli.choices import Fluid, LiquidPreset
from app.cli.output import JSON_HELP, emit, write_result
from app.core.errors import InvalidInput
from app.core.liquid.defaults import DEFAULT_FLUID, DEFAULT_LIQUID_PRESET

PRESET_HELP = "tilt-tank preset"
FLUID_HELP = "fluid: low or high viscosity"


def _verdict(check: dict[str, Any]) -> str:
    if "skipped" in check:
        return f"skipped ({check['skipped']})"
    return "passed" if check["passed"] else "FAILED"


def _print_constants(stored: dict[str, Any], json_output: bool) -> None:
    """The constants as JSON, or a table of their top-level figures (details: ``--json``)."""
    if json_output:
        emit(stored, as_json=True)
    else:
        emit({k: v for k, v in stored.items() if not isinstance(v, dict | list)}, as_json=False)


def validate(
    preset: LiquidPreset = typer.Option(LiquidPreset(DEFAULT_LIQUID_PRESET), help=PRESET_HELP),
    fluid: Fluid = typer.Option(Fluid(DEFAULT_FLUID), help=FLUID_HELP),
    json_output: bool = typer.Option(False, "--json", help=JSON_HELP),
    result_path: Path | None = typer.Option(
        None, "--result", help="also write the JSON result to this file"
    ),
) -> None:
    """Physical checks of the PCISPH liquid (minutes on small); exit 1 if one fails.

    Runs the kernel/NumPy twins, bit-reproducibility, a hydrostatic tank, Martin and
    Moyce's dam break (water: skipped for the high-viscosity fluid) and the settling
    after a tilt. Prints one line per check (with --json: the JSON of every check).
    """
    from app.config import get_settings
    from app.liquid import validation
    from app.reports.provenance import with_provenance

    settings = get_settings()
    typer.echo(f"validating tilt-tank/{preset} with the {fluid} fluid (minutes) ...", err=True)
    report = with_provenance(
        validation.validate(preset.value, fluid.value, device=settings.runtime.opencl_device),
        settings,
    )
    if result_path is not None:
        write_result(result_path, report)
    if json_output:
        emit(report, as_json=True)
    else:
        for name, check in report["checks"].items():
            typer.echo(f"{name}: {_verdict(check)}")
        details = f" (details: {result_path})" if result_path is not None else ""
        typer.echo(f"all passed: {report['passed']}{details}")
    if not report["passed"]:
        raise typer.Exit(1)


def calibrate(
    preset: LiquidPreset = typer.Option(..., help=PRESET_HELP),
    fluid: Fluid = typer.Option(Fluid(DEFAULT_FLUID), help=FLUID_HELP),
    only: Literal["threshold"] | None = typer.Option(
        None, help="re-measure just this constant, keep the others stored"
    ),
    figures: Path | None = typer.Option(
        None, help="with --only threshold: write the study's PNG figures to this directory"
    ),
    records: Path | None = typer.Option(
        None, help="with --only threshold: write every measured blend to this JSON file"
    ),
    json_output: bool = typer.Option(False, "--json", help=JSON_HELP),
) -> None:
    """Measure T0, w_e, the crowd radius and the high-error threshold of a preset.

    Stores them in app/data/calibration/PRESET.json (PRESET-high.json for the
    high-viscosity fluid; read by LiquidDynamics) and prints them. The threshold
    (docs/threshold.md) is most of the time: 4-8 min on tiny, about 18 min on small at a
    load of 11 on 2 cores; the paper preset takes hours.
    """
    preset_name, fluid_name = preset.value, fluid.value
    if only is None and (figures or records):
        raise InvalidInput("--figures and --records go with --only threshold")

    from app.config import get_settings
    from app.liquid.devices import LiquidDevices
    from app.reports.provenance import with_provenance

    settings = get_settings()
    devices = LiquidDevices.from_settings(settings)

    def progress(message: str) -> None:
        typer.echo(message, err=True)

    if only == "threshold":
        from app.liquid.calibration import calibrate_threshold

        typer.echo(
            f"threshold of tilt-tank/{preset_name}, {fluid_name} fluid (minutes) ...", err=True
        )
        stored, study = calibrate_threshold(preset_name, fluid_name, progress, devices=devices)
        if records:
            write_result(records, with_provenance({**stored, "blends": study.records()}, settings))
        if figures:
            from app.reports.threshold import write_threshold_figures

            name = preset_name if fluid_name == DEFAULT_FLUID else f"{preset_name}-{fluid_name}"
            old = stored.get("percentile_threshold")
            for path in write_threshold_figures(study, figures, name, old):
                typer.echo(f"wrote {path}", err=True)
        _print_constants(stored, json_output)
        return
    from app.liquid import calibration

    typer.echo(f"calibrating tilt-tank/{preset_name} with the {fluid_name} fluid ...", err=True)
    _print_constants(
        calibration.calibrate(preset_name, fluid_name, progress, devices=devices), json_output
    )
