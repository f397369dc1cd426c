"""Players: a person is called ``person`` (was ``human``), beside ``bot``.

The kind itself is not new: ``players.kind`` has been a NOT NULL column since 0001, and
every writer has always said who played (the web client registered ``human``; `srg
play`, its HTTP path, the experiments, the demo and the ingest benchmark register
``bot``). So no row needs guessing and no server default is added: the existing
``human`` rows are people, renamed; a default would let a writer that forgot to say
who played count as one kind silently, so an insert without a kind still fails.

Downgrade renames people back to ``human``.

Revision ID: 0007
Revises: 0006
Create Date: 2026-11-27 10:00:00
"""

from collections.abc import Sequence

from alembic import op

revision: str = '0007'
down_revision: str | None = '0006'
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None


def _rename_kind(old: str, new: str) -> None:
    """Swap the CHECK constraint's ``old`` for ``new`` and rename the rows in between."""
    with op.batch_alter_table('players') as batch:
        batch.drop_constraint(op.f('ck_players_kind'), type_='check')
    op.execute(f"UPDATE players SET kind = '{new}' WHERE kind = '{old}'")
    with op.batch_alter_table('players') as batch:
        batch.create_check_constraint(op.f('ck_players_kind'), f"kind IN ('{new}', 'bot')")


def upgrade() -> None:
    _rename_kind('human', 'person')


def downgrade() -> None:
    _rename_kind('person', 'human')
