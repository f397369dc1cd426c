"""Eq. 3-8 of the liquid on synthetic fields: the properties the graph relies on."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from app.core.graph.dynamics import ClipFeatures
from app.core.liquid.liquid_metrics import (
    LiquidMetricParams,
    blend_sdf,
    blend_weights,
    clip_distance,
    descriptor_distance,
    energy_distance,
    energy_normalisation,
    fit_energy_weight,
    shape_distance,
)

PARAMS = LiquidMetricParams(rest_kinetic=0.05, energy_weight=0.01, voxel_volume=1e-6)
SHAPE = (3, 5, 4, 3)


def features(seed: int, kinetic: float, control: int = 0) -> ClipFeatures:
    rng = np.random.default_rng(seed)
    occ = rng.integers(0, 256, SHAPE, dtype=np.uint8)
    return ClipFeatures(
        control=control,
        kinetic=kinetic,
        potential=rng.uniform(0, 2, 3),
        occupancy=occ,
        descriptor=rng.uniform(0, 1, 216),
        score=0.0,
    )


@given(st.integers(0, 1000), st.integers(0, 1000), st.floats(0.1, 5.0), st.floats(0.1, 5.0))
@settings(max_examples=40, deadline=None)
def test_distance_to_itself_is_zero_and_shape_term_symmetric(
    i: int, j: int, ti: float, tj: float
) -> None:
    a, b = features(i, ti), features(j, tj)
    assert clip_distance(a, a, 0, PARAMS) == 0.0
    assert shape_distance(a.occupancy, b.occupancy, 1e-6) == pytest.approx(
        shape_distance(b.occupancy, a.occupancy, 1e-6)
    )
    assert descriptor_distance(a, b) == pytest.approx(descriptor_distance(b, a))


def test_shape_distance_is_the_symmetric_difference_volume() -> None:
    a = np.zeros(SHAPE, np.uint8)
    b = np.zeros(SHAPE, np.uint8)
    a[0, :2] = 255  # 2 x 4 x 3 = 24 full voxels in frame 0
    b[0, 1:3] = 255  # overlaps a on 12 of them
    assert shape_distance(a, b, 2.0) == pytest.approx(24 * 2.0)
    # float occupancy gives the same number as its uint8 quantisation
    assert shape_distance(a / 255.0, b / 255.0, 2.0) == pytest.approx(24 * 2.0)


@given(st.integers(0, 2**32 - 1))
@settings(max_examples=20, deadline=None)
def test_the_stored_levels_give_the_float_fractions_distance(seed: int) -> None:
    """The uint8 path (no widening) against the fractions': no wrap-around at 0 or 255."""
    rng = np.random.default_rng(seed)
    a, b = (rng.choice(np.array([0, 1, 128, 254, 255], np.uint8), SHAPE) for _ in range(2))
    assert shape_distance(a, b, 0.5) == pytest.approx(
        shape_distance(a / 255.0, b / 255.0, 0.5), rel=1e-6
    )


@given(st.floats(0.0, 10.0), st.floats(0.06, 5.0))
def test_an_energy_gain_costs_more_than_an_equal_loss(e: float, delta: float) -> None:
    gain = energy_distance(e, e + delta, PARAMS.rest_kinetic)
    loss = energy_distance(e + delta, e, PARAMS.rest_kinetic)
    assert gain == pytest.approx(PARAMS.c_gain / PARAMS.c_loss * loss)
    assert gain > loss


def test_a_gain_within_t0_is_charged_as_a_loss() -> None:
    assert energy_distance(1.0, 1.04, 0.05) == pytest.approx(0.04)


def test_settled_clips_of_one_control_are_at_distance_zero() -> None:
    a, b = features(1, 0.01), features(2, 0.02)
    assert clip_distance(a, b, 0, PARAMS) == 0.0
    # ... but not across controls: norm_e = 1 / sqrt(T_avg + T0)
    c = features(2, 0.02, control=1)
    assert energy_normalisation(0.01, 0.02, False, 0.05) == pytest.approx(1 / np.sqrt(0.065))
    assert clip_distance(a, c, 0, PARAMS) > 0.0


def test_distance_is_eq_3() -> None:
    a, b = features(3, 1.0), features(4, 2.0)
    shape = shape_distance(a.occupancy, b.occupancy, PARAMS.voxel_volume)
    energy = energy_distance(a.energy(1), b.energy(1), PARAMS.rest_kinetic)
    expected = (shape + PARAMS.energy_weight * energy) / np.sqrt(1.5 + 0.05)
    assert clip_distance(a, b, 1, PARAMS) == pytest.approx(expected)


def test_blend_weights_follow_eq_8() -> None:
    w_s, w_d, w_u = blend_weights(10)
    assert (w_s[0], w_d[0], w_u[0]) == (1.0, 0.0, 0.0)
    assert (w_s[-1], w_d[-1], w_u[-1]) == (0.0, 1.0, 0.0)
    assert np.all(w_s >= 0) and np.all(w_d >= 0) and np.all(w_u >= -1e-12)
    assert np.all(np.diff(w_s) <= 0) and np.all(np.diff(w_d) >= 0)
    np.testing.assert_allclose(w_s + w_d + w_u, 1.0)


def test_blend_starts_at_the_source_and_ends_at_the_destination() -> None:
    rng = np.random.default_rng(0)
    src, dst = rng.normal(size=(10, 4, 3, 2)), rng.normal(size=(10, 4, 3, 2))
    out = blend_sdf(src, dst)
    np.testing.assert_allclose(out[0], src[0], atol=1e-6)
    np.testing.assert_allclose(out[-1], dst[-1], atol=1e-6)
    # mid-blend the union dominates: never outside both shapes
    assert np.all(out <= np.maximum(src, dst) + 1e-6)


def test_energy_weight_fit_recovers_a_known_slope() -> None:
    e = np.array([0.5, 1.0, 2.0, 4.0])
    assert fit_energy_weight(3.0 * e, e) == pytest.approx(3.0)
    with pytest.raises(ValueError):
        fit_energy_weight(e, np.zeros(4))
