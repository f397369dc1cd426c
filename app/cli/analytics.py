"""``srg analytics``: what the traces of a graph's play say, as tables or JSON."""

from __future__ import annotations

import typer

from app.cli.output import JSON_HELP, emit
from app.core.errors import InvalidInput


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
    from app.db.sessions import database_sessions
    from app.services.analytics import played_graph_analytics

    if top < 1:
        raise InvalidInput(f"--top must be at least 1, got {top}")
    chosen = parse_player_selection(players)
    settings = get_settings()
    with database_sessions(settings)() as session:
        report = played_graph_analytics(
            session,
            settings,
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
