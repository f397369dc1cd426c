"""``srg bench ...``: speed and memory figures, always JSON on stdout (targets live here,
never in tests).

Each command checks its arguments before it starts the benchmark of :mod:`app.bench`, so
bad input fails at once: a choice or a number out of range in the parser, the rest with
an :class:`~app.core.errors.InvalidInput`.
"""

from __future__ import annotations

from dataclasses import asdict
from pathlib import Path
from typing import Any

import typer

from app.cli.choices import DynamicsName, Fluid, LiquidPreset, positive_finite, value_of
from app.cli.liquid import FLUID_HELP, PRESET_HELP
from app.cli.output import emit, progress_bar
from app.cli.serve import MAX_WORKERS
from app.core.errors import InvalidInput
from app.core.scene import DEFAULT_FLUID
from app.services.dynamics import DEFAULT_LIQUID_PRESET

app = typer.Typer(help="Benchmarks; each prints JSON.", no_args_is_help=True)


def _emit(result: Any) -> None:
    """A benchmark's JSON on stdout, led by where and how it was measured."""
    from app.config import get_settings
    from app.reports.provenance import with_provenance

    emit(with_provenance(result, get_settings()), as_json=True)


def _positive_ints(option: str, value: str) -> list[int]:
    """A comma-separated list of positive integers, or a one-line error."""
    message = f"{option} takes comma-separated positive integers, got {value!r}"
    try:
        numbers = [int(part) for part in value.split(",")]
    except ValueError:
        raise InvalidInput(message) from None
    if any(n <= 0 for n in numbers):
        raise InvalidInput(message)
    return numbers


@app.command("rank")
def rank(
    edges: int = typer.Option(1_000_000, min=1, help="edges of the synthetic grown graph"),
    controls: int = typer.Option(3, min=1, help="controls N"),
    seed: int = typer.Option(0, min=0, help="seed of the synthetic graph"),
) -> None:
    """One cold and one warm STATERANK (after one expansion), next to networkx.pagerank."""
    from app.bench.rank import bench_rank

    if edges < controls * 10:
        raise InvalidInput(f"--edges must be at least {controls * 10}")
    _emit(bench_rank(n_edges=edges, n_controls=controls, seed=seed))


@app.command(
    "experiment", context_settings={"allow_extra_args": True, "ignore_unknown_options": True}
)
def experiment(ctx: typer.Context) -> None:
    """Wall and CPU time of `srg experiment ARGS...` from an empty database.

    For example: srg bench experiment --dynamics liquid --preset tiny --seeds 0
    --checkpoints 2000,5000,10000,20000 (the paper's four strategies to 20k frames).
    """
    from app.bench.experiment import bench_experiment

    refused = ("--json", "--result", "--resume", "--name", "--out")
    if any(arg in refused for arg in ctx.args):
        raise InvalidInput("the benchmark runs a fresh experiment: leave out " + ", ".join(refused))
    _emit(bench_experiment(list(ctx.args)))


@app.command("grow")
def grow(
    epochs: int = typer.Option(6, min=1, help="growth epochs per run"),
    batch: int = typer.Option(
        8, min=1, help="expansions per epoch (and integrated per graph size)"
    ),
    workers: str = typer.Option("1,2", help="comma-separated worker-process counts"),
    sizes: str | None = typer.Option(
        None, help="graph sizes (edges) to integrate at [default: 1000,10000,100000]"
    ),
    frames: str | None = typer.Option(
        None, help="graph sizes in simulated frames to integrate at, instead of --sizes"
    ),
    integration_only: bool = typer.Option(
        False,
        "--integration-only",
        help="only the integrating step, on a graph of --dynamics (default: also throughput)",
    ),
    dynamics: DynamicsName = typer.Option(DynamicsName.TOY, help="dynamics of the throughput runs"),
    preset: LiquidPreset | None = typer.Option(None, help="liquid preset (default tiny)"),
) -> None:
    """Expansions per minute on 1 and 2 worker processes; integration time vs graph size."""
    from app.bench.grow import bench_grow
    from app.config import get_settings
    from app.liquid.devices import LiquidDevices
    from app.services.dynamics import QUICK_LIQUID_PRESET, make_dynamics

    if sizes is not None and frames is not None:
        raise InvalidInput("give --sizes (edges) or --frames, not both")
    scene_preset = value_of(preset)
    if dynamics is DynamicsName.LIQUID:
        scene_preset = scene_preset or QUICK_LIQUID_PRESET
    settings = get_settings()
    # a preset for the toy fails here, before any service starts
    model = make_dynamics(
        dynamics.value, scene_preset, devices=LiquidDevices.from_settings(settings)
    )
    edge_sizes = _positive_ints("--sizes", sizes or "1000,10000,100000")
    frame_sizes = None if frames is None else _positive_ints("--frames", frames)
    smallest = model.n_controls * (model.n_controls + 1) * model.frames_per_clip
    if frame_sizes is not None and min(frame_sizes) < smallest:
        raise InvalidInput(
            f"--frames must be at least {smallest} (the initial tree), got {min(frame_sizes)}"
        )
    _emit(
        bench_grow(
            settings=settings,
            dynamics=dynamics.value,
            preset=scene_preset,
            epochs=epochs,
            batch=batch,
            worker_counts=_positive_ints("--workers", workers),
            sizes=edge_sizes,
            frames=frame_sizes,
            integration_only=integration_only,
        )
    )


