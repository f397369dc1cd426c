"""Growth requests: what became of each growth the admin route accepted; and whether an
epoch renders, so that a re-send of its lost work renders as the epoch did.

Revision ID: 0006
Revises: 0005
Create Date: 2026-11-25 20:40:00
"""

from collections.abc import Sequence

import sqlalchemy as sa
from alembic import op

revision: str = '0006'
down_revision: str | None = '0005'
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None


def upgrade() -> None:
    op.create_table(
        'growth_requests',
        sa.Column('id', sa.Integer(), nullable=False),
        sa.Column('graph_id', sa.Integer(), nullable=False),
        sa.Column('expansions', sa.Integer(), nullable=False),
        sa.Column('runs_on', sa.String(length=16), nullable=False),
        sa.Column('state', sa.String(length=16), nullable=False),
        sa.Column('reason', sa.String(length=500), nullable=True),
        sa.Column('done', sa.Integer(), nullable=False),
        sa.Column('epoch_id', sa.Integer(), nullable=True),
        sa.Column(
            'created_at', sa.DateTime(timezone=True), server_default=sa.func.now(), nullable=False
        ),
        sa.Column('finished_at', sa.DateTime(timezone=True), nullable=True),
        sa.ForeignKeyConstraint(
            ['graph_id'], ['graphs.id'],
            name=op.f('fk_growth_requests_graph_id_graphs'), ondelete='CASCADE',
        ),
        sa.ForeignKeyConstraint(
            ['epoch_id'], ['growth_epochs.id'],
            name=op.f('fk_growth_requests_epoch_id_growth_epochs'), ondelete='SET NULL',
        ),
        sa.PrimaryKeyConstraint('id', name=op.f('pk_growth_requests')),
    )
    op.create_index(
        op.f('ix_growth_requests_graph_id'), 'growth_requests', ['graph_id'], unique=False
    )
    with op.batch_alter_table('growth_epochs') as batch:
        batch.add_column(
            sa.Column('renders', sa.Boolean(), nullable=False, server_default=sa.true())
        )


def downgrade() -> None:
    with op.batch_alter_table('growth_epochs') as batch:
        batch.drop_column('renders')
    op.drop_index(op.f('ix_growth_requests_graph_id'), table_name='growth_requests')
    op.drop_table('growth_requests')
