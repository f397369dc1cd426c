"""SQL for analysts (docs/analytics.md): the threshold in force stored with each
publication, an edge-kind lookup, two views, and a comment on every table and column.

- ``publications.high_error_threshold``: the high-error threshold in force when the
  publication was made (NULL for those made before: it was not stored).
- ``edge_kinds``: 0 sim, 1 blend, the names of ``app.core.graph.state_graph.EdgeKind``, written out
  here so that this migration stays what it was.
- ``analytics_sessions``: one row per session (trace) with its steps, its error, its
  high-error steps and its player's kind; the means over sessions an analyst needs come
  from it without the join that counts a session once per step.
- ``analytics_steps``: one row per step with the kind and error of the edge taken.
- ``COMMENT ON`` every table and column on PostgreSQL (SQLite keeps no comments): the
  tables' from ``app.models.comments`` (the one place each is said; those of tables and
  columns that exist at this revision), the views' here with their definitions.

SQLite checks a table's views when batch mode rebuilds it: a later migration that
rebuilds traces, trace_steps, publications, publication_edges, players or edge_kinds
there drops the views first and creates them again after.

Revision ID: 0011
Revises: 0010
Create Date: 2026-11-27 15:00:00
"""

from collections.abc import Callable, Sequence

import sqlalchemy as sa
from alembic import op

revision: str = '0011'
down_revision: str | None = '0010'
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None

EDGE_KINDS = [(0, 'sim'), (1, 'blend')]

#: tables of rows this migration writes itself: its downgrade drops them, losing nothing
#: of the user's (app.db.data_loss)
OWN_ROWS = ('edge_kinds',)

ANALYTICS_SESSIONS = """
CREATE VIEW analytics_sessions AS
SELECT t.id AS trace_id,
       t.publication_id,
       p.graph_id,
       p.number AS publication_number,
       t.player_id,
       pl.kind AS player_kind,
       t.created_at,
       COUNT(s.step) AS steps,
       COALESCE(SUM(e.err), 0.0) AS total_error,
       AVG(e.err) AS mean_error,
       SUM(CASE WHEN p.high_error_threshold IS NULL THEN NULL
                WHEN e.err > p.high_error_threshold THEN 1 ELSE 0 END) AS high_error_steps,
       p.high_error_threshold
FROM traces t
JOIN publications p ON p.id = t.publication_id
JOIN players pl ON pl.id = t.player_id
LEFT JOIN trace_steps s ON s.trace_id = t.id
LEFT JOIN publication_edges e
  ON e.publication_id = t.publication_id AND e.vertex = s.vertex AND e.control = s.control
GROUP BY t.id, t.publication_id, p.graph_id, p.number, t.player_id, pl.kind, t.created_at,
         p.high_error_threshold
"""

ANALYTICS_STEPS = """
CREATE VIEW analytics_steps AS
SELECT s.trace_id,
       s.step,
       t.publication_id,
       p.graph_id,
       p.number AS publication_number,
       pl.kind AS player_kind,
       s.vertex,
       s.control,
       e.dst,
       e.kind AS edge_kind,
       k.name AS edge_kind_name,
       e.err,
       CASE WHEN p.high_error_threshold IS NULL THEN NULL
            WHEN e.err > p.high_error_threshold THEN 1 ELSE 0 END AS high_error
FROM trace_steps s
JOIN traces t ON t.id = s.trace_id
JOIN publications p ON p.id = t.publication_id
JOIN players pl ON pl.id = t.player_id
JOIN publication_edges e
  ON e.publication_id = t.publication_id AND e.vertex = s.vertex AND e.control = s.control
LEFT JOIN edge_kinds k ON k.kind = e.kind
"""

