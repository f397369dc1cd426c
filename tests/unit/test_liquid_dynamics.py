"""LiquidDynamics on the tiny preset: the Dynamics contract on real simulated clips."""

from __future__ import annotations

import json
from dataclasses import asdict
from pathlib import Path

import numpy as np
import pytest

from app.config import RenderSettings, RuntimeSettings, Settings
from app.core.graph.dynamics import Dynamics, SimClip
from app.core.liquid.scene import tilt_tank
from app.core.liquid.surface import dequantise_sdf, liquid_volumes, occupancy
from app.liquid.adapter import (
    CALIBRATION_DIR,
    LiquidDynamics,
    MissingCalibration,
    calibration_path,
    load_calibration,
    stepping,
)
from app.liquid.devices import LiquidDevices


@pytest.fixture(scope="module")
def dyn() -> LiquidDynamics:
    return LiquidDynamics("tiny")


@pytest.fixture(scope="module")
def rest(dyn: LiquidDynamics) -> np.ndarray:
    return dyn.initial_state()


@pytest.fixture(scope="module")
def tilted(dyn: LiquidDynamics, rest: np.ndarray) -> SimClip:
    return dyn.simulate(rest, 1)


def volumes(dyn: LiquidDynamics, frames: np.ndarray) -> np.ndarray:
    return liquid_volumes(dyn.grid, occupancy(dyn.grid, dequantise_sdf(dyn.grid, frames)))


def test_satisfies_the_protocol_with_calibrated_constants(dyn: LiquidDynamics) -> None:
    assert isinstance(dyn, Dynamics)
    stored = load_calibration("tiny")
    assert dyn.rest_kinetic > 0 and stored.energy_weight > 0
    assert dyn.crowd_radius > 0 and dyn.high_error_threshold > 0


def test_clip_frames_are_quantised_sdfs_and_features_are_consistent(
    dyn: LiquidDynamics, rest: np.ndarray, tilted: SimClip
) -> None:
    assert tilted.frames.dtype == np.int8
    assert tilted.frames.shape == (dyn.frames_per_clip, *dyn.grid.shape)
    assert tilted.end_state.shape == rest.shape
    f = dyn.features(tilted)
    assert f.occupancy.dtype == np.uint8 and f.descriptor.shape == (216,)
    assert f.kinetic > dyn.rest_kinetic and f.potential.shape == (3,)
    # the liquid keeps its volume (within the surface reconstruction's few per cent)
    np.testing.assert_allclose(
        volumes(dyn, tilted.frames), volumes(dyn, tilted.frames)[0], rtol=0.08
    )
    assert dyn.dist(f, f, 1) == 0.0
    # what the store derives from the stored frames is what the features hold
    occupancy, descriptor = dyn.shape(tilted.frames.copy())
    np.testing.assert_array_equal(occupancy, f.occupancy)
    np.testing.assert_array_equal(descriptor, f.descriptor)


def test_an_expansions_clips_together_are_each_clip_alone(
    dyn: LiquidDynamics, rest: np.ndarray, tilted: SimClip
) -> None:
    """More clips than one batch holds (two batches), from two states: each is
    :meth:`simulate`'s clip, surface and snapped end state included."""
    states = [rest, tilted.end_state, rest, tilted.end_state]
    controls = [1, 0, 2, 2]
    together = dyn.simulate_many(states, controls)
    assert [clip.control for clip in together] == controls
    assert together[0].end_state.shape == rest.shape
    for clip, state, control in zip(together, states, controls, strict=True):
        alone = dyn.simulate(state, control)
        assert np.array_equal(clip.frames, alone.frames)
        assert np.array_equal(clip.end_state, alone.end_state)
    assert np.array_equal(together[0].frames, tilted.frames)


def test_settled_clips_of_one_control_are_at_distance_zero(
    dyn: LiquidDynamics, rest: np.ndarray
) -> None:
    first = dyn.simulate(rest, 0)
    second = dyn.simulate(first.end_state, 0)
    a, b = dyn.features(first), dyn.features(second)
    assert max(a.kinetic, b.kinetic) < dyn.rest_kinetic
    assert dyn.dist(a, b, 0) == 0.0 and dyn.dist(b, a, 0) == 0.0
    assert dyn.pdist(a, b) < dyn.crowd_radius


def test_blend_of_nearby_clips(dyn: LiquidDynamics, rest: np.ndarray, tilted: SimClip) -> None:
    """Ends on the endpoints; volume never exceeds the larger endpoint by 10 %."""
    _, (later_state,) = dyn.solver.run_batch([rest], [1], 1)  # the same tilt a frame later
    later = dyn.simulate(later_state, 1)
    blended = dyn.blend(tilted.frames, later.frames)
    assert np.array_equal(blended[0], tilted.frames[0])
    assert np.array_equal(blended[-1], later.frames[-1])
    bound = np.maximum(volumes(dyn, tilted.frames), volumes(dyn, later.frames))
    assert np.all(volumes(dyn, blended) <= 1.10 * bound)
    assert dyn.dist(dyn.features(tilted), dyn.features(later), 1) > 0.0


def test_the_devices_default_to_the_embedded_configuration() -> None:
    # a liquid made without devices runs where an unconfigured srg runs it
    unconfigured = Settings.model_construct(  # the defaults, not this process's environment
        render=RenderSettings.model_construct(), runtime=RuntimeSettings.model_construct()
    )
    assert LiquidDevices() == LiquidDevices.from_settings(unconfigured)
    assert LiquidDynamics("tiny").devices == LiquidDevices()
    chosen = LiquidDevices(opencl_device="cpu", render_variant="scalar_rgb")
    assert LiquidDynamics("tiny", devices=chosen).devices is chosen


@pytest.mark.parametrize("path", sorted(CALIBRATION_DIR.glob("*.json")), ids=lambda p: p.stem)
def test_every_shipped_calibration_loads_and_is_a_measurement(path: Path) -> None:
    """Each file names its preset, fluid and stepping; one measured on today's stepping
    loads and holds four positive finite constants, the threshold the visible one with
    the study's details beside it; one measured on another stepping is refused."""
    stored = json.loads(path.read_text())
    preset, fluid = stored["preset"], stored.get("fluid", "low")
    assert calibration_path(preset, fluid) == path
    if stored["stepping"] != stepping(tilt_tank(preset, fluid)):
        # measured on frames the solver no longer makes: refused, with the way out
        with pytest.raises(MissingCalibration, match=f"srg calibrate --preset {preset}"):
            load_calibration(preset, fluid)
        return
    constants = load_calibration(preset, fluid)
    values = np.array(list(asdict(constants).values()))
    assert np.all(np.isfinite(values)) and np.all(values > 0), constants
    assert stored["visible_threshold"]["threshold"] == constants.high_error_threshold


def test_a_calibration_of_other_frames_is_refused(tmp_path: Path) -> None:
    """Constants measured with another stepping (the high fluid before its viscosity
    steps: 24 whole substeps a frame) do not judge today's clips."""
    stored = json.loads(calibration_path("tiny", "high").read_text())
    target = calibration_path("tiny", "high", tmp_path)
    target.write_text(json.dumps({**stored, "stepping": {"substeps": 24, "viscosity_steps": 1}}))
    with pytest.raises(MissingCalibration, match="srg calibrate --preset tiny --fluid high"):
        load_calibration("tiny", "high", tmp_path)
    target.write_text(json.dumps(stored))
    assert load_calibration("tiny", "high", tmp_path) == load_calibration("tiny", "high")
