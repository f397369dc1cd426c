"""SQL analytics over uploaded traces (docs/design.md, "Runtime": "SQL queries over traces").

Plain SQL text, portable between SQLite (3.25+, for window functions) and PostgreSQL, so
the same statements can be read in docs/play.md and pasted into ``psql`` or ``sqlite3``.
Vertex indices are stable across a graph's publications (vertices are only ever
appended), so the per-vertex figures pool every publication of the graph.

Every statement reads only the sessions of the players chosen (``:kinds``, the
:class:`~app.core.players.PlayerKind` values of a
:class:`~app.core.players.PlayerSelection`). The figures that are means over sessions
are read one row per session, so that their standard error is computed over sessions
(:mod:`app.core.session_figures`).
"""

from __future__ import annotations

from dataclasses import asdict
from typing import Any

from sqlalchemy import TextClause, bindparam, text
from sqlalchemy.orm import Session

from app.core.players import PlayerKind, PlayerSelection
from app.core.session_figures import SessionFigure, SessionLengths


def _chosen_players(statement: str) -> TextClause:
    """A statement whose ``:kinds`` is a list of player kinds."""
    return text(statement).bindparams(bindparam("kinds", expanding=True))


CONTROL_PROBABILITIES = _chosen_players("""
SELECT s.vertex, s.control, COUNT(*) AS n,
       CAST(COUNT(*) AS FLOAT) / SUM(COUNT(*)) OVER (PARTITION BY s.vertex) AS p
FROM trace_steps s
JOIN traces t ON t.id = s.trace_id
JOIN publications p ON p.id = t.publication_id
JOIN players pl ON pl.id = t.player_id
WHERE p.graph_id = :graph_id AND pl.kind IN :kinds
GROUP BY s.vertex, s.control
ORDER BY s.vertex, s.control
""")

VISIT_COUNTS = _chosen_players("""
SELECT s.vertex, COUNT(*) AS visits, COUNT(DISTINCT s.trace_id) AS sessions
FROM trace_steps s
JOIN traces t ON t.id = s.trace_id
JOIN publications p ON p.id = t.publication_id
JOIN players pl ON pl.id = t.player_id
WHERE p.graph_id = :graph_id AND pl.kind IN :kinds
GROUP BY s.vertex
ORDER BY visits DESC, s.vertex
""")

SESSION_LENGTHS = _chosen_players("""
SELECT t.n_steps
FROM traces t
JOIN publications p ON p.id = t.publication_id
JOIN players pl ON pl.id = t.player_id
WHERE p.graph_id = :graph_id AND pl.kind IN :kinds
""")

#: one row per session: its steps, their summed error and how many were above the threshold
SESSION_ERRORS = _chosen_players("""
SELECT p.id AS publication_id, p.number, COUNT(*) AS steps, SUM(e.err) AS error,
       SUM(CASE WHEN e.err > :threshold THEN 1 ELSE 0 END) AS high_error_steps
FROM trace_steps s
JOIN traces t ON t.id = s.trace_id
JOIN publications p ON p.id = t.publication_id
JOIN players pl ON pl.id = t.player_id
JOIN publication_edges e
  ON e.publication_id = t.publication_id AND e.vertex = s.vertex AND e.control = s.control
WHERE p.graph_id = :graph_id AND pl.kind IN :kinds
GROUP BY p.id, p.number, t.id
ORDER BY p.number, t.id
""")

#: every session of the graph by its player's kind, whichever players were chosen
SESSIONS_BY_KIND = text("""
SELECT pl.kind, COUNT(*) AS sessions
FROM traces t
JOIN publications p ON p.id = t.publication_id
JOIN players pl ON pl.id = t.player_id
WHERE p.graph_id = :graph_id
GROUP BY pl.kind
""")


def _parameters(graph_id: int, players: PlayerSelection, **more: Any) -> dict[str, Any]:
    return {"graph_id": graph_id, "kinds": [kind.value for kind in players.kinds], **more}


def control_probabilities(
    session: Session, graph_id: int, players: PlayerSelection = PlayerSelection.ALL
) -> list[dict[str, Any]]:
    """Observed P(c | v): per visited vertex and control, the count and its share."""
    rows = session.execute(CONTROL_PROBABILITIES, _parameters(graph_id, players)).mappings()
    return [dict(row) for row in rows]


def visit_counts(
    session: Session, graph_id: int, players: PlayerSelection = PlayerSelection.ALL
) -> list[dict[str, Any]]:
    """Steps taken from each visited vertex, and in how many sessions; most visited first."""
    rows = session.execute(VISIT_COUNTS, _parameters(graph_id, players)).mappings()
    return [dict(row) for row in rows]


def session_lengths(
    session: Session, graph_id: int, players: PlayerSelection = PlayerSelection.ALL
) -> SessionLengths:
    lengths = session.scalars(SESSION_LENGTHS, _parameters(graph_id, players)).all()
    return SessionLengths.of(lengths)


def observed_error(
    session: Session,
    graph_id: int,
    threshold: float,
    players: PlayerSelection = PlayerSelection.ALL,
) -> list[dict[str, Any]]:
    """Per publication: the mean err of the edge taken at each step and the share of steps
    above ``threshold``, each with its standard error over sessions (relative to it)."""
    rows = session.execute(
        SESSION_ERRORS, _parameters(graph_id, players, threshold=threshold)
    ).all()
    by_publication: dict[tuple[int, int], list[Any]] = {}
    for row in rows:
        by_publication.setdefault((row.publication_id, row.number), []).append(row)
    out = []
    for (publication_id, number), sessions in by_publication.items():
        steps = [row.steps for row in sessions]
        mean_error = SessionFigure.over_sessions([row.error for row in sessions], steps)
        high = SessionFigure.over_sessions([row.high_error_steps for row in sessions], steps)
        out.append(
            {
                "publication_id": publication_id,
                "number": number,
                "sessions": len(sessions),
                "steps": sum(steps),
                "mean_error": mean_error.value,
                "mean_error_relative_se": mean_error.relative_se,
                "high_error_fraction": high.value,
                "high_error_fraction_relative_se": high.relative_se,
            }
        )
    return out


def sessions_by_kind(session: Session, graph_id: int) -> dict[str, int]:
    """Sessions played on the graph per player kind, every kind named (0 if none)."""
    rows = session.execute(SESSIONS_BY_KIND, {"graph_id": graph_id}).all()
    counts: dict[str, int] = {row.kind: int(row.sessions) for row in rows}
    return {kind.value: counts.get(kind.value, 0) for kind in PlayerKind}


def graph_analytics(
    session: Session,
    graph_id: int,
    threshold: float,
    players: PlayerSelection = PlayerSelection.ALL,
) -> dict[str, Any]:
    """The SQL reports of the graph, on the sessions of ``players``."""
    return {
        "threshold": threshold,
        "players": players.value,
        "sessions_by_kind": sessions_by_kind(session, graph_id),
        "observed_error": observed_error(session, graph_id, threshold, players),
        "session_lengths": asdict(session_lengths(session, graph_id, players)),
        "visit_counts": visit_counts(session, graph_id, players),
        "control_probabilities": control_probabilities(session, graph_id, players),
    }
