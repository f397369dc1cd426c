"""Players as the API sees them (app.services.players): a registration under a name the
server picks, and the player behind a bearer token."""

from __future__ import annotations

import re

import pytest
from sqlalchemy import func, select
from sqlalchemy.orm import Session

from app.core.players.kinds import PlayerKind
from app.models import Player
from app.services.players import RegisteredPlayer, player_for_token, register_player


def players(session: Session) -> int:
    return int(session.scalar(select(func.count()).select_from(Player)) or 0)


@pytest.mark.parametrize("kind", list(PlayerKind))
def test_a_registered_player_is_found_by_its_token_under_a_name_the_server_chose(
    session: Session, kind: PlayerKind
) -> None:
    registered = register_player(session, kind)
    assert isinstance(registered, RegisteredPlayer) and registered.kind is kind
    assert re.fullmatch(rf"{kind.value}-[0-9a-f]{{16}}", registered.name)
    assert player_for_token(session, registered.token) == registered.id
    row = session.get_one(Player, registered.id)
    assert (row.name, row.kind) == (registered.name, kind.value)
    assert registered.token not in row.token_hash  # only its hash is kept


def test_each_registration_is_a_new_player_with_its_own_token(session: Session) -> None:
    first = register_player(session, PlayerKind.PERSON)
    second = register_player(session, PlayerKind.PERSON)
    assert first.id != second.id and first.name != second.name
    assert first.token != second.token
    assert player_for_token(session, first.token) == first.id
    assert player_for_token(session, second.token) == second.id
    assert players(session) == 2


def test_a_token_nobody_was_given_names_no_player(session: Session) -> None:
    register_player(session, PlayerKind.PERSON)
    assert player_for_token(session, "not-a-token") is None
    assert player_for_token(session, "") is None


def test_an_unknown_kind_is_refused_and_registers_nobody(session: Session) -> None:
    with pytest.raises(ValueError, match="'robot' is not a valid PlayerKind"):
        register_player(session, "robot")  # type: ignore[arg-type]
    assert players(session) == 0
