"""Graphs: the world seed of their start state (docs/experiment.md, "World seeds").

Nullable: a graph grown before world seeds started from the dynamics' canonical state,
which is what NULL means.

Revision ID: 0009
Revises: 0008
Create Date: 2026-11-27 04:00:00
"""

from collections.abc import Sequence

import sqlalchemy as sa
from alembic import op

revision: str = '0009'
down_revision: str | None = '0008'
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None


def upgrade() -> None:
    with op.batch_alter_table('graphs') as batch:
        batch.add_column(sa.Column('world', sa.Integer(), nullable=True))


def downgrade() -> None:
    with op.batch_alter_table('graphs') as batch:
        batch.drop_column('world')
