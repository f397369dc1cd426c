"""The high fluid's splash on the old stepping and on the viscosity steps, side by side.

    python docs/results/viscosity-steps-splash/splash.py docs/images/high-fluid-steps.jpg

From one settled `small` tank (settled on the old stepping), the same left tilt is
simulated with 60 substeps a frame (the old stepping: one viscosity step each) and with
today's 19 substeps and 4 viscosity steps each; frames 10, 20 and 30 of each are
rendered at 320 x 240 (top row old, bottom row new) into one JPEG.
"""

from __future__ import annotations

import sys
from dataclasses import replace

import numpy as np
from PIL import Image

from app.kernels.sph import SphSimulator
from app.liquid.adapter import LiquidDynamics
from app.render.mitsuba_scene import RenderQuality

FRAMES = (10, 20, 30)

dynamics = LiquidDynamics("small", "high", render_quality=RenderQuality(width=320, height=240))
old = replace(dynamics.scene, substeps=60, viscosity_steps=1)
rest = SphSimulator(old).settle()
rows = []
for scene in (old, dynamics.scene):
    positions, _ = SphSimulator(scene).run(rest, 1, max(FRAMES))
    picked = np.stack([positions[f - 1] for f in FRAMES])
    images = dynamics.renderer.frames(dynamics.sdf_kernel.frames(picked))
    rows.append(np.concatenate(list(images), axis=1))
Image.fromarray(np.concatenate(rows, axis=0)).save(sys.argv[1], quality=90)
print(f"{sys.argv[1]}: frames {FRAMES}, top 60 substeps, bottom 19 x 4 viscosity steps")
