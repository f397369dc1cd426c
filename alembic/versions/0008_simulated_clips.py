"""Simulated clips: each (dynamics, start state, control) is simulated once per database.

A new table and nothing else: graphs grown before simply have no entries, and their
next simulations fill it.

Revision ID: 0008
Revises: 0007
Create Date: 2026-11-26 04:00:00
"""

from collections.abc import Sequence

import sqlalchemy as sa
from alembic import op

revision: str = '0008'
down_revision: str | None = '0007'
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None


def upgrade() -> None:
    op.create_table(
        'simulated_clips',
        sa.Column('key', sa.String(length=64), nullable=False),
        sa.Column('clip', sa.String(length=64), nullable=False),
        sa.Column(
            'created_at', sa.DateTime(timezone=True), server_default=sa.func.now(), nullable=False
        ),
        sa.PrimaryKeyConstraint('key', name=op.f('pk_simulated_clips')),
    )


def downgrade() -> None:
    op.drop_table('simulated_clips')
