"""The OpenCL Zhu-Bridson SDF against its NumPy twin (app.core.liquid.surface)."""

from __future__ import annotations

import numpy as np

from app.core.liquid.scene import initial_particles, tilt_tank
from app.core.liquid.surface import surface_grid, zhu_bridson_sdf
from app.kernels.sdf import SdfKernel

SCENE = tilt_tank("tiny")
GRID = surface_grid(SCENE)


def test_kernel_matches_numpy_twin_on_a_jittered_block() -> None:
    rng = np.random.default_rng(7)
    pos = initial_particles(SCENE)[:, :3]
    pos = pos + rng.normal(scale=0.3 * SCENE.spacing, size=pos.shape).astype(np.float32)
    # a few spray particles away from the block, and two just outside the tank
    spray = rng.uniform((0.0, 0.2, 0.0), (0.6, 0.4, 0.16), (40, 3)).astype(np.float32)
    outside = np.array([[-0.005, 0.1, 0.08], [0.3, 0.1, 0.165]], np.float32)
    pos = np.concatenate([pos, spray, outside])
    kernel = SdfKernel(GRID)
    np.testing.assert_allclose(kernel.frame(pos), zhu_bridson_sdf(GRID, pos), atol=2e-6)


def test_kernel_single_particle_is_a_sphere_and_empty_frame_is_far() -> None:
    kernel = SdfKernel(GRID)
    p = np.array([[0.31, 0.21, 0.07]], np.float32)
    phi = kernel.frames(np.stack([p, p]))
    dist = np.linalg.norm(GRID.centres() - p, axis=1).reshape(GRID.shape)
    near = dist < GRID.search_radius
    np.testing.assert_allclose(phi[1][near], dist[near] - GRID.particle_radius, atol=2e-6)
    empty = kernel.frame(np.zeros((0, 3), np.float32))
    np.testing.assert_allclose(empty, GRID.far_value, rtol=1e-6)
