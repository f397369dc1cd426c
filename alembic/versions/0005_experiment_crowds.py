"""Experiment checkpoints: the crowd (bot kind) that played each row.

A run that reads no traces is played by every crowd of its experiment, so a checkpoint
row is one (strategy, seed, crowd, checkpoint). Rows stored before crowds take the bot
their experiment's plan named.

Revision ID: 0005
Revises: 0004
Create Date: 2026-11-25 17:30:00
"""

from collections.abc import Sequence

import sqlalchemy as sa
from alembic import op

revision: str = '0005'
down_revision: str | None = '0004'
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None

DEFAULT_BOT = 'goal-directed'


def upgrade() -> None:
    with op.batch_alter_table('experiment_checkpoints') as batch:
        batch.add_column(
            sa.Column('bot', sa.String(length=32), nullable=False, server_default=DEFAULT_BOT)
        )
        batch.drop_constraint('uq_experiment_checkpoints_run', type_='unique')
        batch.create_unique_constraint(
            'uq_experiment_checkpoints_run',
            ['experiment_id', 'strategy', 'seed', 'bot', 'checkpoint'],
        )
    experiments = sa.table('experiments', sa.column('id'), sa.column('plan', sa.JSON()))
    checkpoints = sa.table('experiment_checkpoints', sa.column('experiment_id'), sa.column('bot'))
    connection = op.get_bind()
    for experiment, plan in connection.execute(sa.select(experiments.c.id, experiments.c.plan)):
        bot = (plan or {}).get('bot', DEFAULT_BOT)
        if bot != DEFAULT_BOT:
            connection.execute(
                checkpoints.update()
                .where(checkpoints.c.experiment_id == experiment)
                .values(bot=bot)
            )


def downgrade() -> None:
    with op.batch_alter_table('experiment_checkpoints') as batch:
        batch.drop_constraint('uq_experiment_checkpoints_run', type_='unique')
        batch.create_unique_constraint(
            'uq_experiment_checkpoints_run', ['experiment_id', 'strategy', 'seed', 'checkpoint']
        )
        batch.drop_column('bot')
