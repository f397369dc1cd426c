"""``srg analytics``: what the traces of a graph's play say, as tables or JSON."""

from __future__ import annotations

import typer

from app.cli.choices import positive_finite
from app.cli.output import JSON_HELP, emit
from app.core.players.kinds import PlayerModelKind, PlayerSelection


def analytics(
    graph: str = typer.Argument(..., help="graph name (or id)"),
    players: PlayerSelection = typer.Option(
        PlayerSelection.ALL, help="whose sessions every figure is computed from"
    ),
    json_output: bool = typer.Option(False, "--json", help=JSON_HELP),
    threshold: float | None = typer.Option(
        None,
        callback=positive_finite,
        help="high-error threshold, above 0 (default: SRG_HIGH_ERROR_THRESHOLD, else the "
        "one calibrated for the graph's dynamics)",
    ),
    top: int = typer.Option(10, min=1, help="vertices shown in the per-vertex tables"),
    player_model: PlayerModelKind | None = typer.Option(
        None, help="crowd model whose prediction is shown (default: the graph's)"
    ),
) -> None:
    """Observed error, session lengths, visits and control probabilities from traces, and
    how well the crowd model predicted the latest publication's play from the earlier ones',
    with a warning for each figure that rests on too few sessions.
    """
    from app.config import get_settings
    from app.db.sessions import transaction
    from app.services.analytics import played_graph_analytics

    settings = get_settings()
    # a unit of work: the sums first count the traces uploaded since they last did
    with transaction(settings) as session:
        report = played_graph_analytics(
            session,
            settings,
            graph,
            players=players,
            threshold=threshold,
            player_model=None if player_model is None else player_model.value,
        )
    if json_output:
        emit(report, as_json=True)
    else:
        from app.cli.analytics_tables import print_report

        print_report(report, top)
