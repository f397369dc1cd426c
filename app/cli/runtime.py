"""``srg worker``, ``beat``, ``flower``, ``set-growing``, ``grow-epoch``: the Celery runtime.

The first three start Celery's own programs on the app of :mod:`app.tasks`, configured
from Settings (``SRG_BROKER_URL``, ``SRG_DATABASE_URL``, ...); see docs/runtime.md.
"""

from __future__ import annotations

from pathlib import Path

import typer

from app.cli.choices import LogLevel
from app.cli.output import JSON_HELP, emit
from app.core.errors import Unavailable

#: the largest TCP port a server may listen on (the smallest is 1)
MAX_PORT = 65535


def worker(
    concurrency: int = typer.Option(1, min=1, help="worker processes (prefork pool)"),
    queues: str = typer.Option("celery", help="comma-separated queues to consume"),
    loglevel: LogLevel = typer.Option(LogLevel.INFO, help="Celery's log level"),
    hostname: str | None = typer.Option(None, help="node name (default: celery@host)"),
) -> None:
    """Run a Celery worker of the growth tasks (needs SRG_BROKER_URL)."""
    from app.tasks import celery_app

    _require_broker()
    argv = ["worker", f"--concurrency={concurrency}", f"--queues={queues}"]
    argv.append(f"--loglevel={loglevel.value}")
    if hostname:
        argv.append(f"--hostname={hostname}")
    celery_app.worker_main(argv)


def beat(
    loglevel: LogLevel = typer.Option(LogLevel.INFO, help="Celery's log level"),
    schedule: Path | None = typer.Option(
        None, help="beat's state file (default SRG_VAR_DIR/celerybeat-schedule)"
    ),
) -> None:
    """Run Celery beat: a growth tick every SRG_BEAT_INTERVAL seconds for growing graphs."""
    from app.config import get_settings
    from app.tasks import celery_app

    _require_broker()
    state = beat_state_file(get_settings().var_dir, schedule)
    celery_app.start(["beat", f"--loglevel={loglevel.value}", f"--schedule={state}"])


def beat_state_file(var_dir: Path, schedule: Path | None) -> Path:
    """Beat's state file, its directory made: beat fails on a missing one."""
    path = schedule or var_dir / "celerybeat-schedule"
    path.parent.mkdir(parents=True, exist_ok=True)
    return path


def flower(
    port: int = typer.Option(5555, min=1, max=MAX_PORT, help="TCP port of the web UI and /api"),
    address: str = typer.Option("127.0.0.1", help="interface to listen on"),
) -> None:
    """Run Flower, the Celery monitor (web UI, /api and /metrics on PORT), behind HTTP
    basic auth when SRG_FLOWER_BASIC_AUTH is set."""
    from app.config import get_settings
    from app.tasks import celery_app
    from app.tasks.flower_metrics import guard_metrics

    _require_broker()
    guard_metrics()
    argv = ["flower", f"--port={port}", f"--address={address}"]
    # from the settings, never an option: a password on a command line is in every
    # user's `ps`; Flower is started in this process, so it is in no command line
    credentials = get_settings().runtime.flower_basic_auth
    if credentials:
        argv.append(f"--basic-auth={credentials}")
    celery_app.start(argv)


def set_growing(
    name: str = typer.Argument(..., help="graph name or id"),
    on: bool = typer.Option(..., "--on/--off", help="grow it on every beat tick, or stop"),
    json_output: bool = typer.Option(False, "--json", help=JSON_HELP),
) -> None:
    """Mark a graph for beat's periodic growth (or take it off)."""
    from app.config import get_settings
    from app.db.engines import require_intact
    from app.db.sessions import transaction
    from app.services.rank_relink_publish import set_growing as mark

    settings = get_settings()
    require_intact(settings)
    with transaction(settings) as session:
        marked = mark(session, name, on)
    emit(marked, json_output)


def grow_epoch(
    name: str = typer.Argument(..., help="graph name or id"),
    json_output: bool = typer.Option(False, "--json", help=JSON_HELP),
) -> None:
    """Send one grow_epoch task now (what beat sends); prints its task id."""
    from app.config import get_settings
    from app.db.sessions import transaction
    from app.services.catalogue import find_graph
    from app.tasks.celery_app import require_broker
    from app.tasks.growth import grow_epoch as task

    _require_broker()
    settings = get_settings()
    require_broker(settings)
    with transaction(settings) as session:
        graph_id = find_graph(session, name).id
    task_id = task.delay(graph_id).id
    if json_output:
        emit({"graph_id": graph_id, "task_id": task_id}, as_json=True)
    else:
        typer.echo(task_id)


def _require_broker() -> None:
    """A broker is configured. Only the commands that send work also connect to it first:
    a worker, beat or Flower started before Redis is up waits for it, as Celery does."""
    from app.config import get_settings

    if get_settings().eager:
        raise Unavailable("no broker: set SRG_BROKER_URL=redis://... (see docs/runtime.md)")
