"""The crowd's play summed as traces are accepted (docs/player-models.md, "What growth
reads of the traces").

``graph_sessions`` numbers each graph's sessions (the next ordinal); ``play_counts`` holds
the steps per (publication, bucket of the session's ordinal, vertex, control);
``play_lengths`` the sessions per (publication, length). Existing traces are numbered in
their graph by id, as growth dealt them to folds until now, and summed from their steps
in SQL. The 60 buckets are ``app.core.players.crowd_play.FOLD_BUCKETS``, written out here so that
this migration stays what it was.

Revision ID: 0010
Revises: 0009
Create Date: 2026-11-27 12:00:00
"""

from collections.abc import Sequence

import sqlalchemy as sa
from alembic import op

revision: str = '0010'
down_revision: str | None = '0009'
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None

BACKFILL = (
    """
    INSERT INTO graph_sessions (graph_id, sessions)
    SELECT p.graph_id, COUNT(*)
    FROM traces t JOIN publications p ON p.id = t.publication_id
    GROUP BY p.graph_id
    """,
    """
    INSERT INTO play_counts (publication_id, bucket, vertex, control, steps)
    SELECT o.publication_id, o.ordinal % 60, s.vertex, s.control, COUNT(*)
    FROM trace_steps s
    JOIN (
        SELECT t.id, t.publication_id,
               ROW_NUMBER() OVER (PARTITION BY p.graph_id ORDER BY t.id) - 1 AS ordinal
        FROM traces t JOIN publications p ON p.id = t.publication_id
    ) o ON o.id = s.trace_id
    GROUP BY o.publication_id, o.ordinal % 60, s.vertex, s.control
    """,
    """
    INSERT INTO play_lengths (publication_id, n_steps, sessions)
    SELECT publication_id, n_steps, COUNT(*) FROM traces GROUP BY publication_id, n_steps
    """,
)


def upgrade() -> None:
    op.create_table(
        'graph_sessions',
        sa.Column('graph_id', sa.Integer(), nullable=False),
        sa.Column('sessions', sa.Integer(), nullable=False),
        sa.ForeignKeyConstraint(
            ['graph_id'],
            ['graphs.id'],
            name=op.f('fk_graph_sessions_graph_id_graphs'),
            ondelete='CASCADE',
        ),
        sa.PrimaryKeyConstraint('graph_id', name=op.f('pk_graph_sessions')),
    )
    op.create_table(
        'play_counts',
        sa.Column('publication_id', sa.Integer(), nullable=False),
        sa.Column('bucket', sa.SmallInteger(), nullable=False),
        sa.Column('vertex', sa.Integer(), nullable=False),
        sa.Column('control', sa.SmallInteger(), nullable=False),
        sa.Column('steps', sa.BigInteger(), nullable=False),
        sa.ForeignKeyConstraint(
            ['publication_id'],
            ['publications.id'],
            name=op.f('fk_play_counts_publication_id_publications'),
            ondelete='CASCADE',
        ),
        sa.PrimaryKeyConstraint(
            'publication_id', 'bucket', 'vertex', 'control', name=op.f('pk_play_counts')
        ),
    )
    op.create_table(
        'play_lengths',
        sa.Column('publication_id', sa.Integer(), nullable=False),
        sa.Column('n_steps', sa.Integer(), nullable=False),
        sa.Column('sessions', sa.BigInteger(), nullable=False),
        sa.ForeignKeyConstraint(
            ['publication_id'],
            ['publications.id'],
            name=op.f('fk_play_lengths_publication_id_publications'),
            ondelete='CASCADE',
        ),
        sa.PrimaryKeyConstraint('publication_id', 'n_steps', name=op.f('pk_play_lengths')),
    )
    for statement in BACKFILL:
        op.execute(statement)


def downgrade() -> None:
    op.drop_table('play_lengths')
    op.drop_table('play_counts')
    op.drop_table('graph_sessions')
