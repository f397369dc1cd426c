"""SQL analytics over uploaded traces (docs/design.md, "Runtime": "SQL queries over traces").

Plain SQL text, portable between SQLite (3.25+, for window functions) and PostgreSQL, so
the same statements can be read in docs/play.md and pasted into ``psql`` or ``sqlite3``.
Vertex indices are stable across a graph's publications (vertices are only ever
appended), so the per-vertex figures pool every publication of the graph.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any

from sqlalchemy import text
from sqlalchemy.orm import Session

from app.store.graphs import get_graph_row

CONTROL_PROBABILITIES = text("""
SELECT s.vertex, s.control, COUNT(*) AS n,
       CAST(COUNT(*) AS FLOAT) / SUM(COUNT(*)) OVER (PARTITION BY s.vertex) AS p
FROM trace_steps s
JOIN traces t ON t.id = s.trace_id
JOIN publications p ON p.id = t.publication_id
WHERE p.graph_id = :graph_id
GROUP BY s.vertex, s.control
ORDER BY s.vertex, s.control
""")

VISIT_COUNTS = text("""
SELECT s.vertex, COUNT(*) AS visits, COUNT(DISTINCT s.trace_id) AS sessions
FROM trace_steps s
JOIN traces t ON t.id = s.trace_id
JOIN publications p ON p.id = t.publication_id
WHERE p.graph_id = :graph_id
GROUP BY s.vertex
ORDER BY visits DESC, s.vertex
""")

SESSION_LENGTH_SUMMARY = text("""
SELECT COUNT(*) AS sessions, AVG(t.n_steps) AS mean, MIN(t.n_steps) AS min,
       MAX(t.n_steps) AS max
FROM traces t
JOIN publications p ON p.id = t.publication_id
WHERE p.graph_id = :graph_id
""")

#: nearest-rank percentile: the value at 1-based rank ceil(q * n) in ascending order
SESSION_LENGTH_AT_RANK = text("""
SELECT t.n_steps
FROM traces t
JOIN publications p ON p.id = t.publication_id
WHERE p.graph_id = :graph_id
ORDER BY t.n_steps
LIMIT 1 OFFSET :offset
""")

OBSERVED_ERROR = text("""
SELECT p.id AS publication_id, p.number, COUNT(DISTINCT t.id) AS sessions,
       COUNT(*) AS steps, AVG(e.err) AS mean_error,
       CAST(SUM(CASE WHEN e.err > :threshold THEN 1 ELSE 0 END) AS FLOAT) / COUNT(*)
           AS high_error_fraction
FROM trace_steps s
JOIN traces t ON t.id = s.trace_id
JOIN publications p ON p.id = t.publication_id
JOIN publication_edges e
  ON e.publication_id = t.publication_id AND e.vertex = s.vertex AND e.control = s.control
WHERE p.graph_id = :graph_id
GROUP BY p.id, p.number
ORDER BY p.number
""")

SESSION_LENGTH_QUANTILES = (0.5, 0.9, 0.99)


@dataclass(frozen=True)
class SessionLengths:
    sessions: int
    mean: float | None
    min: int | None
    max: int | None
    #: nearest-rank percentiles, keyed "p50", "p90", "p99"
    percentiles: dict[str, int]


def control_probabilities(session: Session, graph_id: int) -> list[dict[str, Any]]:
    """Observed P(c | v): per visited vertex and control, the count and its share."""
    rows = session.execute(CONTROL_PROBABILITIES, {"graph_id": graph_id}).mappings()
    return [dict(row) for row in rows]


def visit_counts(session: Session, graph_id: int) -> list[dict[str, Any]]:
    """Steps taken from each visited vertex, and in how many sessions; most visited first."""
    return [dict(row) for row in session.execute(VISIT_COUNTS, {"graph_id": graph_id}).mappings()]


def session_lengths(session: Session, graph_id: int) -> SessionLengths:
    summary = session.execute(SESSION_LENGTH_SUMMARY, {"graph_id": graph_id}).mappings().one()
    n = int(summary["sessions"])
    percentiles = {
        f"p{round(q * 100)}": int(
            session.scalar(
                SESSION_LENGTH_AT_RANK, {"graph_id": graph_id, "offset": math.ceil(q * n) - 1}
            )
        )
        for q in SESSION_LENGTH_QUANTILES
        if n
    }
    return SessionLengths(
        sessions=n,
        mean=None if summary["mean"] is None else float(summary["mean"]),
        min=summary["min"],
        max=summary["max"],
        percentiles=percentiles,
    )


def observed_error(session: Session, graph_id: int, threshold: float) -> list[dict[str, Any]]:
    """Per publication: mean err of the edge taken at each step, share of steps above it."""
    rows = session.execute(OBSERVED_ERROR, {"graph_id": graph_id, "threshold": threshold})
    return [dict(row) for row in rows.mappings()]


def graph_analytics(session: Session, graph: str, threshold: float) -> dict[str, Any]:
    """All four reports for the graph named (or numbered) ``graph``; GraphNotFound if none."""
    graph_id = get_graph_row(session, graph).id
    return {
        "graph": graph,
        "threshold": threshold,
        "observed_error": observed_error(session, graph_id, threshold),
        "session_lengths": asdict(session_lengths(session, graph_id)),
        "visit_counts": visit_counts(session, graph_id),
        "control_probabilities": control_probabilities(session, graph_id),
    }
