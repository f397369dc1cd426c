"""The camera-ray silhouette of SDF frames on synthetic fields."""

from __future__ import annotations

import math

import numpy as np
import pytest

from app.core.liquid.scene import tilt_tank
from app.core.liquid.silhouette import silhouette_projector, silhouettes, tank_camera
from app.core.liquid.surface import surface_grid

SCENE = tilt_tank("tiny")
GRID = surface_grid(SCENE)
CAMERA = tank_camera(SCENE.tank)
PROJECTOR = silhouette_projector(CAMERA, GRID)


def sphere_sdf(centre: tuple[float, float, float], radius: float) -> np.ndarray:
    d = np.linalg.norm(GRID.centres() - np.asarray(centre), axis=1) - radius
    return np.minimum(d, GRID.far_value).reshape(GRID.shape).astype(np.float32)


def test_rays_span_the_field_of_view_around_the_look_direction() -> None:
    rays = CAMERA.ray_directions()
    forward = np.subtract(CAMERA.target, CAMERA.eye)
    forward /= np.linalg.norm(forward)
    centre = rays[59:61, 79:81].reshape(-1, 3).mean(axis=0)
    assert np.dot(centre / np.linalg.norm(centre), forward) == pytest.approx(1.0, abs=1e-6)
    # the leftmost and rightmost pixel centres are half a pixel inside the 33 degree fov
    across = math.degrees(math.acos(np.dot(rays[60, 0], rays[60, -1])))
    assert across == pytest.approx(33.0 * 159 / 160, abs=0.3)
    # columns grow with x, rows go down in y (image convention)
    assert rays[60, -1, 0] > rays[60, 0, 0]
    assert rays[0, 80, 1] > rays[-1, 80, 1]


def test_no_liquid_gives_an_empty_mask() -> None:
    far = np.full((2, *GRID.shape), GRID.far_value, np.float32)
    assert not silhouettes(PROJECTOR, far).any()


def test_a_sphere_projects_to_a_disc_of_its_angular_size() -> None:
    centre, radius = (0.3, 0.2, 0.08), 0.06
    mask = silhouettes(PROJECTOR, sphere_sdf(centre, radius)[None])[0]
    distance = float(np.linalg.norm(np.subtract(centre, CAMERA.eye)))
    pixel = 2 * distance * math.tan(math.radians(CAMERA.fov_x) / 2) / CAMERA.width
    expected = math.pi * (radius / pixel) ** 2
    assert mask.sum() == pytest.approx(expected, rel=0.1)
    rows, cols = np.nonzero(mask)
    assert cols.mean() == pytest.approx(79.5, abs=1.0)  # x = 0.3 is the middle of the image


def test_more_liquid_never_shows_fewer_pixels() -> None:
    phi = sphere_sdf((0.2, 0.1, 0.05), 0.05)
    small, large = silhouettes(PROJECTOR, np.stack([phi, phi - 0.02]))
    assert small.sum() < large.sum()
    assert not (small & ~large).any()
