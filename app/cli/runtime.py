"""``srg worker``, ``beat``, ``flower``, ``set-growing``, ``grow-epoch``, ``bench grow``.

The first three start Celery's own programs on the app of :mod:`app.tasks`, configured
from Settings (``SRG_BROKER_URL``, ``SRG_DATABASE_URL``, ...); see docs/runtime.md.
"""

from __future__ import annotations

import json
from pathlib import Path

import typer


def worker(
    concurrency: int = typer.Option(1, help="worker processes (prefork pool)"),
    queues: str = typer.Option("celery", help="comma-separated queues to consume"),
    loglevel: str = typer.Option("INFO"),
    hostname: str | None = typer.Option(None, help="node name (default: celery@host)"),
) -> None:
    """Run a Celery worker of the growth tasks (needs SRG_BROKER_URL)."""
    from app.tasks import celery_app

    _require_broker()
    argv = ["worker", f"--concurrency={concurrency}", f"--queues={queues}"]
    argv.append(f"--loglevel={loglevel}")
    if hostname:
        argv.append(f"--hostname={hostname}")
    celery_app.worker_main(argv)


def beat(
    loglevel: str = typer.Option("INFO"),
    schedule: Path | None = typer.Option(
        None, help="beat's state file (default SRG_VAR_DIR/celerybeat-schedule)"
    ),
) -> None:
    """Run Celery beat: a growth tick every SRG_BEAT_INTERVAL seconds for growing graphs."""
    from app.config import get_settings
    from app.tasks import celery_app

    _require_broker()
    state = beat_state_file(get_settings().var_dir, schedule)
    celery_app.start(["beat", f"--loglevel={loglevel}", f"--schedule={state}"])


def beat_state_file(var_dir: Path, schedule: Path | None) -> Path:
    """Beat's state file, its directory made: beat fails on a missing one."""
    path = schedule or var_dir / "celerybeat-schedule"
    path.parent.mkdir(parents=True, exist_ok=True)
    return path


def flower(
    port: int = typer.Option(5555),
    address: str = typer.Option("127.0.0.1"),
) -> None:
    """Run Flower, the Celery monitor (web UI and /api on PORT)."""
    from app.tasks import celery_app

    _require_broker()
    celery_app.start(["flower", f"--port={port}", f"--address={address}"])


def set_growing(
    name: str = typer.Argument(..., help="graph name or id"),
    on: bool = typer.Option(..., "--on/--off", help="grow it on every beat tick, or stop"),
) -> None:
    """Mark a graph for beat's periodic growth (or take it off)."""
    from app.cli.graph import emit
    from app.db import transaction
    from app.services.growth import set_growing as mark

    with transaction() as session:
        emit(mark(session, name, on), False)


def grow_epoch(name: str = typer.Argument(..., help="graph name or id")) -> None:
    """Send one grow_epoch task now (what beat sends); prints its task id."""
    from app.db import transaction
    from app.store.graphs import get_graph_row
    from app.tasks.growth import grow_epoch as task

    with transaction() as session:
        graph_id = get_graph_row(session, name).id
    typer.echo(task.delay(graph_id).id)


def _require_broker() -> None:
    from app.config import get_settings

    if get_settings().eager:
        raise ValueError("no broker: set SRG_BROKER_URL=redis://... (see docs/runtime.md)")


def _positive_ints(option: str, value: str) -> list[int]:
    """A comma-separated list of positive integers, or a one-line ``ValueError``."""
    message = f"{option} takes comma-separated positive integers, got {value!r}"
    try:
        numbers = [int(part) for part in value.split(",")]
    except ValueError:
        raise ValueError(message) from None
    if any(n <= 0 for n in numbers):
        raise ValueError(message)
    return numbers


def bench_grow(
    epochs: int = typer.Option(6, help="growth epochs per run"),
    batch: int = typer.Option(8, help="expansions per epoch (and integrated per graph size)"),
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
    dynamics: str = typer.Option("toy", help="dynamics of the throughput runs: toy or liquid"),
    preset: str | None = typer.Option(None, help="liquid preset (default tiny)"),
    json_output: bool = typer.Option(True, "--json/--no-json", help="print JSON (default)"),
) -> None:
    """Expansions per minute on 1 and 2 worker processes; integration time vs graph size."""
    from app.bench.grow import bench_grow as run
    from app.services.dynamics import make_dynamics

    if sizes is not None and frames is not None:
        raise ValueError("give --sizes (edges) or --frames, not both")
    for option, value in (("--epochs", epochs), ("--batch", batch)):
        if value <= 0:
            raise ValueError(f"{option} must be positive, got {value}")
    if dynamics == "liquid":
        preset = preset or "tiny"
    model = make_dynamics(dynamics, preset)  # bad names fail here, before any service starts
    edge_sizes = _positive_ints("--sizes", sizes or "1000,10000,100000")
    frame_sizes = None if frames is None else _positive_ints("--frames", frames)
    smallest = model.n_controls * (model.n_controls + 1) * model.frames_per_clip
    if frame_sizes is not None and min(frame_sizes) < smallest:
        raise ValueError(
            f"--frames must be at least {smallest} (the initial tree), got {min(frame_sizes)}"
        )
    result = run(
        dynamics=dynamics,
        preset=preset,
        epochs=epochs,
        batch=batch,
        worker_counts=_positive_ints("--workers", workers),
        sizes=edge_sizes,
        frames=frame_sizes,
        integration_only=integration_only,
    )
    typer.echo(json.dumps(result, indent=2))


def register_runtime_commands(app: typer.Typer, bench_app: typer.Typer) -> None:
    """Attach the runtime commands to the main app and ``bench grow`` to the bench app."""
    app.command("worker")(worker)
    app.command("beat")(beat)
    app.command("flower")(flower)
    app.command("set-growing")(set_growing)
    app.command("grow-epoch")(grow_epoch)
    bench_app.command("grow")(bench_grow)
