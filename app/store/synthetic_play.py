"""Synthetic play written by the server, for ``srg bench epoch-traces``.

Millions of steps cannot go through the upload path in a benchmark's time, so the server
writes them (``generate_series``), numbers them in their graph, and migration 0012's
backfill sums them and each session's error, as it would a database that had stored
them before the sums existed.
"""

from __future__ import annotations

import time

from sqlalchemy import text
from sqlalchemy.orm import Session

from app.db.engines import make_engine
from app.db.migrations import alembic_config

#: the revision before the one whose backfill sums stored steps (0012)
BEFORE_SUMS = "0011"

STORED_SESSIONS = """
INSERT INTO traces (publication_id, player_id, idempotency_key, n_steps)
SELECT p.id, :player, 'stored-' || p.id || '-' || g, :length
FROM publications p CROSS JOIN generate_series(1, :per_publication) g
WHERE p.graph_id = :graph
"""
#: the sessions written count in their graph's numbering (the next ordinal)
NUMBERED_SESSIONS = """
UPDATE graph_sessions SET sessions = sessions + :stored WHERE graph_id = :graph
"""
STORED_STEPS = """
INSERT INTO trace_steps (trace_id, step, vertex, control)
SELECT t.id, s, floor(random() * p.n_vertices)::int, floor(random() * :controls)::int
FROM traces t
JOIN publications p ON p.id = t.publication_id
CROSS JOIN generate_series(0, :length - 1) s
WHERE p.graph_id = :graph AND t.idempotency_key LIKE 'stored-%'
"""

GRAPH_STEPS = text("""
SELECT COUNT(*) FROM trace_steps s
JOIN traces t ON t.id = s.trace_id
JOIN publications p ON p.id = t.publication_id
WHERE p.graph_id = :graph
""")


def graph_step_count(session: Session, graph_id: int) -> int:
    """Steps stored on all of a graph's publications."""
    return int(session.scalar(GRAPH_STEPS, {"graph": graph_id}) or 0)


def store_synthetic_steps(
    url: str, graph_id: int, steps: int, session_steps: int
) -> dict[str, float]:
    """N steps written by the server, then summed by migration 0012's backfill (timed)."""
    engine = make_engine(url)
    try:
        began = time.perf_counter()
        with engine.begin() as connection:
            connection.execute(text("SELECT setseed(0.5)"))
            player = connection.scalar(text("SELECT id FROM players WHERE name = 'bench-bots'"))
            per_publication = max(1, steps // (2 * session_steps))
            parameters = {"graph": graph_id, "player": player, "length": session_steps}
            stored = connection.execute(
                text(STORED_SESSIONS), {**parameters, "per_publication": per_publication}
            ).rowcount
            connection.execute(text(NUMBERED_SESSIONS), {"graph": graph_id, "stored": stored})
            connection.execute(text(STORED_STEPS), {**parameters, "controls": 3})
        inserted = time.perf_counter() - began
        from alembic import command

        began = time.perf_counter()
        with engine.begin() as connection:
            # the sums 0012 drops are what its upgrade computes again: lost on purpose
            config = alembic_config(connection, drop_data=True)
            command.downgrade(config, BEFORE_SUMS)
            command.upgrade(config, "head")
            connection.execute(text("ANALYZE"))
        return {"insert_s": round(inserted, 2), "backfill_s": round(time.perf_counter() - began, 2)}
    finally:
        engine.dispose()
