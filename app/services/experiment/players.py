"""Who plays an experiment's runs, by label: its crowds, their fresh judges, other judges,
and the populations judged on their members' steps together (docs/experiment.md,
"Judges")."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from fractions import Fraction
from typing import Any

import numpy as np

from app.core.errors import InvalidInput
from app.core.players.kinds import BotKind

#: the label of a fresh judge of a crowd's kind is the kind's name after this
FRESH = "fresh-"
#: the label of a pooled crowd's sessions taken together (and, after :data:`FRESH`, of
#: its fresh judges' sessions taken together)
POPULATION = "population"


@dataclass(frozen=True)
class PlayerGroup:
    """Sessions of one bot kind measured at every checkpoint of a run, under ``label``:
    a crowd's (``stored``: its traces teach a run that learns) or a judge's."""

    label: str
    bot: BotKind
    sessions: int
    stored: bool

    @property
    def fresh(self) -> bool:
        """A crowd's fresh judges: its kind on other seeds."""
        return self.label.startswith(FRESH)


def kind_of(label: str) -> str:
    """The bot kind of a player label (a fresh judge's is its crowd's)."""
    return label.removeprefix(FRESH)


def with_populations(
    populations: Mapping[str, tuple[str, ...]], steps: Mapping[tuple[Any, ...], np.ndarray]
) -> dict[tuple[Any, ...], np.ndarray]:
    """``steps`` (keyed by player label first) with each population's: its members' steps
    together wherever every member played, so that a kind weighs by the steps it took."""
    together = dict(steps)
    for label, members in populations.items():
        for key in [k for k in steps if k[0] == members[0]]:
            keys = [(member, *key[1:]) for member in members]
            if all(k in steps for k in keys):
                together[(label, *key[1:])] = np.concatenate([steps[k] for k in keys])
    return together


def check_shares(shares: Sequence[float], crowds: int, sessions: int, *, pooled: bool) -> None:
    """Shares are given for pooled crowds, one each, positive, summing to one, and each a
    whole number of a checkpoint's sessions, so that the mix is kept exactly."""
    if not pooled or len(shares) != crowds:
        raise InvalidInput("--shares gives one share per crowd of pooled crowds (--pooled)")
    if not all(share > 0 for share in shares) or not abs(sum(shares) - 1.0) <= 1e-9:
        listed = ", ".join(f"{share:g}" for share in shares)
        raise InvalidInput(f"shares must be positive and sum to 1, got {listed}")
    for share in shares:
        if _fraction(share) * sessions % 1:
            raise InvalidInput(
                f"a share of {share:g} of {sessions} sessions is not a whole number of "
                "sessions: choose shares and --sessions that give whole sessions"
            )


def share_sessions(share: float, sessions: int) -> int:
    """The whole sessions ``share`` of ``sessions`` is (:func:`check_shares` held)."""
    return int(_fraction(share) * sessions)


def _fraction(share: float) -> Fraction:
    """A share as the fraction it was meant as (0.3 is not exactly 3/10 in binary)."""
    return Fraction(share).limit_denominator(10_000)
