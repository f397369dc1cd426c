"""Mitsuba 3 renders of liquid SDF frames from one fixed camera.

The static part of the scene (camera, lights, the tank's floor, the back wall glowing
softly behind the water, side walls, the target region as a tinted patch on the back
wall, the water material) is built once per
process and kept as loaded Mitsuba objects; each frame only makes a new mesh and
re-assembles the scene around it (about 10 ms), so the PLY/XML parsing and plugin
construction are not repeated.

Variant: ``scalar_rgb`` works everywhere. Mitsuba's LLVM variant is about three times
faster here, but the LLVM 14/15 that Debian installs by default crash inside Dr.Jit, so
:func:`pick_variant` uses it only when a newer libLLVM is given (``DRJIT_LIBLLVM_PATH``)
or found (Debian's ``libllvm19``, ``libllvm18``...) *and* a probe render in a child
process succeeds; otherwise it falls back to ``scalar_rgb``.
"""

from __future__ import annotations

import logging
import os
import subprocess
import sys
from dataclasses import dataclass
from functools import cache
from pathlib import Path
from typing import Any

import drjit as dr
import mitsuba as mi
import numpy as np

from app.core.liquid.scene import Box, Scene
from app.core.liquid.silhouette import tank_camera
from app.core.liquid.surface import SurfaceGrid
from app.render.denoise import median_denoise
from app.render.meshing import LiquidMesh, render_mesh
from app.render.smoothing import SMOOTHING_STEPS

DEFAULT_VARIANT = "scalar_rgb"
LLVM_VARIANT = "llvm_ad_rgb"
#: libLLVM builds Dr.Jit's LLVM backend runs with, newest first (14 and 15 crash in it)
LLVM_LIBRARIES = tuple(
    f"{directory}/{name}"
    for name in ("libLLVM.so.19.1", "libLLVM-19.so", "libLLVM-18.so", "libLLVM-17.so")
    for directory in ("/usr/lib/x86_64-linux-gnu", "/usr/lib/aarch64-linux-gnu", "/usr/lib")
)
log = logging.getLogger(__name__)
#: water: refractive index 1.33 with a blue tint so thin sheets still read as water
WATER_IOR = 1.33
WATER_TINT = (0.5, 0.75, 0.95)
TARGET_COLOUR = (0.85, 0.35, 0.2)
WALL_COLOUR = (0.8, 0.8, 0.78)
#: the tank's side frames: a light brushed-metal grey; seen through a splash, the darker
#: grey they had (0.2) came out near-black inside the water (docs/render.md)
FRAME_COLOUR = (0.5, 0.55, 0.625)
#: the back wall glows with this fraction of its colour (a light box behind the tank)
BACKLIGHT = 0.35
SKY_RADIANCE = 0.3


@dataclass(frozen=True)
class RenderQuality:
    """Image size, samples per pixel, path depth, the median's passes, the mesh's smoothing.

    The defaults are the game's, chosen by the measurements in docs/render.md (the
    cheapest setting without visible noise at 480 x 360, deep enough that light leaves
    a folded sheet of water); tests pass smaller sizes.
    """

    width: int = 480
    height: int = 360
    spp: int = 4
    max_depth: int = 12
    median_passes: int = 2
    smoothing_steps: int = SMOOTHING_STEPS


def llvm_variant_usable() -> bool:
    """Whether ``llvm_ad_rgb`` renders in a child process (a crash there costs nothing).

    The child inherits ``DRJIT_LIBLLVM_PATH`` from this process's environment: set it to
    a libLLVM >= 19 to opt in.
    """
    probe = (
        "import mitsuba as mi; mi.set_variant('llvm_ad_rgb');"
        "mi.render(mi.load_dict(mi.cornell_box()), spp=1)"
    )
    try:
        done = subprocess.run([sys.executable, "-c", probe], capture_output=True, timeout=120)
    except subprocess.TimeoutExpired:
        return False
    return done.returncode == 0


@cache
def pick_variant(preference: str = "auto", llvm_path: str = "") -> str:
    """The Mitsuba variant to render with, decided once per process.

    ``preference`` ``"auto"`` means the LLVM variant when a working libLLVM exists:
    ``llvm_path``, else the first of :data:`LLVM_LIBRARIES` on disk. Dr.Jit reads the
    library's path from ``DRJIT_LIBLLVM_PATH`` when its LLVM backend starts, so it is set
    for this process and the probe child (and workers forked later) before the probe.
    """
    if preference != "auto":
        return preference
    path = llvm_path or next((p for p in LLVM_LIBRARIES if Path(p).is_file()), "")
    if not path:
        log.info("rendering with %s: no libLLVM >= 17 found", DEFAULT_VARIANT)
        return DEFAULT_VARIANT
    os.environ["DRJIT_LIBLLVM_PATH"] = path
    variant = LLVM_VARIANT if llvm_variant_usable() else DEFAULT_VARIANT
    log.info("rendering with %s (libLLVM %s)", variant, path)
    return variant


def _box(box: Box, bsdf: Any) -> Any:
    """A cube plugin scaled onto an axis-aligned box."""
    lo, hi = np.asarray(box.lo), np.asarray(box.hi)
    centre, half = (lo + hi) / 2, (hi - lo) / 2
    to_world = mi.ScalarTransform4f().translate(centre.tolist()).scale(half.tolist())
    return mi.load_dict({"type": "cube", "to_world": to_world, "bsdf": bsdf})


def _diffuse(rgb: tuple[float, float, float]) -> Any:
    return mi.load_dict({"type": "diffuse", "reflectance": {"type": "rgb", "value": rgb}})


