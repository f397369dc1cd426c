"""Graphs: the crowd player model their growth learns (eq. 2, or eq. 2 under a logit prior).

Revision ID: 0004
Revises: 0003
Create Date: 2026-11-24 04:00:00
"""

from collections.abc import Sequence

import sqlalchemy as sa
from alembic import op

revision: str = '0004'
down_revision: str | None = '0003'
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None


def upgrade() -> None:
    with op.batch_alter_table('graphs') as batch:
        batch.add_column(
            sa.Column('player_model', sa.String(length=16), nullable=False, server_default='eq2')
        )


def downgrade() -> None:
    with op.batch_alter_table('graphs') as batch:
        batch.drop_column('player_model')
