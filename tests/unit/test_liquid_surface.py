"""The NumPy SDF, occupancy, descriptor, score and the quantised storage."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from app.core.liquid.scene import Box, initial_particles, tilt_tank
from app.core.liquid.surface import (
    clip_descriptor,
    clip_score,
    dequantise_occupancy,
    dequantise_sdf,
    liquid_volumes,
    occupancy,
    quantise_occupancy,
    quantise_sdf,
    surface_grid,
    zhu_bridson_sdf,
)

SCENE = tilt_tank("tiny")
GRID = surface_grid(SCENE)


def test_single_particle_zero_level_set_is_a_sphere_of_the_particle_radius() -> None:
    fine = dataclasses.replace(GRID, voxel=0.004, shape=(150, 100, 40))
    centre = np.array([[0.3, 0.2, 0.08]])
    phi = zhu_bridson_sdf(fine, centre)
    dist = np.linalg.norm(fine.centres() - centre, axis=1).reshape(fine.shape)
    near = dist < fine.search_radius
    # one neighbour: phi = |x - p| - r exactly, so the zero set is the sphere |x - p| = r
    np.testing.assert_allclose(phi[near], dist[near] - fine.particle_radius, atol=1e-6)
    assert np.all(phi[~near] == pytest.approx(fine.far_value))
    inside = liquid_volumes(fine, occupancy(fine, phi)[None])[0]
    assert inside == pytest.approx(4 / 3 * np.pi * fine.particle_radius**3, rel=0.05)


def test_settled_block_volume_matches_the_particles() -> None:
    state = initial_particles(SCENE)
    occ = occupancy(GRID, zhu_bridson_sdf(GRID, state[:, :3]))
    fluid = len(state) * SCENE.spacing**3
    assert liquid_volumes(GRID, occ[None])[0] == pytest.approx(fluid, rel=0.05)


def test_descriptor_is_the_mean_occupied_fraction_of_coarse_cells() -> None:
    occ = np.zeros((2, *GRID.shape), np.float32)
    occ[0, :, : GRID.shape[1] // 2] = 1.0  # frame 0: lower half full; frame 1 empty
    d = clip_descriptor(GRID, SCENE.tank, occ).reshape(6, 6, 6)
    np.testing.assert_allclose(d[:, :3], 0.5, atol=1e-9)
    np.testing.assert_allclose(d[:, 3:], 0.0, atol=1e-9)


def test_score_sums_target_volume_over_frames() -> None:
    occ = np.ones((3, *GRID.shape), np.float32)
    target = Box((0.2, 0.2, 0.0), (0.4, 0.3, 0.16))
    assert clip_score(GRID, target, occ) == pytest.approx(3 * 0.2 * 0.1 * 0.16)


def test_quantised_fields_round_trip_within_a_step() -> None:
    rng = np.random.default_rng(1)
    phi = rng.uniform(-GRID.particle_radius, GRID.far_value, (4, *GRID.shape)).astype(np.float32)
    q = quantise_sdf(GRID, phi)
    assert q.dtype == np.int8
    band = np.maximum(phi, -GRID.voxel / 2)  # deeper inside is clamped to half a voxel
    step = GRID.search_radius / 127
    np.testing.assert_allclose(dequantise_sdf(GRID, q), band, atol=step / 2 + 1e-7)
    assert dequantise_sdf(GRID, q).min() >= -GRID.voxel / 2 - step
    occ = occupancy(GRID, phi)
    qo = quantise_occupancy(occ)
    np.testing.assert_allclose(dequantise_occupancy(qo), occ, atol=1 / 510 + 1e-7)


def test_interior_clamp_keeps_occupancy() -> None:
    """The clamp cuts only where occupancy is full: occupancy of the stored field is that of
    the same field unclamped, level for level."""
    levels = np.arange(-127, 128, dtype=np.float32)
    phi = levels * np.float32(GRID.search_radius / 127)
    clamped = dequantise_sdf(GRID, quantise_sdf(GRID, phi))
    assert clamped.min() > phi.min()  # the clamp does cut
    np.testing.assert_array_equal(
        quantise_occupancy(occupancy(GRID, clamped)), quantise_occupancy(occupancy(GRID, phi))
    )