def _glowing(box: Box, rgb: tuple[float, float, float]) -> Any:
    """A diffuse box that also emits ``BACKLIGHT`` of its colour.

    The water blocks shadow rays, so a wall seen through it gets no direct light and,
    lit only by bounces, shows as dark speckle at a few samples per pixel. A wall that
    glows is seen through the refraction directly, without noise, as a lit aquarium's is.
    """
    lo, hi = np.asarray(box.lo), np.asarray(box.hi)
    centre, half = (lo + hi) / 2, (hi - lo) / 2
    return mi.load_dict(
        {
            "type": "cube",
            "to_world": mi.ScalarTransform4f().translate(centre.tolist()).scale(half.tolist()),
            "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": rgb}},
            "emitter": {
                "type": "area",
                "radiance": {"type": "rgb", "value": [BACKLIGHT * c for c in rgb]},
            },
        }
    )


def _static_objects(scene: Scene, quality: RenderQuality) -> dict[str, Any]:
    """Loaded Mitsuba objects of everything but the liquid."""
    lo, hi = np.asarray(scene.tank.lo), np.asarray(scene.tank.hi)
    size = hi - lo
    t = 0.02 * size[0]  # wall thickness
    wall, frame = _diffuse(WALL_COLOUR), _diffuse(FRAME_COLOUR)
    tg = scene.target
    camera = tank_camera(scene.tank, quality.width, quality.height)
    return {
        "integrator": mi.load_dict({"type": "path", "max_depth": quality.max_depth}),
        "sensor": mi.load_dict(
            {
                "type": "perspective",
                "fov": camera.fov_x,
                "fov_axis": "x",
                "to_world": mi.ScalarTransform4f().look_at(
                    origin=list(camera.eye), target=list(camera.target), up=list(camera.up)
                ),
                "film": {
                    "type": "hdrfilm",
                    "width": quality.width,
                    "height": quality.height,
                    "rfilter": {"type": "box"},
                },
                "sampler": {"type": "multijitter", "sample_count": quality.spp},
            }
        ),
        "sky": mi.load_dict(
            {"type": "constant", "radiance": {"type": "rgb", "value": SKY_RADIANCE}}
        ),
        "lamp": mi.load_dict(
            {
                "type": "directional",
                "direction": [-0.3, -1.0, -0.5],
                "irradiance": {"type": "rgb", "value": 2.5},
            }
        ),
        "floor": _box(
            Box((lo[0] - 0.3, lo[1] - t, lo[2] - 0.3), (hi[0] + 0.3, lo[1], hi[2] + 0.6)), wall
        ),
        "back": _glowing(
            Box((lo[0] - t, lo[1] - t, lo[2] - t), (hi[0] + t, hi[1] + t, lo[2])), WALL_COLOUR
        ),
        "left": _box(Box((lo[0] - t, lo[1], lo[2]), (lo[0], hi[1], hi[2])), frame),
        "right": _box(Box((hi[0], lo[1], lo[2]), (hi[0] + t, hi[1], hi[2])), frame),
        "target": _glowing(
            Box((tg.lo[0], tg.lo[1], lo[2]), (tg.hi[0], tg.hi[1], lo[2] + 0.1 * t)), TARGET_COLOUR
        ),
        "water": mi.load_dict(
            {
                "type": "dielectric",
                "int_ior": WATER_IOR,
                "specular_transmittance": {"type": "rgb", "value": WATER_TINT},
            }
        ),
    }


def _liquid_mesh(mesh: LiquidMesh, water: Any) -> Any:
    props = mi.Properties()
    props["bsdf"] = water
    shaded = mesh.normals is not None
    shape = mi.Mesh(
        "liquid", len(mesh.vertices), len(mesh.faces), props=props, has_vertex_normals=shaded
    )
    params = mi.traverse(shape)
    params["vertex_positions"] = dr.scalar.ArrayXf(mesh.vertices.ravel())
    params["faces"] = dr.scalar.ArrayXu(mesh.faces.ravel())
    if mesh.normals is not None:
        params["vertex_normals"] = dr.scalar.ArrayXf(mesh.normals.ravel())
    params.update()
    return shape


class LiquidRenderer:
    """Renders SDF frames of one scene; build one per process and reuse it."""

    def __init__(
        self,
        scene: Scene,
        grid: SurfaceGrid,
        quality: RenderQuality | None = None,
        variant: str = DEFAULT_VARIANT,
    ) -> None:
        mi.set_variant(variant)
        self.grid = grid
        self.quality = quality or RenderQuality()
        objects = _static_objects(scene, self.quality)
        self.water = objects.pop("water")
        self.static = objects

    def frame(self, phi: np.ndarray) -> np.ndarray:
        """(H, W, 3) uint8 sRGB image of one float (X, Y, Z) SDF frame."""
        mesh = render_mesh(self.grid, phi, self.quality.smoothing_steps)
        shapes = dict(self.static)
        if len(mesh.faces):
            shapes["liquid"] = _liquid_mesh(mesh, self.water)
        rendered = mi.render(mi.load_dict({"type": "scene", **shapes}))
        bitmap = mi.Bitmap(rendered).convert(
            mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.UInt8, srgb_gamma=True
        )
        image = np.array(bitmap, dtype=np.uint8)
        for _ in range(self.quality.median_passes):
            image = median_denoise(image)
        return image

    def frames(self, sdf_frames: np.ndarray) -> np.ndarray:
        """(k, H, W, 3) uint8 images of (k, X, Y, Z) float SDF frames.

        Every frame renders with the same (default) sampler seed, so the static parts of
        the image keep the same noise from frame to frame instead of flickering.
        """
        return np.stack([self.frame(phi) for phi in sdf_frames])
