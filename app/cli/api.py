"""``srg serve`` and ``srg analytics``: the play side of the CLI."""

from __future__ import annotations

import typer

from app.cli.output import JSON_HELP, emit
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
    from app.db.engines import get_engine, require_intact
    from app.db.migrations import require_current_schema

    # refused here in one line, rather than served as a 503 to every request: a database
    # unreachable, not a database, damaged or not migrated (the embedded default migrates)
    engine = get_engine()
    require_current_schema(engine)
    require_intact(engine)
    require_listenable(host, port)
    uvicorn.run(create_app(), host=host, port=port, **UVICORN_OPTIONS)


def analytics(
    graph: str = typer.Argument(..., help="graph name (or id)"),
    players: str = typer.Option(
        "all", help="whose sessions every figure is computed from: people, bots or all"
    ),
    json_output: bool = typer.Option(False, "--json", help=JSON_HELP),
    threshold: float | None = typer.Option(
        None, help="high-error threshold (default: settings, else the dynamics' default)"
    ),
    top: int = typer.Option(10, help="vertices shown in the per-vertex tables"),
    player_model: str | None = typer.Option(
        None, help="crowd model whose prediction is shown: eq2, knn or logit (default: the graph's)"
    ),
) -> None:
    """Observed error, session lengths, visits and control probabilities from traces, and
    how well the crowd model predicted the latest publication's play from the earlier ones',
    with a warning for each figure that rests on too few sessions.
    """
    from app.config import get_settings
    from app.core.players import parse_player_selection
    from app.db.sessions import session_factory
    from app.services.analytics import played_graph_analytics

    if top < 1:
        raise InvalidInput(f"--top must be at least 1, got {top}")
    chosen = parse_player_selection(players)
    with session_factory()() as session:
        report = played_graph_analytics(
            session,
            get_settings(),
            graph,
            players=chosen,
            threshold=threshold,
            player_model=player_model,
        )
    if json_output:
        emit(report, as_json=True)
    else:
        from app.cli.analytics_tables import print_report

        print_report(report, top)