@app.command("ingest")
def ingest(
    clients: int = typer.Option(200, min=1, help="concurrent players"),
    uploads: int = typer.Option(2, min=1, help="traces per player (each also replayed once)"),
    mean_steps: int = typer.Option(90, min=2, help="mean steps per trace"),
    database_url: str = typer.Option("", help="database to load ('': a temporary SQLite)"),
) -> None:
    """Concurrent trace uploads on loopback: every upload accounted for, p99 latency.

    Exit status 1 when an upload was lost or stored twice.
    """
    from app.bench.ingest import bench_ingest

    result = bench_ingest(
        clients=clients, uploads=uploads, mean_steps=mean_steps, database_url=database_url
    )
    _emit(result)
    if not result["ok"]:
        raise typer.Exit(1)


@app.command("sph")
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
        None,
        "--batch",
        help="instead: whole clips in batches of these sizes (e.g. 1,3,12), clip-frames "
        "per second and identity with each clip run alone",
    ),
) -> None:
    """Particle-substeps per second of the PCISPH kernels (converged and at 3 iterations)."""
    from app.config import get_settings

    sizes = _positive_ints("--batch", batch) if batch is not None else None
    if sizes is not None and profile:
        raise InvalidInput("--batch and --profile are two benchmarks: give one")
    device = get_settings().runtime.opencl_device
    if sizes is not None:
        from app.bench.sph_batch import bench_batch

        _emit(bench_batch(preset.value, fluid.value, sizes, device))
        return
    if profile:
        from app.bench.sph_profile import profile_sph

        _emit(profile_sph(preset.value, fluid.value, steps, device))
        return
    from app.bench.sph import bench_sph

    result = bench_sph(
        preset.value, steps, fluid=fluid.value, device=device, compare_splishsplash=splishsplash
    )
    _emit(result)


@app.command("gpu")
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

    sizes = _positive_ints("--batch", batch)
    device = get_settings().runtime.opencl_device
    _emit(bench_gpu(device, frame_preset.value, batch_preset.value, tuple(sizes)))


@app.command("clip")
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
    _emit(bench_clip(preset.value, fluid.value, devices=devices, settle=settle, frames=frames))


@app.command("store")
def store(
    edges: int = typer.Option(100_000, min=1, help="edges of the synthetic graph"),
    database_url: str | None = typer.Option(
        None, help="a migrated database (default: a temporary SQLite file)"
    ),
    distinct_bundles: int | None = typer.Option(
        None, min=1, help="clips share this many bundles (default: one per clip)"
    ),
) -> None:
    """Seconds to save and to load a whole graph of N edges (the work is rolled back)."""
    from app.bench.store import bench_store

    result = asdict(
        bench_store(edges, database_url=database_url, distinct_bundles=distinct_bundles)
    )
    result["save_edges_per_s"] = result["n_edges"] / max(result["save_seconds"], 1e-12)
    result["load_edges_per_s"] = result["n_edges"] / max(result["load_seconds"], 1e-12)
    _emit(result)


@app.command("bytes")
def stored_bytes(name: str = typer.Argument(..., help="a stored graph")) -> None:
    """Everything a stored graph keeps, per simulated frame and by kind."""
    from app.bench.footprint import bench_bytes
    from app.config import get_settings

    _emit(bench_bytes(get_settings(), name))


@app.command("look")
def look(name: str = typer.Argument(..., help="a stored graph with rendered clips")) -> None:
    """Near-black pixels per frame of a graph's rendered clips: percentiles, the worst."""
    from app.bench.look import bench_look
    from app.config import get_settings

    _emit(bench_look(get_settings(), name))


