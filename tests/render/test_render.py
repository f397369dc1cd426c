"""Meshing, Mitsuba frames and the strip encoding on tiny inputs."""

from __future__ import annotations

import dataclasses
import io
import os
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from app.core.scene import initial_particles, tilt_tank
from app.core.surface import surface_grid, zhu_bridson_sdf
from app.render.animation import (
    STRIP_MEDIA_TYPE,
    decode_strip,
    encode_poster,
    encode_strip,
    phone_strip,
)
from app.render.meshing import surface_mesh
from app.render.mitsuba_scene import LiquidRenderer, RenderSettings, pick_variant

SCENE = tilt_tank("tiny")
GRID = surface_grid(SCENE)


def test_mesh_of_one_particle_is_a_sphere_with_outward_faces() -> None:
    fine = dataclasses.replace(GRID, voxel=0.004, shape=(150, 100, 40))
    centre = np.array([0.3, 0.2, 0.08])
    vertices, faces = surface_mesh(fine, zhu_bridson_sdf(fine, centre[None]))
    radii = np.linalg.norm(vertices - centre, axis=1)
    np.testing.assert_allclose(radii, fine.particle_radius, rtol=0.05)
    tri = vertices[faces]
    normals = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    outward = np.einsum("ij,ij->i", normals, tri.mean(axis=1) - centre)
    assert np.all(outward > 0)


def test_mesh_of_liquid_at_a_wall_is_closed_and_empty_frame_has_none() -> None:
    phi = zhu_bridson_sdf(GRID, initial_particles(SCENE)[:, :3])
    vertices, faces = surface_mesh(GRID, phi)
    edges = np.sort(faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    assert np.all(counts == 2)  # every edge shared by two triangles: watertight
    # the floor closes within a voxel of y = 0; the top is near the fluid block's 0.16 m
    assert 0.0 <= vertices[:, 1].min() < GRID.voxel
    assert vertices[:, 1].max() == pytest.approx(SCENE.fluid.hi[1], abs=GRID.voxel)
    empty_v, empty_f = surface_mesh(GRID, np.full(GRID.shape, GRID.far_value, np.float32))
    assert len(empty_v) == 0 and len(empty_f) == 0


def test_rendered_frames_show_water_at_the_bottom() -> None:
    renderer = LiquidRenderer(SCENE, GRID, RenderSettings(width=48, height=36, spp=4))
    phi = zhu_bridson_sdf(GRID, initial_particles(SCENE)[:, :3])
    empty = np.full(GRID.shape, GRID.far_value, np.float32)
    images = renderer.frames(np.stack([phi, empty]))
    assert images.shape == (2, 36, 48, 3) and images.dtype == np.uint8
    change = np.abs(images[0].astype(float) - images[1].astype(float))
    # the water changes the lower middle of the tank, not the wall above it (mean colour
    # change per region: path-tracing noise alone is a few levels)
    assert change[24:30, 12:36].mean() > 20
    assert change[:8].mean() < 0.3 * change[24:30, 12:36].mean()


def test_clip_round_trips_its_frames() -> None:
    rng = np.random.default_rng(0)
    frames = np.zeros((10, 12, 16, 3), np.uint8)
    for f in range(10):
        frames[f] = rng.integers(0, 255, 3)  # one flat colour per frame
    data = encode_strip(frames)
    assert data[:4] == b"DKIF" and data[8:12] == b"VP90" and STRIP_MEDIA_TYPE == "video/x-ivf"
    decoded = decode_strip(data, 10)
    assert decoded.shape == frames.shape
    np.testing.assert_allclose(
        decoded[:, 3:-3, 3:-3].mean(axis=(1, 2)), frames[:, 0, 0].astype(float), atol=12
    )
    assert encode_poster(frames)[8:12] == b"WEBP"
    with pytest.raises(ValueError):
        decode_strip(data, 7)
    with pytest.raises(ValueError):
        decode_strip(data[:40], 10)  # a clip cut short is no clip


def test_image_strips_stored_as_webp_before_still_decode() -> None:
    frames = np.zeros((4, 12, 16, 3), np.uint8)
    frames[:, :, :, 2] = np.arange(4)[:, None, None] * 60
    buffer = io.BytesIO()
    Image.fromarray(frames.transpose(1, 0, 2, 3).reshape(12, 64, 3)).save(buffer, format="WEBP")
    decoded = decode_strip(buffer.getvalue(), 4)
    np.testing.assert_allclose(
        decoded[:, 4:-4, 4:-4, 2].mean(axis=(1, 2)), [0, 60, 120, 180], atol=12
    )


def test_the_phone_clip_halves_every_frame() -> None:
    frames = np.zeros((3, 24, 32, 3), np.uint8)
    frames[1] = 255  # a white frame between black ones: nothing bleeds across the cut
    small = decode_strip(phone_strip(encode_strip(frames), 3), 3)
    assert small.shape == (3, 12, 16, 3)
    np.testing.assert_allclose(small.mean(axis=(1, 2, 3)), [0, 255, 0], atol=12)


def test_the_variant_choice_falls_back_to_scalar_without_a_working_libllvm(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    monkeypatch.setenv("DRJIT_LIBLLVM_PATH", "")  # restored after the test
    choose = pick_variant.__wrapped__  # uncached: each call decides afresh
    assert choose("scalar_rgb") == "scalar_rgb"
    broken = tmp_path / "libLLVM.so.19.1"
    broken.write_bytes(b"not a shared library")
    assert choose("auto", str(broken)) == "scalar_rgb"
    assert os.environ["DRJIT_LIBLLVM_PATH"] == str(broken)
