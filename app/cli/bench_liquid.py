"""``srg bench sph|gpu|clip``: the liquid's benchmarks (registered on ``srg bench`` by
:mod:`app.cli.bench`), JSON on stdout; bad input fails before any simulation."""

from __future__ import annotations

import typer

from app.cli.choices import Fluid, LiquidPreset, positive_finite, positive_ints
from app.cli.liquid import FLUID_HELP, PRESET_HELP
from app.cli.output import emit_measured
from app.core.errors import InvalidInput
from app.core.liquid.defaults import DEFAULT_FLUID, DEFAULT_LIQUID_PRESET


def sph(
    preset: LiquidPreset = typer.Option(LiquidPreset(DEFAULT_LIQUID_PRESET), help=PRESET_HELP),
    fluid: Fluid = typer.Option(Fluid(DEFAULT_FLUID), help=FLUID_HELP),
    steps: int = typer.Option(300, min=1, help="substeps timed (rounded down to whole frames)"),
    splishsplash: bool = typer.Option(
        True, "--splishsplash/--no-splishsplash", help="also time SPlisHSPlasH's PCISPH"
    ),
    profile: bool = typer.Option(
        False,
        "--profile",
        help="instead: device time per kernel and the host's gaps, per substep, "
        "from a profiling queue (the tank tilted, after a 1 s settle)",
    ),
    batch: str | None = typer.Option(
        None, help="instead: whole clips in batches of these sizes (e.g. 1,3,12)"
    ),
) -> None:
    """Particle-substeps per second of the PCISPH kernels (converged and at 3 iterations)."""
    from app.config import get_settings

    device = get_settings().runtime.opencl_device
    if batch is not None:
        if profile:
            raise InvalidInput("--batch and --profile are two benchmarks: give one")
        from app.bench.sph_batch import bench_batch

        emit_measured(
            bench_batch(preset.value, fluid.value, positive_ints("--batch", batch), device)
        )
    elif profile:
        from app.bench.sph_profile import profile_sph

        emit_measured(profile_sph(preset.value, fluid.value, steps, device))
    else:
        from app.bench.sph import bench_sph

        emit_measured(
            bench_sph(
                preset.value,
                steps,
                fluid=fluid.value,
                device=device,
                compare_splishsplash=splishsplash,
            )
        )


def gpu(
    frame_preset: LiquidPreset = typer.Option(
        LiquidPreset("paper"), help="preset of the high fluid's frame time"
    ),
    batch_preset: LiquidPreset = typer.Option(
        LiquidPreset("small"), help="preset of the low fluid's clips in batches"
    ),
    batch: str = typer.Option("1,12", help="batch sizes; the last one's speed-up is judged"),
) -> None:
    """The GPU check (infra/gpu-bench.sh): a frame's seconds, batches, identity, profile."""
    from app.bench.gpu import bench_gpu
    from app.config import get_settings

    sizes = tuple(positive_ints("--batch", batch))
    emit_measured(
        bench_gpu(
            get_settings().runtime.opencl_device, frame_preset.value, batch_preset.value, sizes
        )
    )


def clip(
    preset: LiquidPreset = typer.Option(LiquidPreset(DEFAULT_LIQUID_PRESET), help=PRESET_HELP),
    fluid: Fluid = typer.Option(Fluid(DEFAULT_FLUID), help=FLUID_HELP),
    settle: float = typer.Option(
        1.0, callback=positive_finite, help="seconds of settling first (half damped)"
    ),
    frames: int | None = typer.Option(
        None, min=1, help="simulate this many frames of each clip and scale (default: all)"
    ),
) -> None:
    """Seconds per clip of each stage of a liquid edge (SPH to the VP9 clip) and its bytes."""
    from app.bench.clip import bench_clip
    from app.config import get_settings
    from app.liquid.devices import LiquidDevices

    devices = LiquidDevices.from_settings(get_settings())
    emit_measured(
        bench_clip(preset.value, fluid.value, devices=devices, settle=settle, frames=frames)
    )
