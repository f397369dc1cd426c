"""The strategies growth can follow, by name: what a graph, an experiment and the CLI's
options say, kept apart from the ranking itself so that naming one costs no import of
the numerical code (shell completion reads these)."""

from __future__ import annotations

from enum import StrEnum

from app.core.choices import parse_choice


class Strategy(StrEnum):
    MAX_ERROR = "max-error"
    BASELINE = "baseline"
    SR_HEURISTIC = "sr-heuristic"
    SR_CROWD = "sr-crowd"

    @property
    def uses_staterank(self) -> bool:
        return self in (Strategy.SR_HEURISTIC, Strategy.SR_CROWD)

    @property
    def learns_from_traces(self) -> bool:
        return self is Strategy.SR_CROWD


def parse_strategy(name: str) -> Strategy:
    return parse_choice(Strategy, name, what="strategy")