@app.command("dedup")
def dedup(
    name: str = typer.Argument(..., help="a stored graph with rendered clips"),
    fractions: str = typer.Option(
        "0.05,0.1,0.2,0.5", help="limits to replay, as fractions of the high-error threshold"
    ),
    sheet: Path | None = typer.Option(
        None, help="PNG of the last limit's worst substitutions (own frame, frame shown)"
    ),
) -> None:
    """Shared animations on a stored graph: clips reused, bytes saved, the visual cost."""
    from app.bench.dedup import bench_dedup
    from app.config import get_settings

    message = f"--fractions takes comma-separated numbers in (0, 1], got {fractions!r}"
    try:
        values = [float(part) for part in fractions.split(",")]
    except ValueError:
        raise InvalidInput(message) from None
    if not all(0.0 < v <= 1.0 for v in values):
        raise InvalidInput(message)
    _emit(bench_dedup(get_settings(), name, values, sheet))


@app.command("writer")
def writer(
    frames: int = typer.Option(200_000, min=1, help="grow the graph to this many simulated frames"),
    batch: int = typer.Option(30, min=1, help="expansions per epoch"),
    workers: str = typer.Option("50,100,200,400", help="comma-separated worker counts W"),
    clip_seconds: float = typer.Option(
        18.9,
        callback=positive_finite,
        help="worker-seconds per clip (default: the paper preset's, renders included, "
        "docs/runtime.md)",
    ),
    liquid_seconds: float = typer.Option(
        0.33,
        min=0,
        help="seconds the liquid adds to each integration (default: the paper preset's "
        "with warm caches, docs/runtime.md)",
    ),
) -> None:
    """The single writer grown to --frames with synthetic clips: its share of the time at W."""
    from app.bench.writer import bench_writer
    from app.config import get_settings

    counts = _positive_ints("--workers", workers)
    with progress_bar(frames, "frames grown by the writer") as advance:
        result = bench_writer(
            settings=get_settings(),
            frames=frames,
            batch=batch,
            workers=counts,
            clip_seconds=clip_seconds,
            liquid_seconds=liquid_seconds,
            progress=advance,
        )
    _emit(result)


@app.command("epoch-traces")
def epoch_traces(
    steps: int = typer.Option(10_000_000, min=1, help="trace steps stored on the played graph"),
    session_steps: int = typer.Option(2_000, min=1, help="steps per stored session"),
    expansions: int = typer.Option(8, min=1, help="expansions per timed grow"),
    repeats: int = typer.Option(3, min=1, help="timed grows per graph (the median is kept)"),
    sessions: int = typer.Option(20, min=2, help="bot sessions uploaded per publication"),
) -> None:
    """A grow's time with and without --steps stored steps, and srg analytics over them,
    on a scratch PostgreSQL database (ratio target <= 1.2)."""
    from app.bench.epoch_traces import bench_epoch_traces
    from app.config import get_settings

    _emit(
        bench_epoch_traces(
            steps=steps,
            session_steps=session_steps,
            expansions=expansions,
            repeats=repeats,
            sessions=sessions,
            settings=get_settings(),
        )
    )


@app.command("client")
def client(
    seconds: float = typer.Option(20.0, min=1.0, max=600.0, help="seconds of play"),
) -> None:
    """The browser's stalls while the web client plays a toy publication with the keys in
    headless Chromium (the browser test bounds the client's gaps, not these)."""
    from app.bench.client import bench_client

    _emit(bench_client(seconds))


@app.command("serve")
def serve(
    players: str = typer.Option(
        "10,100,500", help="comma-separated numbers of players at once, a round each"
    ),
    workers: int = typer.Option(
        2, min=1, max=MAX_WORKERS, help="uvicorn worker processes of srg serve"
    ),
    mean_steps: int = typer.Option(30, min=2, max=2_000, help="mean steps of a session"),
    database_url: str = typer.Option(
        "",
        help="a migrated database to serve ('': a scratch PostgreSQL database on the "
        "server of SRG_SCRATCH_POSTGRES_URL, dropped afterwards)",
    ),
) -> None:
    """Players at once through srg serve: sessions per second, p50/p99 latency, errors.

    Each player registers, fetches the publication and the animations its session plays
    and uploads its trace. Exit status 1 when a request failed or a trace was not stored.
    """
    from app.bench.serve import bench_serve
    from app.config import get_settings

    result = bench_serve(
        get_settings(),
        players=_positive_ints("--players", players),
        workers=workers,
        mean_steps=mean_steps,
        database_url=database_url,
    )
    _emit(result)
    if not result["ok"]:
        raise typer.Exit(1)
