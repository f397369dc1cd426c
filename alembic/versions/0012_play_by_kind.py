"""The play sums by player kind, the sessions per vertex, and each session's error
(docs/analytics.md, "What analytics reads").

``srg analytics`` answers for people, bots or both, from sums rather than steps:

- ``play_counts`` and ``play_lengths`` gain ``player_kind`` in their keys;
- ``play_visits``: the sessions per (publication, player kind, vertex) that stepped there;
- ``traces.error``: the summed error of the session's steps on its publication, and
  ``traces.high_error_steps``: its steps above the publication's stored threshold (NULL
  where the publication stored none).

The tables are created again and filled from the stored steps in SQL, sessions numbered
in their graph by id as migration 0010 numbered them (the 60 buckets written out, as
there). Downgrading fills the old tables from the steps the same way.

Revision ID: 0012
Revises: 0011
Create Date: 2026-11-27 17:00:00
"""

from collections.abc import Sequence

import sqlalchemy as sa
from alembic import op

revision: str = '0012'
down_revision: str | None = '0011'
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None

#: each trace with its publication, its player's kind and its ordinal in the graph
NUMBERED = """
    SELECT t.id, t.publication_id, pl.kind,
           ROW_NUMBER() OVER (PARTITION BY p.graph_id ORDER BY t.id) - 1 AS ordinal
    FROM traces t
    JOIN publications p ON p.id = t.publication_id
    JOIN players pl ON pl.id = t.player_id
"""

BACKFILL = (
    f"""
    INSERT INTO play_counts (publication_id, player_kind, bucket, vertex, control, steps)
    SELECT o.publication_id, o.kind, o.ordinal % 60, s.vertex, s.control, COUNT(*)
    FROM trace_steps s JOIN ({NUMBERED}) o ON o.id = s.trace_id
    GROUP BY o.publication_id, o.kind, o.ordinal % 60, s.vertex, s.control
    """,
    """
    INSERT INTO play_lengths (publication_id, player_kind, n_steps, sessions)
    SELECT t.publication_id, pl.kind, t.n_steps, COUNT(*)
    FROM traces t JOIN players pl ON pl.id = t.player_id
    GROUP BY t.publication_id, pl.kind, t.n_steps
    """,
    """
    INSERT INTO play_visits (publication_id, player_kind, vertex, sessions)
    SELECT t.publication_id, pl.kind, v.vertex, COUNT(*)
    FROM (SELECT DISTINCT trace_id, vertex FROM trace_steps) v
    JOIN traces t ON t.id = v.trace_id
    JOIN players pl ON pl.id = t.player_id
    GROUP BY t.publication_id, pl.kind, v.vertex
    """,
    """
    UPDATE traces SET error = a.error, high_error_steps = a.high_error_steps
    FROM (
        SELECT s.trace_id, SUM(e.err) AS error,
               CASE WHEN MAX(p.high_error_threshold) IS NULL THEN NULL
                    ELSE SUM(CASE WHEN e.err > p.high_error_threshold THEN 1 ELSE 0 END)
               END AS high_error_steps
        FROM trace_steps s
        JOIN traces t ON t.id = s.trace_id
        JOIN publications p ON p.id = t.publication_id
        JOIN publication_edges e
          ON e.publication_id = t.publication_id AND e.vertex = s.vertex
             AND e.control = s.control
        GROUP BY s.trace_id
    ) a
    WHERE a.trace_id = traces.id
    """,
)

#: migration 0010's backfill of the tables without kinds, for the downgrade
BACKFILL_WITHOUT_KINDS = (
    f"""
    INSERT INTO play_counts (publication_id, bucket, vertex, control, steps)
    SELECT o.publication_id, o.ordinal % 60, s.vertex, s.control, COUNT(*)
    FROM trace_steps s JOIN ({NUMBERED}) o ON o.id = s.trace_id
    GROUP BY o.publication_id, o.ordinal % 60, s.vertex, s.control
    """,
    """
    INSERT INTO play_lengths (publication_id, n_steps, sessions)
    SELECT publication_id, n_steps, COUNT(*) FROM traces GROUP BY publication_id, n_steps
    """,
)

#: the tables this migration creates (or creates again): its comments' subjects
CREATED = ('play_counts', 'play_lengths', 'play_visits')


