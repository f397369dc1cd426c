"""Each fluid's target: water's is the one its graphs were grown with, the thick one's a band.

The target is scene data (a row of ``FLUIDS``): the thick liquid gets the top of the
tank across its whole width, where the crest of its run-up reaches when a tilt starts
(docs/liquid.md, "A goal for each fluid"; ``tests/kernels/test_high_fluid_validate.py``
simulates that).
"""

from __future__ import annotations

import pytest

from app.core.liquid.scene import FILL_HEIGHT, FLUIDS, Box, tilt_tank

#: the target every low-fluid graph was grown and scored with
WATER_TARGET = Box((0.2, 0.25, 0.0), (0.4, 0.4, 0.16))


@pytest.mark.parametrize("preset", ["tiny", "small", "paper"])
def test_the_low_fluid_keeps_its_target(preset: str) -> None:
    assert tilt_tank(preset).target == WATER_TARGET
    assert tilt_tank(preset, "low").target == WATER_TARGET


@pytest.mark.parametrize("preset", ["tiny", "small", "paper"])
def test_the_high_fluid_target_is_the_top_of_the_tank_wall_to_wall(preset: str) -> None:
    scene = tilt_tank(preset, "high")
    assert scene.target == FLUIDS["high"].target
    assert scene.target == Box((0.0, 0.34, 0.0), scene.tank.hi)
    # far above the level tank's surface: only a tilt's run-up gets there
    assert scene.target.lo[1] > 1.5 * FILL_HEIGHT


def test_every_target_lies_inside_the_tank() -> None:
    for fluid in FLUIDS:
        scene = tilt_tank("tiny", fluid)
        tank, target = scene.tank, scene.target
        assert all(t <= lo for t, lo in zip(tank.lo, target.lo, strict=True))
        assert all(hi <= t for t, hi in zip(tank.hi, target.hi, strict=True))
