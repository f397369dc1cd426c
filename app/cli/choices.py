"""The choices and ranges of ``srg``'s options as Typer reads them: listed in ``--help``,
refused by the parser, completed by the shell.

An option of one choice is annotated with an enum (those of :mod:`app.core`, or the ones
below for the names :mod:`app.services.dynamics` keeps as tuples; tests/cli/test_cli_choices.py
holds the two together). An option of several takes them comma-separated, as the README
writes them (``--bots goal-directed,hesitant``): :func:`choice_list` parses each element,
refuses an unknown one in one line and completes the element being typed.
"""

from __future__ import annotations

import math
from enum import StrEnum
from typing import Any, TypeVar

import typer

from app.core.choices import unknown_choice
from app.core.errors import InvalidInput

E = TypeVar("E", bound=StrEnum)


class DynamicsName(StrEnum):
    """``app.services.dynamics.DYNAMICS_NAMES``."""

    TOY = "toy"
    LIQUID = "liquid"


class LiquidPreset(StrEnum):
    """``app.services.dynamics.LIQUID_PRESETS``, smallest first."""

    TINY = "tiny"
    SMALL = "small"
    PAPER = "paper"


class Fluid(StrEnum):
    """``app.services.dynamics.LIQUID_FLUIDS``: the paper's low and high viscosity."""

    LOW = "low"
    HIGH = "high"


class LogLevel(StrEnum):
    """The levels Celery's ``--loglevel`` takes."""

    DEBUG = "DEBUG"
    INFO = "INFO"
    WARNING = "WARNING"
    ERROR = "ERROR"
    CRITICAL = "CRITICAL"


def positive_finite(value: float | None) -> float | None:
    """The callback of a float option that must be above 0 and finite (typer's ``min`` is
    inclusive and lets ``inf`` through)."""
    if value is not None and not 0 < value < math.inf:
        raise typer.BadParameter(f"must be a finite number above 0, got {value}")
    return value


def positive_ints(option: str, value: str) -> list[int]:
    """A comma-separated list of positive integers, or a one-line error."""
    message = f"{option} takes comma-separated positive integers, got {value!r}"
    try:
        numbers = [int(part) for part in value.split(",")]
    except ValueError:
        raise InvalidInput(message) from None
    if any(n <= 0 for n in numbers):
        raise InvalidInput(message)
    return numbers


def value_of(choice: StrEnum | None) -> str | None:
    """The plain string of an optional choice, as the services take it."""
    return None if choice is None else choice.value


class _ChoiceList:
    """Parse and complete a comma-separated list of ``kind``'s values."""

    def __init__(self, kind: type[StrEnum], what: str) -> None:
        self.kind = kind
        self.what = what

    def parse(self, value: str) -> tuple[StrEnum, ...]:
        known = [member.value for member in self.kind]
        chosen = []
        for name in value.split(","):
            name = name.strip()
            if name not in known:
                raise typer.BadParameter(unknown_choice(self.what, name, known))
            chosen.append(self.kind(name))
        return tuple(chosen)

    def complete(self, incomplete: str) -> list[str]:
        """The choices the element being typed may become, after those already typed."""
        typed, comma, last = incomplete.rpartition(",")
        return [
            f"{typed}{comma}{member.value}" for member in self.kind if member.value.startswith(last)
        ]


def choice_list(kind: type[E], *, what: str, help: str) -> Any:  # noqa: A002 (typer's name)
    """A ``typer.Option`` (default ``None``) of comma-separated ``kind`` values; annotate
    the parameter ``Sequence[kind] | None``."""
    values = [member.value for member in kind]
    parser = _ChoiceList(kind, what)
    return typer.Option(
        None,
        parser=parser.parse,
        autocompletion=parser.complete,
        metavar=f"{what.upper()},...",  # the help lists the values: no fold mid-word
        help=f"{help} (comma-separated: {', '.join(values)})",
    )


def seed_list(text: str, option: str) -> tuple[int, ...]:
    """Comma-separated integer seeds, as ``--seeds 20,21`` writes them."""
    try:
        return tuple(int(s) for s in text.split(","))
    except ValueError:
        raise InvalidInput(f"{option} must be comma-separated integers, got {text!r}") from None
