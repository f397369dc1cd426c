"""The liquid solver seam (docs/sph.md, "Solvers"): a scene names its solver, the solver
is made by that name, and the clip key and the calibration say which solver made them."""

from __future__ import annotations

import hashlib
import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from app.core.errors import InvalidInput
from app.core.liquid.scene import tilt_tank
from app.kernels.pcisph import PcisphSolver
from app.kernels.solvers import SOLVERS, make_solver
from app.liquid.adapter import (
    LiquidDynamics,
    MissingCalibration,
    calibration_path,
    load_calibration,
)

TINY = tilt_tank("tiny")
#: sha256 of a settled tank, a clip and a batch of three clips (below), computed with the
#: solver before it had a name (``SphSimulator`` of ``app/kernels/sph.py``): naming it and
#: putting it behind the seam moved no bit of any frame
FRAMES_BEFORE_THE_SEAM = "25085137f4a64beb14f4d5b5695ff8a307ef10034194a90a6f86693bd136bd07"


def test_every_preset_names_a_solver_srg_has() -> None:
    for preset in ("tiny", "small", "paper"):
        for fluid in ("low", "high"):
            assert tilt_tank(preset, fluid).solver in SOLVERS
    assert dict(SOLVERS) == {"pcisph": PcisphSolver}


def test_the_named_solver_makes_the_frames_it_made_before_it_had_a_name() -> None:
    sim = make_solver(TINY, batch=3)
    assert isinstance(sim, PcisphSolver)
    rest = sim.settle(seconds=0.4, damped_seconds=0.2, world=20)
    frames, end = sim.simulate_clip(rest, 1)
    positions, ends = sim.run_batch([rest, end, rest], [2, 0, 1], 4)
    digest = hashlib.sha256()
    for array in (rest, frames, end, positions, ends):
        digest.update(np.ascontiguousarray(array).tobytes())
    assert digest.hexdigest() == FRAMES_BEFORE_THE_SEAM


def test_a_scene_naming_a_solver_srg_lacks_is_refused_in_one_line() -> None:
    with pytest.raises(InvalidInput) as refused:
        make_solver(replace(TINY, solver="dfsph"))
    assert str(refused.value) == (
        "scene 'tilt-tank/tiny' names the liquid solver 'dfsph'; srg has pcisph"
    )


def test_the_clip_key_changes_with_the_solver() -> None:
    pcisph = LiquidDynamics("tiny")
    other = LiquidDynamics("tiny")
    other.scene = replace(other.scene, solver="dfsph")
    assert pcisph.simulation_identity != other.simulation_identity
    again = LiquidDynamics("tiny")
    assert pcisph.simulation_identity == again.simulation_identity


@pytest.mark.parametrize(
    ("solver", "said"), [("dfsph", "measured with dfsph"), (None, "an unrecorded solver")]
)
def test_a_calibration_of_another_solver_is_refused(
    tmp_path: Path, solver: str | None, said: str
) -> None:
    stored = json.loads(calibration_path("tiny").read_text())
    assert stored["solver"] == "pcisph"
    if solver is None:
        del stored["solver"]
    else:
        stored["solver"] = solver
    calibration_path("tiny", directory=tmp_path).write_text(json.dumps(stored))
    with pytest.raises(MissingCalibration, match=f"{said}, the scene now takes pcisph; run srg"):
        load_calibration("tiny", directory=tmp_path)
    stored["solver"] = "pcisph"
    calibration_path("tiny", directory=tmp_path).write_text(json.dumps(stored))
    assert load_calibration("tiny", directory=tmp_path) == load_calibration("tiny")
