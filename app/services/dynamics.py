"""Which dynamics a graph runs: scenes are data, so a graph stores a name and a preset.

The liquid is imported only when asked for: it pulls in PyOpenCL and Mitsuba, and the
API, the CLI and the toy experiments import this module without needing either.
"""

from __future__ import annotations

from app.core.dynamics import Dynamics
from app.core.scene import TILT_TANK_SPACINGS
from app.core.toy import ToyDynamics

DYNAMICS_NAMES = ("toy", "liquid")
#: presets of the liquid (``app.core.scene.tilt_tank``), smallest first
LIQUID_PRESETS = tuple(sorted(TILT_TANK_SPACINGS, key=TILT_TANK_SPACINGS.__getitem__, reverse=True))
DEFAULT_LIQUID_PRESET = "small"


class UnknownDynamics(ValueError):
    pass


class UnknownPreset(ValueError):
    pass


def check_liquid_preset(preset: str) -> str:
    """``preset`` itself if the liquid has it; else :class:`UnknownPreset` (one line)."""
    if preset not in LIQUID_PRESETS:
        raise UnknownPreset(f"unknown preset {preset!r} (known: {', '.join(LIQUID_PRESETS)})")
    return preset


def make_dynamics(name: str, preset: str | None = None) -> Dynamics:
    """The dynamics ``name`` with the scene ``preset`` (ignored by ``toy``).

    Raises
    ------
    UnknownDynamics, UnknownPreset
        A name or preset that does not exist (both ``ValueError``).
    app.services.liquid.MissingCalibration
        The liquid preset has no stored calibration (a ``LookupError``); the message
        names the command that makes one.
    """
    if name == "toy":
        return ToyDynamics()
    if name == "liquid":
        preset = check_liquid_preset(preset or DEFAULT_LIQUID_PRESET)
        from app.services.liquid import LiquidDynamics, MissingCalibration

        try:
            return LiquidDynamics(preset)
        except MissingCalibration:
            raise MissingCalibration(
                f"no calibration for liquid preset {preset!r}; "
                f"run `srg calibrate --preset {preset}` first"
            ) from None
    raise UnknownDynamics(f"unknown dynamics {name!r} (known: {', '.join(DYNAMICS_NAMES)})")
