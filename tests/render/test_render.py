"""Meshing, Mitsuba frames and the strip encoding on tiny inputs."""

from __future__ import annotations

import dataclasses
import io
import os
from pathlib import Path

import numpy as np
import pytest
from PIL import Image
from scipy.ndimage import median_filter

from app.core.liquid.scene import initial_particles, tilt_tank
from app.core.liquid.surface import dequantise_sdf, surface_grid, zhu_bridson_sdf
from app.render.animation import (
    STRIP_MEDIA_TYPE,
    decode_strip,
    encode_poster,
    encode_strip,
    phone_strip,
)
from app.render.denoise import median_denoise
from app.render.look import dark_fractions
from app.render.meshing import WALL_OVERLAP, render_mesh, surface_mesh
from app.render.mitsuba_scene import LiquidRenderer, RenderQuality, pick_variant
from app.render.smoothing import mesh_volume

SCENE = tilt_tank("tiny")
GRID = surface_grid(SCENE)
#: one frame of a splash on `tiny` (int8 SDF, the game's quantisation): a sheet of water
#: folding over from the right wall, the frame that rendered darkest (docs/render.md)
SPLASH = dequantise_sdf(GRID, np.load(Path(__file__).parent / "data" / "splash-tiny.npy"))


def _edge_angles(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Angles (rad) between the normals of the two faces of every edge.

    NaN where a face has no area (marching cubes makes a few).
    """
    tri = vertices[faces].astype(np.float64)
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    length = np.linalg.norm(n, axis=1, keepdims=True)
    n = n / np.where(length > 0, length, np.nan)
    edges = np.sort(faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    order = np.lexsort(edges.T[::-1])
    pairs = np.repeat(np.arange(len(faces)), 3)[order].reshape(-1, 2)  # closed: 2 per edge
    cos = np.einsum("ij,ij->i", n[pairs[:, 0]], n[pairs[:, 1]])
    return np.arccos(np.clip(cos, -1.0, 1.0))


def test_mesh_of_one_particle_is_a_sphere_with_outward_faces() -> None:
    fine = dataclasses.replace(GRID, voxel=0.004, shape=(150, 100, 40))
    centre = np.array([0.3, 0.2, 0.08])
    mesh = surface_mesh(fine, zhu_bridson_sdf(fine, centre[None]))
    vertices, faces = mesh.vertices, mesh.faces
    assert not mesh.on_wall.any()
    radii = np.linalg.norm(vertices - centre, axis=1)
    np.testing.assert_allclose(radii, fine.particle_radius, rtol=0.05)
    tri = vertices[faces]
    normals = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    outward = np.einsum("ij,ij->i", normals, tri.mean(axis=1) - centre)
    assert np.all(outward > 0)


def test_mesh_of_liquid_at_a_wall_is_closed_meets_the_wall_and_empty_frame_has_none() -> None:
    phi = zhu_bridson_sdf(GRID, initial_particles(SCENE)[:, :3])
    mesh = surface_mesh(GRID, phi)
    vertices, faces = mesh.vertices, mesh.faces
    edges = np.sort(faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    assert np.all(counts == 2)  # every edge shared by two triangles: watertight
    # the water meets the floor (just inside it, no seam of air); its top is near the
    # fluid block's 0.16 m
    floor = vertices[mesh.on_wall[:, 1], 1]
    np.testing.assert_allclose(floor[floor < 0.1], -WALL_OVERLAP * GRID.voxel, atol=1e-6)
    assert vertices[:, 1].min() == pytest.approx(-WALL_OVERLAP * GRID.voxel, abs=1e-6)
    assert vertices[:, 1].max() == pytest.approx(SCENE.fluid.hi[1], abs=GRID.voxel)
    empty = surface_mesh(GRID, np.full(GRID.shape, GRID.far_value, np.float32))
    assert len(empty.vertices) == 0 and len(empty.faces) == 0


def test_smoothing_keeps_the_volume_and_the_walls_and_removes_facets() -> None:
    raw = surface_mesh(GRID, SPLASH)
    smooth = render_mesh(GRID, SPLASH)
    assert mesh_volume(smooth.vertices, smooth.faces) == pytest.approx(
        mesh_volume(raw.vertices, raw.faces), rel=0.02
    )
    held = raw.on_wall
    np.testing.assert_array_equal(smooth.vertices[held], raw.vertices[held])
    # the facets: the mean angle between neighbouring faces falls (0.30 to 0.25 rad here;
    # a drop one voxel across stays a few faces, which the shading normals round)
    before = np.nanmean(_edge_angles(raw.vertices, raw.faces))
    after = np.nanmean(_edge_angles(smooth.vertices, smooth.faces))
    assert after < 0.9 * before
    assert smooth.normals is not None
    np.testing.assert_allclose(np.linalg.norm(smooth.normals, axis=1), 1.0, rtol=1e-5)


def test_a_splash_renders_without_black_shards() -> None:
    """A folding sheet of water: paths that bounce in it reach a light, no seam is dark.

    With the renderer before (paths of depth 4, the water stopping short of the walls,
    no smoothing) 4.3 % of this frame was near-black at this size.
    """
    renderer = LiquidRenderer(SCENE, GRID, RenderQuality(width=160, height=120))
    image = renderer.frames(SPLASH[None])
    assert dark_fractions(image)[0] <= 0.003


def test_rendered_frames_show_water_at_the_bottom() -> None:
    renderer = LiquidRenderer(SCENE, GRID, RenderQuality(width=48, height=36, spp=4))
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


def test_the_median_network_is_the_median_filter() -> None:
    image = np.random.default_rng(0).integers(0, 256, (37, 53, 3), dtype=np.uint8)
    expected = median_filter(image, size=(3, 3, 1), mode="nearest")
    np.testing.assert_array_equal(median_denoise(image), expected)
