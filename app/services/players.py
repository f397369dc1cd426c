"""Players as the API sees them: registration and the player behind a bearer token."""

from __future__ import annotations

import secrets
from dataclasses import dataclass

from sqlalchemy.orm import Session

from app.core.players.kinds import PlayerKind
from app.store.traces import get_or_create_player, player_for_token
from app.store.transactions import in_transaction

__all__ = ["RegisteredPlayer", "player_for_token", "register_player"]


@dataclass(frozen=True)
class RegisteredPlayer:
    id: int
    name: str
    kind: PlayerKind
    token: str


def register_player(session: Session, kind: PlayerKind) -> RegisteredPlayer:
    """A fresh player of ``kind`` under a name the server picks, in its own transaction.

    The name is random: registering under a chosen name would let anyone take over an
    existing player by re-issuing its token.
    """
    name = f"{kind}-{secrets.token_hex(8)}"
    player_id, token = in_transaction(session, lambda: get_or_create_player(session, name, kind))
    return RegisteredPlayer(player_id, name, kind, token)
