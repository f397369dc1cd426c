"""Uploads count nothing shared: each trace is numbered and summed by the first reader of
the play sums after it (docs/player-models.md, "What growth reads of the traces").

- ``traces.ordinal``: the trace's place (0, 1, ...) among its graph's sessions, NULL until
  the sums count it. Every trace stored before this revision was counted as it was
  stored, in id order: numbered so here.
- ``ix_traces_publication_id_ordinal``: a publication's uncounted traces, and a batch.

The revision below counted every trace as it was stored, so the downgrade first counts
those not yet counted (numbered after their graph's counted ones, in id order, and added
to the sums: app.store.play_counts's statements written out, so that this migration
stays what it is), then drops the column, whose values are lost (``--drop-data``).

Revision ID: 0013
Revises: 0012
Create Date: 2026-12-08 00:10:00
"""

from collections.abc import Sequence

import sqlalchemy as sa
from alembic import op

revision: str = "0013"
down_revision: str | None = "0012"
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None

NUMBERED = """
UPDATE traces SET ordinal = o.ordinal
FROM (
    SELECT t.id, ROW_NUMBER() OVER (PARTITION BY p.graph_id ORDER BY t.id) - 1 AS ordinal
    FROM traces t JOIN publications p ON p.id = t.publication_id
) o
WHERE o.id = traces.id
"""

#: the uncounted traces, each with its player's kind and the ordinal it is counted under
UNCOUNTED = """(
    SELECT t.id, t.publication_id, t.n_steps, pl.kind,
           COALESCE(g.sessions, 0)
           + ROW_NUMBER() OVER (PARTITION BY p.graph_id ORDER BY t.id) - 1 AS ordinal
    FROM traces t
    JOIN publications p ON p.id = t.publication_id
    JOIN players pl ON pl.id = t.player_id
    LEFT JOIN graph_sessions g ON g.graph_id = p.graph_id
    WHERE t.ordinal IS NULL
) b"""

COUNT_UNCOUNTED = (
    f"""
    INSERT INTO play_counts (publication_id, player_kind, bucket, vertex, control, steps)
    SELECT b.publication_id, b.kind, b.ordinal % 60, s.vertex, s.control, COUNT(*)
    FROM trace_steps s JOIN {UNCOUNTED} ON b.id = s.trace_id
    WHERE true
    GROUP BY b.publication_id, b.kind, b.ordinal % 60, s.vertex, s.control
    ON CONFLICT (publication_id, player_kind, bucket, vertex, control)
    DO UPDATE SET steps = play_counts.steps + excluded.steps
    """,
    f"""
    INSERT INTO play_lengths (publication_id, player_kind, n_steps, sessions)
    SELECT b.publication_id, b.kind, b.n_steps, COUNT(*) FROM {UNCOUNTED}
    WHERE true
    GROUP BY b.publication_id, b.kind, b.n_steps
    ON CONFLICT (publication_id, player_kind, n_steps)
    DO UPDATE SET sessions = play_lengths.sessions + excluded.sessions
    """,
    f"""
    INSERT INTO play_visits (publication_id, player_kind, vertex, sessions)
    SELECT v.publication_id, v.kind, v.vertex, COUNT(*)
    FROM (SELECT DISTINCT s.trace_id, b.publication_id, b.kind, s.vertex
          FROM trace_steps s JOIN {UNCOUNTED} ON b.id = s.trace_id) v
    WHERE true
    GROUP BY v.publication_id, v.kind, v.vertex
    ON CONFLICT (publication_id, player_kind, vertex)
    DO UPDATE SET sessions = play_visits.sessions + excluded.sessions
    """,
    """
    INSERT INTO graph_sessions (graph_id, sessions)
    SELECT p.graph_id, COUNT(*)
    FROM traces t JOIN publications p ON p.id = t.publication_id
    WHERE t.ordinal IS NULL
    GROUP BY p.graph_id
    ON CONFLICT (graph_id) DO UPDATE SET sessions = graph_sessions.sessions + excluded.sessions
    """,
)

INDEX = "ix_traces_publication_id_ordinal"


def upgrade() -> None:
    # in place on SQLite (no batch rebuild: under foreign keys it would cascade)
    op.add_column("traces", sa.Column("ordinal", sa.Integer(), nullable=True))
    op.execute(NUMBERED)
    op.create_index(INDEX, "traces", ["publication_id", "ordinal"])
    if op.get_bind().dialect.name == "postgresql":
        from app.models.comments import COMMENTS

        comment = COMMENTS["traces"][1]["ordinal"].replace("'", "''")
        op.execute(f"COMMENT ON COLUMN traces.ordinal IS '{comment}'")


def downgrade() -> None:
    for statement in COUNT_UNCOUNTED:
        op.execute(statement)
    op.drop_index(INDEX, "traces")
    op.drop_column("traces", "ordinal")
