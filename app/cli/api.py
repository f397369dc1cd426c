"""``srg serve`` and ``srg analytics``: the play side of the CLI."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import typer

from app.cli.output import JSON_HELP, emit
from app.core.errors import InvalidInput

if TYPE_CHECKING:
    from rich.console import Console


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
    from app.db import get_engine, require_current_schema, require_intact

    # refused here in one line, rather than served as a 503 to every request: a database
    # unreachable, not a database, damaged or not migrated (the embedded default migrates)
    engine = get_engine()
    require_current_schema(engine)
    require_intact(engine)
    require_listenable(host, port)
    uvicorn.run(create_app(), host=host, port=port, **UVICORN_OPTIONS)


def analytics(
    graph: str = typer.Argument(..., help="graph name (or id)"),
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
    how well the crowd model predicted the latest publication's play from the earlier ones'.
    """
    from app.config import get_settings
    from app.core.player_models import parse_player_model
    from app.db import session_factory
    from app.liquid.devices import LiquidDevices
    from app.services.dynamics import make_dynamics
    from app.services.prediction import latest_play_prediction
    from app.store.analytics import graph_analytics
    from app.store.graphs import get_graph_row

    if top < 1:
        raise InvalidInput(f"--top must be at least 1, got {top}")
    if player_model is not None:  # before any work; '' names no model either
        parse_player_model(player_model)
    settings = get_settings()
    with session_factory()() as session:
        if threshold is None:
            row = get_graph_row(session, graph)
            dynamics = make_dynamics(
                row.dynamics,
                row.scene.get("preset"),
                row.scene.get("fluid"),
                devices=LiquidDevices.from_settings(settings),
            )
            threshold = settings.high_error_threshold or dynamics.high_error_threshold
        report = graph_analytics(session, graph, threshold)
        report["prediction"] = latest_play_prediction(session, settings, graph, player_model)
    if json_output:
        emit(report, as_json=True)
    else:
        _print_tables(report, top)


def _print_tables(report: dict[str, Any], top: int) -> None:
    from rich.console import Console
    from rich.table import Table

    def table(title: str, rows: list[dict[str, Any]]) -> Table:
        out = Table(title=title)
        for column in rows[0] if rows else ["(no traces)"]:
            out.add_column(str(column), justify="right")
        for row in rows:
            out.add_row(*(f"{v:.4g}" if isinstance(v, float) else str(v) for v in row.values()))
        return out

    lengths = dict(report["session_lengths"])
    lengths.update(lengths.pop("percentiles"))
    visits = report["visit_counts"][:top]
    shown = {row["vertex"] for row in visits}
    console = Console()
    console.print(
        table(f"observed error (threshold {report['threshold']:g})", report["observed_error"])
    )
    console.print(table("session lengths (steps)", [lengths]))
    console.print(table(f"visits (top {top} vertices)", visits))
    console.print(
        table(
            "observed control probabilities (those vertices)",
            [r for r in report["control_probabilities"] if r["vertex"] in shown],
        )
    )
    _print_prediction(console, report["prediction"])


#: the figures of the prediction table, in the order an operator reads them
PREDICTION_ROWS = (
    "predicted_expected_error",
    "observed_mean_error",
    "expected_error_relative_difference",
    "per_vertex_bound_expected_error",
    "per_vertex_bound_relative_difference",
    "density_correlation",
    "density_tv_distance",
    "predicted_mass_unvisited",
)


def _print_prediction(console: Console, prediction: dict[str, Any] | None) -> None:
    """The latest publication's play against what the crowd model predicted for it."""
    from rich.table import Table

    if prediction is None:
        console.print("prediction: fewer than two publications played, nothing to compare yet")
        return
    caption = (
        f"the {prediction['player_model']} model, learned from "
        f"{prediction['sessions_learned_from']} sessions on "
        f"{prediction['publications_learned_from']} earlier publication(s), against "
        f"{prediction['sessions_predicted']} sessions on the latest"
    )
    out = Table(title="prediction of the latest publication's play", caption=caption)
    out.add_column("figure")
    out.add_column("value", justify="right")
    for key in PREDICTION_ROWS:
        value = prediction[key]
        out.add_row(key, f"{value:.4g}" if isinstance(value, float) else str(value))
    console.print(out)
    if prediction["model_fit"] is not None:
        fit = prediction["model_fit"]
        console.print("model fit: " + " ".join(f"{k}={v}" for k, v in fit.items()), markup=False)