#: view -> (what one row is, {column: what it holds})
VIEW_COMMENTS = {
    'analytics_sessions': (
        'One row per session (trace): its steps, its error and its player kind. Means '
        'over steps: SUM(total_error) / SUM(steps), never AVG over a join of steps.',
        {
            'trace_id': 'the session (traces.id)',
            'publication_id': 'the publication played (publications.id)',
            'graph_id': 'the graph (graphs.id)',
            'publication_number': '1, 2, ... per graph',
            'player_id': 'who played (players.id)',
            'player_kind': 'person or bot',
            'created_at': 'when the session was uploaded (UTC)',
            'steps': 'steps of the session',
            'total_error': 'summed error of the edges taken (0 for a session of no steps)',
            'mean_error': 'mean error per step of this session; NULL without steps',
            'high_error_steps': 'steps whose edge error exceeded high_error_threshold; '
            'NULL where the threshold is not known',
            'high_error_threshold': 'the threshold in force when the publication was made',
        },
    ),
    'analytics_steps': (
        'One row per step of a session, with the kind and error of the edge taken.',
        {
            'trace_id': 'the session (traces.id)',
            'step': '0, 1, ... in the session',
            'publication_id': 'the publication played (publications.id)',
            'graph_id': 'the graph (graphs.id)',
            'publication_number': '1, 2, ... per graph',
            'player_kind': 'person or bot',
            'vertex': 'the vertex the player was at',
            'control': 'the control the player took there',
            'dst': 'the vertex the edge led to',
            'edge_kind': '0 sim, 1 blend (edge_kinds.kind)',
            'edge_kind_name': 'sim or blend',
            'err': "the edge's error: 0 for a sim edge, the blend's distance otherwise",
            'high_error': "1 if the edge's error exceeded the publication's threshold, "
            'else 0; NULL where the threshold is not known',
        },
    ),
}


def _literal(text: str) -> str:
    """``text`` as an SQL string literal (COMMENT ON takes no bound parameters)."""
    return "'" + text.replace("'", "''") + "'"


def _comment_everything(comment_of: Callable[[str], str]) -> None:
    """COMMENT ON every table, view and column there is at this revision, with
    ``comment_of(text)`` (the literal, or NULL to take them off)."""
    from app.models.comments import COMMENTS

    bind = op.get_bind()
    inspector = sa.inspect(bind)
    present = set(inspector.get_table_names())
    described = {**COMMENTS, **VIEW_COMMENTS}
    for name, (table_comment, columns) in described.items():
        kind = 'VIEW' if name in VIEW_COMMENTS else 'TABLE'
        if kind == 'TABLE' and name not in present:
            continue
        existing = {column['name'] for column in inspector.get_columns(name)}
        op.execute(f'COMMENT ON {kind} {name} IS {comment_of(table_comment)}')
        for column, comment in columns.items():
            if column in existing:
                op.execute(f'COMMENT ON COLUMN {name}.{column} IS {comment_of(comment)}')


def upgrade() -> None:
    op.add_column('publications', sa.Column('high_error_threshold', sa.Double(), nullable=True))
    edge_kinds = op.create_table(
        'edge_kinds',
        sa.Column('kind', sa.SmallInteger(), autoincrement=False, nullable=False),
        sa.Column('name', sa.String(length=16), nullable=False),
        sa.PrimaryKeyConstraint('kind', name=op.f('pk_edge_kinds')),
        sa.UniqueConstraint('name', name=op.f('uq_edge_kinds_name')),
    )
    op.bulk_insert(edge_kinds, [{'kind': kind, 'name': name} for kind, name in EDGE_KINDS])
    op.execute(ANALYTICS_SESSIONS)
    op.execute(ANALYTICS_STEPS)
    if op.get_bind().dialect.name == 'postgresql':
        _comment_everything(_literal)


def downgrade() -> None:
    if op.get_bind().dialect.name == 'postgresql':
        _comment_everything(lambda text: 'NULL')
    op.execute('DROP VIEW analytics_steps')
    op.execute('DROP VIEW analytics_sessions')
    op.drop_table('edge_kinds')
    # SQLite drops the column in place (3.35+): a batch rebuild drops the table first,
    # which under foreign keys deletes every trace of every publication by cascade
    op.drop_column('publications', 'high_error_threshold')
