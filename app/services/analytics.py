"""What the traces of a graph say (``srg analytics``): the SQL reports, how well the crowd
model predicted the latest publication's play, and a warning for every figure that rests
on too few sessions (the rule: :mod:`app.core.evaluation.session_figures`).

Every figure is computed from the sessions of the players chosen: people, bots or all.
"""

from __future__ import annotations

import math
from typing import Any

from sqlalchemy.orm import Session

from app.config import Settings
from app.core.evaluation.session_figures import MAX_RELATIVE_SE, MIN_SESSIONS, SessionFigure
from app.core.players.kinds import PlayerSelection, parse_player_model
from app.services.loading import graph_context
from app.services.prediction import latest_play_prediction
from app.store.analytics import graph_analytics
from app.store.graph_catalogue import graph_entry


def played_graph_analytics(
    session: Session,
    settings: Settings,
    graph: str,
    *,
    players: PlayerSelection = PlayerSelection.ALL,
    threshold: float | None = None,
    player_model: str | None = None,
) -> dict[str, Any]:
    """The analytics of the graph named (or numbered) ``graph`` on the sessions of
    ``players``; ``threshold`` defaults to the settings', else the dynamics' own, and
    ``player_model`` (the crowd model judged) to the graph's.

    Raises GraphNotFound, and InvalidInput for an unknown player model (before any work).
    """
    if player_model is not None:  # '' names no model either
        parse_player_model(player_model)
    entry = graph_entry(session, graph)
    if threshold is None:
        threshold = graph_context(entry, settings).threshold
    report: dict[str, Any] = {
        "graph": graph,
        **graph_analytics(session, entry.id, threshold, players),
    }
    report["prediction"] = latest_play_prediction(session, settings, graph, player_model, players)
    report["warnings"] = [
        _warning(name, figure) for name, figure in _figures(report) if figure.too_few_sessions
    ]
    return report


def _figures(report: dict[str, Any]) -> list[tuple[str, SessionFigure]]:
    """The report's means over sessions, named as the warnings name them; those with no
    value (no session played) are left out: there is nothing to trust or distrust."""
    figures = []
    for row in report["observed_error"]:
        number, sessions = row["number"], row["sessions"]
        figures += [
            (
                f"mean error of publication {number}",
                SessionFigure(row["mean_error"], sessions, row["mean_error_relative_se"]),
            ),
            (
                f"high-error share of publication {number}",
                SessionFigure(
                    row["high_error_fraction"], sessions, row["high_error_fraction_relative_se"]
                ),
            ),
        ]
    lengths = report["session_lengths"]
    figures.append(
        (
            "mean session length",
            SessionFigure(lengths["mean"], lengths["sessions"], lengths["mean_relative_se"]),
        )
    )
    prediction = report["prediction"]
    if prediction is not None:
        relative_se = prediction["observed_mean_error_relative_se"]
        observed = SessionFigure(
            prediction["observed_mean_error"],
            prediction["sessions_predicted"],
            None if math.isnan(relative_se) else relative_se,
        )
        figures.append(("observed error the prediction is judged against", observed))
    return [(name, figure) for name, figure in figures if figure.value is not None]


def _warning(name: str, figure: SessionFigure) -> dict[str, Any]:
    """One figure's warning: its sessions, its relative standard error, about how many
    sessions would do, and a sentence saying so."""
    rests_on = f"{name} rests on {figure.sessions} sessions"
    if figure.sessions < MIN_SESSIONS:
        measured = "" if figure.relative_se is None else f" (measured: {figure.relative_se:.0%})"
        why = f", fewer than {MIN_SESSIONS}: even its standard error is unsure{measured}"
    else:
        why = f": its standard error is {figure.relative_se:.0%} of it, over {MAX_RELATIVE_SE:.0%}"
    return {
        "figure": name,
        "sessions": figure.sessions,
        "relative_se": figure.relative_se,
        "sessions_needed": figure.sessions_needed,
        "message": f"{rests_on}{why}; about {figure.sessions_needed} sessions would do",
    }
