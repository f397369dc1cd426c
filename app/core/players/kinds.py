"""Who played: a person or a bot, said once at registration and kept with the player.

Growth learns from everyone's traces, but an operator asks different questions of each:
how people play the game, and whether the bots standing in for them play alike. The
kind is stored with the player (``players.kind``) rather than guessed from a name, so
every trace can be told apart by a join.
"""

from __future__ import annotations

from enum import StrEnum

from app.core.choices import parse_choice


class PlayerKind(StrEnum):
    #: registered by the web client, or by any client that does not say otherwise
    PERSON = "person"
    #: `srg play`, the experiments, the demo and the ingest benchmark
    BOT = "bot"


class PlayerSelection(StrEnum):
    """Whose sessions a figure is computed from (``srg analytics --players``)."""

    PEOPLE = "people"
    BOTS = "bots"
    ALL = "all"

    @property
    def kinds(self) -> tuple[PlayerKind, ...]:
        if self is PlayerSelection.PEOPLE:
            return (PlayerKind.PERSON,)
        if self is PlayerSelection.BOTS:
            return (PlayerKind.BOT,)
        return tuple(PlayerKind)


def parse_player_selection(name: str) -> PlayerSelection:
    """The selection called ``name``; :class:`InvalidInput` naming the known ones otherwise."""
    return parse_choice(PlayerSelection, name, what="players")
