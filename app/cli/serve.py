"""``srg serve``: the HTTP API and the browser client, on a database ready to serve."""

from __future__ import annotations

import typer

from app.core.errors import InvalidInput


def serve(
    host: str = typer.Option("127.0.0.1", help="interface to listen on"),
    port: int = typer.Option(8000, help="TCP port"),
) -> None:
    """Serve the HTTP API and the browser client (open http://HOST:PORT/)."""
    if not 0 < port < 65536:
        raise InvalidInput(f"--port must be a TCP port, 1 to 65535, got {port}")
    import uvicorn

    from app.api.app import create_app
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
    uvicorn.run(create_app(settings), host=host, port=port, **UVICORN_OPTIONS)
