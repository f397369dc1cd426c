"""Initial schema: graphs, artifacts, publications, players, traces, growth epochs.

Revision ID: 0001
Revises:
Create Date: 2026-11-22 22:06:34.363447
"""

from collections.abc import Sequence

import sqlalchemy as sa
from alembic import op

revision: str = '0001'
down_revision: str | None = None
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None


def upgrade() -> None:
    op.create_table('artifacts',
    sa.Column('hash', sa.String(length=64), nullable=False),
    sa.Column('size', sa.BigInteger(), nullable=False),
    sa.Column('media_type', sa.String(length=100), nullable=False),
    sa.Column('created_at', sa.DateTime(timezone=True), server_default=sa.text('(CURRENT_TIMESTAMP)'), nullable=False),
    sa.PrimaryKeyConstraint('hash', name=op.f('pk_artifacts'))
    )
    op.create_table('graphs',
    sa.Column('id', sa.Integer(), nullable=False),
    sa.Column('name', sa.String(length=200), nullable=False),
    sa.Column('dynamics', sa.String(length=64), nullable=False),
    sa.Column('scene', sa.JSON(), nullable=False),
    sa.Column('n_controls', sa.Integer(), nullable=False),
    sa.Column('frames_per_clip', sa.Integer(), nullable=False),
    sa.Column('seed', sa.Integer(), nullable=False),
    sa.Column('strategy', sa.String(length=32), nullable=False),
    sa.Column('growing', sa.Boolean(), nullable=False),
    sa.Column('revision', sa.Integer(), nullable=False),
    sa.Column('created_at', sa.DateTime(timezone=True), server_default=sa.text('(CURRENT_TIMESTAMP)'), nullable=False),
    sa.PrimaryKeyConstraint('id', name=op.f('pk_graphs')),
    sa.UniqueConstraint('name', name=op.f('uq_graphs_name'))
    )
    op.create_table('players',
    sa.Column('id', sa.Integer(), nullable=False),
    sa.Column('name', sa.String(length=100), nullable=False),
    sa.Column('kind', sa.String(length=8), nullable=False),
    sa.Column('token_hash', sa.String(length=64), nullable=False),
    sa.Column('created_at', sa.DateTime(timezone=True), server_default=sa.text('(CURRENT_TIMESTAMP)'), nullable=False),
    sa.CheckConstraint("kind IN ('human', 'bot')", name=op.f('ck_players_kind')),
    sa.PrimaryKeyConstraint('id', name=op.f('pk_players')),
    sa.UniqueConstraint('name', name=op.f('uq_players_name')),
    sa.UniqueConstraint('token_hash', name=op.f('uq_players_token_hash'))
    )
    op.create_table('clips',
    sa.Column('graph_id', sa.Integer(), nullable=False),
    sa.Column('idx', sa.Integer(), nullable=False),
    sa.Column('source', sa.Integer(), nullable=False),
    sa.Column('control', sa.SmallInteger(), nullable=False),
    sa.Column('kinetic', sa.Double(), nullable=False),
    sa.Column('potential', sa.LargeBinary(), nullable=False),
    sa.Column('score', sa.Double(), nullable=False),
    sa.Column('descriptor', sa.LargeBinary(), nullable=False),
    sa.Column('bundle', sa.String(length=64), nullable=False),
    sa.Column('animation', sa.String(length=64), nullable=True),
    sa.ForeignKeyConstraint(['animation'], ['artifacts.hash'], name=op.f('fk_clips_animation_artifacts')),
    sa.ForeignKeyConstraint(['bundle'], ['artifacts.hash'], name=op.f('fk_clips_bundle_artifacts')),
    sa.ForeignKeyConstraint(['graph_id'], ['graphs.id'], name=op.f('fk_clips_graph_id_graphs'), ondelete='CASCADE'),
    sa.PrimaryKeyConstraint('graph_id', 'idx', name=op.f('pk_clips'))
    )
    op.create_table('growth_epochs',
    sa.Column('id', sa.Integer(), nullable=False),
    sa.Column('graph_id', sa.Integer(), nullable=False),
    sa.Column('number', sa.Integer(), nullable=False),
    sa.Column('strategy', sa.String(length=32), nullable=False),
    sa.Column('status', sa.String(length=16), nullable=False),
    sa.Column('started_at', sa.DateTime(timezone=True), server_default=sa.text('(CURRENT_TIMESTAMP)'), nullable=False),
    sa.Column('finished_at', sa.DateTime(timezone=True), nullable=True),
    sa.Column('expansions', sa.Integer(), nullable=False),
    sa.Column('relinks', sa.Integer(), nullable=False),
    sa.Column('size_frames', sa.Integer(), nullable=False),
    sa.ForeignKeyConstraint(['graph_id'], ['graphs.id'], name=op.f('fk_growth_epochs_graph_id_graphs'), ondelete='CASCADE'),
    sa.PrimaryKeyConstraint('id', name=op.f('pk_growth_epochs')),
    sa.UniqueConstraint('graph_id', 'number', name=op.f('uq_growth_epochs_graph_id_number'))
    )
    op.create_table('publications',
    sa.Column('id', sa.Integer(), nullable=False),
    sa.Column('graph_id', sa.Integer(), nullable=False),
    sa.Column('number', sa.Integer(), nullable=False),
    sa.Column('created_at', sa.DateTime(timezone=True), server_default=sa.text('(CURRENT_TIMESTAMP)'), nullable=False),
    sa.Column('n_vertices', sa.Integer(), nullable=False),
    sa.Column('n_edges', sa.Integer(), nullable=False),
    sa.Column('size_frames', sa.Integer(), nullable=False),
    sa.Column('start', sa.Integer(), nullable=False),
    sa.ForeignKeyConstraint(['graph_id'], ['graphs.id'], name=op.f('fk_publications_graph_id_graphs'), ondelete='CASCADE'),
    sa.PrimaryKeyConstraint('id', name=op.f('pk_publications')),
    sa.UniqueConstraint('graph_id', 'number', name=op.f('uq_publications_graph_id_number'))
    )
    op.create_table('vertices',
    sa.Column('graph_id', sa.Integer(), nullable=False),
    sa.Column('idx', sa.Integer(), nullable=False),
    sa.Column('control', sa.SmallInteger(), nullable=False),
    sa.Column('clip_idx', sa.Integer(), nullable=True),
    sa.ForeignKeyConstraint(['graph_id'], ['graphs.id'], name=op.f('fk_vertices_graph_id_graphs'), ondelete='CASCADE'),
    sa.PrimaryKeyConstraint('graph_id', 'idx', name=op.f('pk_vertices'))
    )
    op.create_table('edges',
    sa.Column('graph_id', sa.Integer(), nullable=False),
    sa.Column('vertex', sa.Integer(), nullable=False),
    sa.Column('control', sa.SmallInteger(), nullable=False),
    sa.Column('kind', sa.SmallInteger(), nullable=False),
    sa.Column('clip_idx', sa.Integer(), nullable=False),
    sa.Column('dst', sa.Integer(), nullable=False),
    sa.Column('target', sa.Integer(), nullable=True),
    sa.Column('err', sa.Double(), nullable=False),
    sa.Column('animation', sa.String(length=64), nullable=True),
    sa.ForeignKeyConstraint(['animation'], ['artifacts.hash'], name=op.f('fk_edges_animation_artifacts')),
    sa.ForeignKeyConstraint(['graph_id', 'vertex'], ['vertices.graph_id', 'vertices.idx'], name=op.f('fk_edges_graph_id_vertex_vertices'), ondelete='CASCADE'),
    sa.ForeignKeyConstraint(['graph_id'], ['graphs.id'], name=op.f('fk_edges_graph_id_graphs'), ondelete='CASCADE'),
    sa.PrimaryKeyConstraint('graph_id', 'vertex', 'control', name=op.f('pk_edges'))
    )
    op.create_table('publication_edges',
    sa.Column('publication_id', sa.Integer(), nullable=False),
    sa.Column('vertex', sa.Integer(), nullable=False),
    sa.Column('control', sa.SmallInteger(), nullable=False),
    sa.Column('dst', sa.Integer(), nullable=False),
    sa.Column('kind', sa.SmallInteger(), nullable=False),
    sa.Column('err', sa.Double(), nullable=False),
    sa.Column('score', sa.Double(), nullable=False),
    sa.Column('animation', sa.String(length=64), nullable=True),
    sa.ForeignKeyConstraint(['animation'], ['artifacts.hash'], name=op.f('fk_publication_edges_animation_artifacts')),
    sa.ForeignKeyConstraint(['publication_id'], ['publications.id'], name=op.f('fk_publication_edges_publication_id_publications'), ondelete='CASCADE'),
    sa.PrimaryKeyConstraint('publication_id', 'vertex', 'control', name=op.f('pk_publication_edges'))
    )
    op.create_table('traces',
    sa.Column('id', sa.Integer(), nullable=False),
    sa.Column('publication_id', sa.Integer(), nullable=False),
    sa.Column('player_id', sa.Integer(), nullable=False),
    sa.Column('idempotency_key', sa.String(length=128), nullable=False),
    sa.Column('created_at', sa.DateTime(timezone=True), server_default=sa.text('(CURRENT_TIMESTAMP)'), nullable=False),
    sa.Column('n_steps', sa.Integer(), nullable=False),
    sa.ForeignKeyConstraint(['player_id'], ['players.id'], name=op.f('fk_traces_player_id_players'), ondelete='CASCADE'),
    sa.ForeignKeyConstraint(['publication_id'], ['publications.id'], name=op.f('fk_traces_publication_id_publications'), ondelete='CASCADE'),
    sa.PrimaryKeyConstraint('id', name=op.f('pk_traces')),
    sa.UniqueConstraint('player_id', 'idempotency_key', name=op.f('uq_traces_player_id_idempotency_key'))
    )
    with op.batch_alter_table('traces', schema=None) as batch_op:
        batch_op.create_index(batch_op.f('ix_traces_publication_id'), ['publication_id'], unique=False)

    op.create_table('trace_steps',
    sa.Column('trace_id', sa.Integer(), nullable=False),
    sa.Column('step', sa.Integer(), nullable=False),
    sa.Column('vertex', sa.Integer(), nullable=False),
    sa.Column('control', sa.SmallInteger(), nullable=False),
    sa.ForeignKeyConstraint(['trace_id'], ['traces.id'], name=op.f('fk_trace_steps_trace_id_traces'), ondelete='CASCADE'),
    sa.PrimaryKeyConstraint('trace_id', 'step', name=op.f('pk_trace_steps'))
    )


def downgrade() -> None:
    op.drop_table('trace_steps')
    with op.batch_alter_table('traces', schema=None) as batch_op:
        batch_op.drop_index(batch_op.f('ix_traces_publication_id'))

    op.drop_table('traces')
    op.drop_table('publication_edges')
    op.drop_table('edges')
    op.drop_table('vertices')
    op.drop_table('publications')
    op.drop_table('growth_epochs')
    op.drop_table('clips')
    op.drop_table('players')
    op.drop_table('graphs')
    op.drop_table('artifacts')
