"""Player registration: a fresh player and its bearer token.

The server picks the name: registering under a chosen name would let anyone take over
an existing player by re-issuing its token. Registrations are rate-limited per client
address (``registration_rate``), so fresh players cannot multiply the upload limit nor
grow the players table without bound. A player is a person unless the body says ``bot``
(the web client says ``person``, every bot ``bot``), so analytics can tell them apart.
"""

from __future__ import annotations

from fastapi import APIRouter, Depends
from sqlalchemy.orm import Session

from app.api.deps import get_session
from app.api.errors import error_responses
from app.api.ratelimit import limited_registration
from app.api.schemas import PlayerCreated, PlayerRequest
from app.core.players.kinds import PlayerKind
from app.services.players import register_player as register

router = APIRouter(prefix="/api/players", tags=["players"])


@router.post(
    "",
    status_code=201,
    dependencies=[Depends(limited_registration)],
    responses=error_responses(400, 413, 422, 429, s429="over the address's registration rate"),
)
def register_player(
    body: PlayerRequest | None = None, session: Session = Depends(get_session)
) -> PlayerCreated:
    """Register a player (a person unless the body says bot): its id and the token its
    trace uploads carry."""
    player = register(session, body.kind if body else PlayerKind.PERSON)
    return PlayerCreated(
        player_id=player.id, name=player.name, kind=player.kind, token=player.token
    )
