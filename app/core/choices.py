"""Words a user picks from a fixed set (a strategy, a bot, a preset): one refusal for all.

The refusal names the set, so the one line the CLI prints (or the API's 422 body) says
what would have been accepted.
"""

from __future__ import annotations

from collections.abc import Iterable
from enum import StrEnum
from typing import TypeVar

from app.core.errors import InvalidInput

E = TypeVar("E", bound=StrEnum)


def unknown_choice(what: str, name: str, known: Iterable[str]) -> str:
    """The message refusing ``name`` as a ``what``, naming the ones ``known``."""
    return f"unknown {what} {name!r} (known: {', '.join(known)})"


def parse_choice(kind: type[E], name: str, *, what: str) -> E:
    """The member of ``kind`` called ``name``; :class:`InvalidInput` naming them otherwise."""
    try:
        return kind(name)
    except ValueError:
        raise InvalidInput(unknown_choice(what, name, (k.value for k in kind))) from None
