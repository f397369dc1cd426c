"""Which dynamics a graph runs: scenes are data, so a graph stores a name, a preset and
(liquid only) a fluid.

The liquid is imported only when asked for: it pulls in PyOpenCL and Mitsuba, and the
API, the CLI and the toy experiments import this module without needing either.
"""

from __future__ import annotations

from app.config import Settings
from app.core.choices import unknown_choice
from app.core.errors import InvalidInput
from app.core.graph.dynamics import Dynamics
from app.core.graph.toy import ToyDynamics
from app.core.liquid.defaults import DEFAULT_FLUID, DEFAULT_LIQUID_PRESET
from app.core.liquid.scene import FLUIDS, TILT_DEGREES, TILT_TANK_SPACINGS
from app.liquid.devices import LiquidDevices

DYNAMICS_NAMES = ("toy", "liquid")
#: presets of the liquid (``app.core.liquid.scene.tilt_tank``), smallest first
LIQUID_PRESETS = tuple(sorted(TILT_TANK_SPACINGS, key=TILT_TANK_SPACINGS.__getitem__, reverse=True))
#: fluids of the liquid (``app.core.liquid.scene.FLUIDS``): the paper's low and high viscosity
LIQUID_FLUIDS = tuple(FLUIDS)


class UnknownDynamics(InvalidInput):
    """A dynamics name srg does not have."""

    @classmethod
    def of(cls, name: str) -> UnknownDynamics:
        return cls(unknown_choice("dynamics", name, DYNAMICS_NAMES))


class UnknownPreset(InvalidInput):
    """A scene preset the liquid does not have."""


class UnknownFluid(InvalidInput):
    """A fluid the liquid does not have."""


def check_liquid_preset(preset: str) -> str:
    """``preset`` itself if the liquid has it; else :class:`UnknownPreset` (one line)."""
    if preset not in LIQUID_PRESETS:
        raise UnknownPreset(unknown_choice("preset", preset, LIQUID_PRESETS))
    return preset


def check_fluid(fluid: str) -> str:
    """``fluid`` itself if the liquid has it; else :class:`UnknownFluid` (one line)."""
    if fluid not in LIQUID_FLUIDS:
        raise UnknownFluid(unknown_choice("fluid", fluid, LIQUID_FLUIDS))
    return fluid


def threshold_in_force(settings: Settings, dynamics: Dynamics) -> float:
    """The high-error threshold every figure uses: ``SRG_HIGH_ERROR_THRESHOLD`` when set
    (to compare graphs of different calibrations on one scale), else the one calibrated
    with the dynamics' scene (docs/threshold.md)."""
    return settings.growth.high_error_threshold or dynamics.high_error_threshold


def control_count(name: str) -> int:
    """The controls N of the dynamics ``name`` (the tank's tilts are the same for every
    preset and fluid), known without building it."""
    if name not in DYNAMICS_NAMES:
        raise UnknownDynamics.of(name)
    return ToyDynamics.n_controls if name == "toy" else len(TILT_DEGREES)


def make_dynamics(
    name: str, preset: str | None = None, fluid: str | None = None, *, devices: LiquidDevices
) -> Dynamics:
    """The dynamics ``name`` with the scene ``preset`` and ``fluid`` (liquid only).

    ``preset`` is ignored by ``toy``; a ``fluid`` given for the toy is refused, as it
    would otherwise be silently dropped. ``devices`` are where the liquid computes and
    renders (the caller's settings: ``LiquidDevices.from_settings``).

    Raises
    ------
    UnknownDynamics, UnknownPreset, UnknownFluid
        A name, preset or fluid that does not exist (all :class:`InvalidInput`).
    InvalidInput
        A fluid for the toy.
    app.liquid.adapter.MissingCalibration
        The liquid preset and fluid have no stored calibration (a ``LookupError``); the
        message names the command that makes one.
    """
    if name == "toy":
        if fluid is not None:
            raise InvalidInput(f"the toy has no fluid (got {fluid!r}); fluids are the liquid's")
        return ToyDynamics()
    if name == "liquid":
        preset = check_liquid_preset(preset or DEFAULT_LIQUID_PRESET)
        fluid = check_fluid(fluid or DEFAULT_FLUID)
        from app.liquid.adapter import LiquidDynamics, MissingCalibration

        try:
            return LiquidDynamics(preset, fluid, devices=devices)
        except MissingCalibration as missing:
            raise MissingCalibration(f"liquid, {fluid} viscosity: {missing}") from None
    raise UnknownDynamics.of(name)