def _publication_key(table: str) -> sa.ForeignKeyConstraint:
    return sa.ForeignKeyConstraint(
        ['publication_id'],
        ['publications.id'],
        name=op.f(f'fk_{table}_publication_id_publications'),
        ondelete='CASCADE',
    )


def _create_tables(*, kinds: bool) -> None:
    """play_counts and play_lengths with ``player_kind`` in their keys, or as 0010 made them."""
    kind = [sa.Column('player_kind', sa.String(length=8), nullable=False)] if kinds else []
    kind_key = ['player_kind'] if kinds else []
    op.create_table(
        'play_counts',
        sa.Column('publication_id', sa.Integer(), nullable=False),
        *kind,
        sa.Column('bucket', sa.SmallInteger(), nullable=False),
        sa.Column('vertex', sa.Integer(), nullable=False),
        sa.Column('control', sa.SmallInteger(), nullable=False),
        sa.Column('steps', sa.BigInteger(), nullable=False),
        _publication_key('play_counts'),
        sa.PrimaryKeyConstraint(
            'publication_id', *kind_key, 'bucket', 'vertex', 'control',
            name=op.f('pk_play_counts'),
        ),
    )
    kind = [sa.Column('player_kind', sa.String(length=8), nullable=False)] if kinds else []
    op.create_table(
        'play_lengths',
        sa.Column('publication_id', sa.Integer(), nullable=False),
        *kind,
        sa.Column('n_steps', sa.Integer(), nullable=False),
        sa.Column('sessions', sa.BigInteger(), nullable=False),
        _publication_key('play_lengths'),
        sa.PrimaryKeyConstraint(
            'publication_id', *kind_key, 'n_steps', name=op.f('pk_play_lengths')
        ),
    )


def _literal(text: str) -> str:
    return "'" + text.replace("'", "''") + "'"


def _comment_created() -> None:
    """COMMENT ON the tables this migration creates, or creates again, and on their
    columns there are (PostgreSQL; from ``app.models.comments``, as 0011)."""
    from app.models.comments import COMMENTS

    inspector = sa.inspect(op.get_bind())
    present = set(inspector.get_table_names())
    for table in CREATED:
        if table not in present:
            continue
        table_comment, columns = COMMENTS[table]
        existing = {column['name'] for column in inspector.get_columns(table)}
        op.execute(f'COMMENT ON TABLE {table} IS {_literal(table_comment)}')
        for column, comment in columns.items():
            if column in existing:
                op.execute(f'COMMENT ON COLUMN {table}.{column} IS {_literal(comment)}')


def upgrade() -> None:
    op.drop_table('play_lengths')
    op.drop_table('play_counts')
    _create_tables(kinds=True)
    op.create_table(
        'play_visits',
        sa.Column('publication_id', sa.Integer(), nullable=False),
        sa.Column('player_kind', sa.String(length=8), nullable=False),
        sa.Column('vertex', sa.Integer(), nullable=False),
        sa.Column('sessions', sa.BigInteger(), nullable=False),
        _publication_key('play_visits'),
        sa.PrimaryKeyConstraint(
            'publication_id', 'player_kind', 'vertex', name=op.f('pk_play_visits')
        ),
    )
    # in place on SQLite (no batch rebuild: under foreign keys it would cascade)
    op.add_column(
        'traces', sa.Column('error', sa.Double(), server_default=sa.text('0'), nullable=False)
    )
    op.add_column('traces', sa.Column('high_error_steps', sa.Integer(), nullable=True))
    for statement in BACKFILL:
        op.execute(statement)
    if op.get_bind().dialect.name == 'postgresql':
        _comment_created()
        from app.models.comments import COMMENTS

        for column in ('error', 'high_error_steps'):
            op.execute(f'COMMENT ON COLUMN traces.{column} IS {_literal(COMMENTS["traces"][1][column])}')


def downgrade() -> None:
    op.drop_column('traces', 'high_error_steps')
    op.drop_column('traces', 'error')
    op.drop_table('play_visits')
    op.drop_table('play_lengths')
    op.drop_table('play_counts')
    _create_tables(kinds=False)
    for statement in BACKFILL_WITHOUT_KINDS:
        op.execute(statement)
    if op.get_bind().dialect.name == 'postgresql':
        _comment_created()
