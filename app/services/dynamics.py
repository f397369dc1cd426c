"""Which dynamics a graph runs: scenes are data, so a graph stores a name and a preset."""

from __future__ import annotations

from app.core.dynamics import Dynamics
from app.core.toy import ToyDynamics

DYNAMICS_NAMES = ("toy",)


class UnknownDynamics(ValueError):
    pass


def make_dynamics(name: str, preset: str | None = None) -> Dynamics:
    if name == "toy":
        return ToyDynamics()
    raise UnknownDynamics(f"unknown dynamics {name!r} (known: {', '.join(DYNAMICS_NAMES)})")
