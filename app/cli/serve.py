"""``srg serve``: the HTTP API and the browser client, on a database ready to serve."""

from __future__ import annotations

import typer

from app.cli.runtime import MAX_PORT

#: worker processes of `srg serve` at most
MAX_WORKERS = 64
#: seconds a worker may leave uvicorn's liveness ping unanswered before it is replaced:
#: uvicorn's 5 s kills, again and again, workers still importing on a busy machine
WORKER_PING_TIMEOUT_S = 60


def serve(
    host: str = typer.Option("127.0.0.1", help="interface to listen on"),
    workers: int = typer.Option(
        1,
        min=1,
        max=MAX_WORKERS,
        help="uvicorn worker processes, each with its own database pool and caches",
    ),
    port: int = typer.Option(8000, min=1, max=MAX_PORT, help="TCP port"),
) -> None:
    """Serve the HTTP API and the browser client (open http://HOST:PORT/)."""
    import uvicorn

    from app.api.serving import UVICORN_OPTIONS, require_listenable
    from app.config import get_settings
    from app.db.engines import database_engine, require_intact
    from app.db.migrations import require_current_schema

    # refused here in one line, rather than served as a 503 to every request: a database
    # unreachable, not a database, damaged or not migrated (the embedded default migrates)
    settings = get_settings()
    require_current_schema(database_engine(settings))
    require_intact(settings)
    require_listenable(host, port)
    # a factory each worker process calls (it reads the same environment's settings)
    uvicorn.run(
        "app.api.app:create_app",
        factory=True,
        host=host,
        port=port,
        workers=workers,
        timeout_worker_healthcheck=WORKER_PING_TIMEOUT_S,
        **UVICORN_OPTIONS,
    )
