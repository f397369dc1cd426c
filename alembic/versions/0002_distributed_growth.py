"""Distributed growth: an epoch's plan, warm start and heartbeat; expansion clips.

Revision ID: 0002
Revises: 0001
Create Date: 2026-11-24 10:00:00.000000
"""

from collections.abc import Sequence

import sqlalchemy as sa
from alembic import op

revision: str = '0002'
down_revision: str | None = '0001'
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None


def upgrade() -> None:
    with op.batch_alter_table('growth_epochs') as batch:
        batch.add_column(sa.Column('plan', sa.JSON(), nullable=True))
        batch.add_column(sa.Column('warm_start', sa.String(length=64), nullable=True))
        batch.add_column(sa.Column('heartbeat', sa.Double(), nullable=True))
        batch.create_foreign_key(
            op.f('fk_growth_epochs_warm_start_artifacts'), 'artifacts', ['warm_start'], ['hash']
        )
    op.create_table('expansion_clips',
    sa.Column('epoch_id', sa.Integer(), nullable=False),
    sa.Column('position', sa.Integer(), nullable=False),
    sa.Column('control', sa.SmallInteger(), nullable=False),
    sa.Column('clip', sa.String(length=64), nullable=False),
    sa.Column('animation', sa.String(length=64), nullable=True),
    sa.ForeignKeyConstraint(['animation'], ['artifacts.hash'], name=op.f('fk_expansion_clips_animation_artifacts')),
    sa.ForeignKeyConstraint(['clip'], ['artifacts.hash'], name=op.f('fk_expansion_clips_clip_artifacts')),
    sa.ForeignKeyConstraint(['epoch_id'], ['growth_epochs.id'], name=op.f('fk_expansion_clips_epoch_id_growth_epochs'), ondelete='CASCADE'),
    sa.PrimaryKeyConstraint('epoch_id', 'position', 'control', name=op.f('pk_expansion_clips'))
    )


def downgrade() -> None:
    op.drop_table('expansion_clips')
    with op.batch_alter_table('growth_epochs') as batch:
        batch.drop_constraint(op.f('fk_growth_epochs_warm_start_artifacts'), type_='foreignkey')
        batch.drop_column('heartbeat')
        batch.drop_column('warm_start')
        batch.drop_column('plan')
