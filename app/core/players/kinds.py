"""The kinds of players, by name: who played (a person or a bot), which bot, and which
crowd model sr-crowd learns. Kept apart from the policies and the models, so that naming
one (a stored row, a CLI option, a shell completion) imports none of the numerics.

Who played is said once at registration and kept with the player.

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


class BotKind(StrEnum):
    GOAL_DIRECTED = "goal-directed"
    HEURISTIC = "heuristic"
    RANDOM = "random"
    HESITANT = "hesitant"
    AVOIDER = "avoider"


def parse_bot(name: str) -> BotKind:
    """The bot called ``name``; :class:`InvalidInput` naming the known ones otherwise."""
    return parse_choice(BotKind, name, what="bot")


class PlayerModelKind(StrEnum):
    """The crowd model sr-crowd learns: the product's choices (docs/player-models.md), each
    an estimator in app.core.players.crowd_models. Candidates that lost their selection left it."""

    #: the paper's kernel density estimate, with its eps prior (crowd_models.eq2)
    EQ2 = "eq2"
    #: eq. 2's kernel counts over the heuristic model as a prior (crowd_models.shrunk)
    SHRUNK = "shrunk"
    #: ``shrunk``'s P(c|v) with heuristic players mixed in (crowd_models.mixed)
    MIXED = "mixed"
    #: ``mixed``, its share of heuristic players chosen where players met error
    #: (crowd_models.mixed_error)
    MIXED_ERROR = "mixed-error"


def parse_player_model(name: str) -> PlayerModelKind:
    """The player model called ``name``; :class:`InvalidInput` naming the known ones otherwise."""
    return parse_choice(PlayerModelKind, name, what="player model")
