"""SQL analytics over uploaded traces (docs/design.md, "Runtime": "SQL queries over traces").

Plain SQL text, portable between SQLite (3.25+, for window functions) and PostgreSQL, so
the same statements can be read in docs/play.md and pasted into ``psql`` or ``sqlite3``.
Vertex indices are stable across a graph's publications (vertices are only ever
appended), so the per-vertex figures pool every publication of the graph. The reports
read the sums (``play_counts``, ``play_visits``: the traces uploaded since the last count
are counted first) and the per-session figures kept as traces are accepted
(``traces.error``), so they answer as fast after millions of steps as
after a few (docs/analytics.md, "What analytics reads").

Every statement reads only the sessions of the players chosen (``:kinds``, the
:class:`~app.core.players.kinds.PlayerKind` values of a
:class:`~app.core.players.kinds.PlayerSelection`). The figures that are means over sessions
are read one row per session, so that their standard error is computed over sessions
(:mod:`app.core.evaluation.session_figures`).
"""

from __future__ import annotations

from dataclasses import asdict
from typing import Any

from sqlalchemy import TextClause, bindparam, text
from sqlalchemy.orm import Session

from app.core.evaluation.session_figures import SessionFigure, SessionLengths
from app.core.players.kinds import PlayerKind, PlayerSelection
from app.store.play_counts import count_uploaded


def _chosen_players(statement: str) -> TextClause:
    """A statement whose ``:kinds`` is a list of player kinds."""
    return text(statement).bindparams(bindparam("kinds", expanding=True))


CONTROL_PROBABILITIES = _chosen_players("""
SELECT c.vertex, c.control, CAST(SUM(c.steps) AS BIGINT) AS n,
       CAST(SUM(c.steps) AS FLOAT) / SUM(SUM(c.steps)) OVER (PARTITION BY c.vertex) AS p
FROM play_counts c
JOIN publications p ON p.id = c.publication_id
WHERE p.graph_id = :graph_id AND c.player_kind IN :kinds
GROUP BY c.vertex, c.control
ORDER BY c.vertex, c.control
""")

VISIT_COUNTS = _chosen_players("""
SELECT s.vertex, s.visits, v.sessions
FROM (SELECT c.vertex, CAST(SUM(c.steps) AS BIGINT) AS visits
      FROM play_counts c
      JOIN publications p ON p.id = c.publication_id
      WHERE p.graph_id = :graph_id AND c.player_kind IN :kinds
      GROUP BY c.vertex) s
JOIN (SELECT w.vertex, CAST(SUM(w.sessions) AS BIGINT) AS sessions
      FROM play_visits w
      JOIN publications p ON p.id = w.publication_id
      WHERE p.graph_id = :graph_id AND w.player_kind IN :kinds
      GROUP BY w.vertex) v ON v.vertex = s.vertex
ORDER BY s.visits DESC, s.vertex
""")

SESSION_LENGTHS = _chosen_players("""
SELECT t.n_steps
FROM traces t
JOIN publications p ON p.id = t.publication_id
JOIN players pl ON pl.id = t.player_id
WHERE p.graph_id = :graph_id AND pl.kind IN :kinds
""")

#: one row per session: its steps, their summed error and, where its publication stored
#: the threshold asked for, how many were above it (else NULL: HIGH_ERROR_STEPS counts them)
SESSION_ERRORS = _chosen_players("""
SELECT p.id AS publication_id, p.number, t.id AS trace_id, t.n_steps AS steps, t.error,
       CASE WHEN p.high_error_threshold = :threshold THEN t.high_error_steps END
         AS high_error_steps
FROM traces t
JOIN publications p ON p.id = t.publication_id
JOIN players pl ON pl.id = t.player_id
WHERE p.graph_id = :graph_id AND pl.kind IN :kinds
ORDER BY p.number, t.id
""")

#: the steps above :threshold of each session of the publications whose stored threshold
#: is another (or none): the only report that reads the steps
HIGH_ERROR_STEPS = _chosen_players("""
SELECT t.id AS trace_id, SUM(CASE WHEN e.err > :threshold THEN 1 ELSE 0 END) AS high_error_steps
FROM trace_steps s
JOIN traces t ON t.id = s.trace_id
JOIN publications p ON p.id = t.publication_id
JOIN players pl ON pl.id = t.player_id
JOIN publication_edges e
  ON e.publication_id = t.publication_id AND e.vertex = s.vertex AND e.control = s.control
WHERE p.graph_id = :graph_id AND pl.kind IN :kinds
  AND (p.high_error_threshold IS NULL OR p.high_error_threshold <> :threshold)
GROUP BY t.id
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
    count_uploaded(session, graph_id)
    rows = session.execute(CONTROL_PROBABILITIES, _parameters(graph_id, players)).mappings()
    return [dict(row) for row in rows]


def visit_counts(
    session: Session, graph_id: int, players: PlayerSelection = PlayerSelection.ALL
) -> list[dict[str, Any]]:
    """Steps taken from each visited vertex, and in how many sessions; most visited first."""
    count_uploaded(session, graph_id)
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
    above ``threshold``, each with its standard error over sessions (relative to it).

    Each session's error and its high-error steps at its publication's threshold were
    kept when it was stored; only a threshold other than the one a publication stored
    makes its steps be read again (``HIGH_ERROR_STEPS``)."""
    parameters = _parameters(graph_id, players, threshold=threshold)
    rows = session.execute(SESSION_ERRORS, parameters).all()
    counted: dict[int, int] = {}
    if any(row.high_error_steps is None for row in rows):
        counted = {
            row.trace_id: row.high_error_steps
            for row in session.execute(HIGH_ERROR_STEPS, parameters)
        }
    by_publication: dict[tuple[int, int], list[Any]] = {}
    for row in rows:
        by_publication.setdefault((row.publication_id, row.number), []).append(row)
    out = []
    for (publication_id, number), sessions in by_publication.items():
        steps = [row.steps for row in sessions]
        mean_error = SessionFigure.over_sessions([row.error for row in sessions], steps)
        high = SessionFigure.over_sessions(
            [
                counted[row.trace_id] if row.high_error_steps is None else row.high_error_steps
                for row in sessions
            ],
            steps,
        )
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
