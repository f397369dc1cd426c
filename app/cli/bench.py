"""``srg bench ...``: speed and memory figures, always JSON on stdout (targets live here,
never in tests).

Each command checks its arguments before it starts the benchmark of :mod:`app.bench`, so
bad input fails at once: a choice or a number out of range in the parser, the rest with
an :class:`~app.core.errors.InvalidInput`.
"""

from __future__ import annotations

from dataclasses import asdict
from pathlib import Path

import typer

from app.cli import bench_liquid
from app.cli.choices import (
    DynamicsName,
    LiquidPreset,
    positive_finite,
    positive_ints,
    value_of,
)
from app.cli.output import emit_measured, progress_bar
from app.cli.serve import MAX_WORKERS
from app.core.errors import InvalidInput

app = typer.Typer(help="Benchmarks; each prints JSON.", no_args_is_help=True)


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
    emit_measured(bench_rank(n_edges=edges, n_controls=controls, seed=seed))


@app.command("completion")
def completion(
    repeats: int = typer.Option(5, min=1, help="completions timed (the median is reported)"),
    line: str = typer.Option("srg exp", help="the command line being completed"),
) -> None:
    """Wall and CPU time of one tab completion, and of importing the CLI; target 0.3 s."""
    from app.bench.completion import bench_completion

    if not line.startswith("srg"):
        raise InvalidInput(f"--line completes an srg command line, not {line!r}")
    emit_measured(bench_completion(repeats=repeats, line=line))


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
    emit_measured(bench_experiment(list(ctx.args)))


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
    from app.core.liquid.defaults import QUICK_LIQUID_PRESET
    from app.liquid.devices import LiquidDevices
    from app.services.dynamics import make_dynamics

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
    edge_sizes = positive_ints("--sizes", sizes or "1000,10000,100000")
    frame_sizes = None if frames is None else positive_ints("--frames", frames)
    smallest = model.n_controls * (model.n_controls + 1) * model.frames_per_clip
    if frame_sizes is not None and min(frame_sizes) < smallest:
        raise InvalidInput(
            f"--frames must be at least {smallest} (the initial tree), got {min(frame_sizes)}"
        )
    emit_measured(
        bench_grow(
            settings=settings,
            dynamics=dynamics.value,
            preset=scene_preset,
            epochs=epochs,
            batch=batch,
            worker_counts=positive_ints("--workers", workers),
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
    emit_measured(result)
    if not result["ok"]:
        raise typer.Exit(1)


app.command("sph")(bench_liquid.sph)
app.command("gpu")(bench_liquid.gpu)
app.command("clip")(bench_liquid.clip)


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
    emit_measured(result)


@app.command("bytes")
def stored_bytes(name: str = typer.Argument(..., help="a stored graph")) -> None:
    """Everything a stored graph keeps, per simulated frame and by kind."""
    from app.bench.footprint import bench_bytes
    from app.config import get_settings

    emit_measured(bench_bytes(get_settings(), name))


@app.command("look")
def look(name: str = typer.Argument(..., help="a stored graph with rendered clips")) -> None:
    """Near-black pixels per frame of a graph's rendered clips: percentiles, the worst."""
    from app.bench.look import bench_look
    from app.config import get_settings

    emit_measured(bench_look(get_settings(), name))


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
    emit_measured(bench_dedup(get_settings(), name, values, sheet))


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

    counts = positive_ints("--workers", workers)
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
    emit_measured(result)


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

    emit_measured(
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

    emit_measured(bench_client(seconds))


@app.command("serve")
def serve(
    players: str = typer.Option(
        "10,100,500", help="comma-separated numbers of players at once, a round each"
    ),
    workers: int = typer.Option(
        2, min=1, max=MAX_WORKERS, help="uvicorn worker processes of srg serve"
    ),
    mean_steps: int = typer.Option(
        30,
        min=2,
        max=100_000,
        help="mean steps of a session (geometric lengths; one over the server's "
        "SRG_MAX_TRACE_STEPS is uploaded cut to it)",
    ),
    database_url: str = typer.Option(
        "",
        help="a migrated database to serve ('': a scratch PostgreSQL database on the "
        "server of SRG_SCRATCH_POSTGRES_URL, dropped afterwards)",
    ),
    uploads_only: bool = typer.Option(
        False,
        "--uploads-only",
        help="players register first; a round is their trace uploads alone, all at once",
    ),
) -> None:
    """Players at once through srg serve: sessions per second, p50/p99 latency, errors.

    Each player registers, fetches the publication and the animations its session plays
    and uploads its trace (with --uploads-only, only uploads). Exit status 1 when a
    request failed, a trace was not stored or the play sums differ from the stored steps.
    """
    from app.bench.serve import bench_serve
    from app.config import get_settings

    result = bench_serve(
        get_settings(),
        players=positive_ints("--players", players),
        workers=workers,
        mean_steps=mean_steps,
        database_url=database_url,
        uploads_only=uploads_only,
    )
    emit_measured(result)
    if not result["ok"]:
        raise typer.Exit(1)
