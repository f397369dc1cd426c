"""Near-black pixels on a `tiny` splash sequence, rendered with the side frames at a grey.

    python frame_colour.py GREY   ->  one JSON line (GREY 0.2: the frames before; 0.5: now)

Twelve clips from the settled tank under controls 1, 1, 2, 2, 1, 2, 2, 1, 1, 2, 0, 1
(120 frames), rendered by the game's renderer with only ``FRAME_COLOUR`` changed (the
same hue: GREY x (1, 1.1, 1.25)); per frame the share of pixels below 24 of 255 in every
channel, and those inside the water's exact silhouette (docs/render.md).
"""

import json
import sys

import numpy as np

import app.render.mitsuba_scene as look
from app.core.liquid.silhouette import silhouette_projector, silhouettes, tank_camera
from app.core.liquid.surface import dequantise_sdf
from app.liquid.adapter import LiquidDynamics
from app.render.look import dark_fractions, dark_inside

CONTROLS = (1, 1, 2, 2, 1, 2, 2, 1, 1, 2, 0, 1)

grey = float(sys.argv[1])
look.FRAME_COLOUR = (grey, grey * 1.1, grey * 1.25)
dyn = LiquidDynamics("tiny")
state = dyn.initial_state()
clips = []
for control in CONTROLS:
    clip = dyn.simulate(state, control)
    clips.append(clip.frames)
    state = clip.end_state
settings = dyn.render_quality
camera = tank_camera(dyn.scene.tank, settings.width, settings.height)
water = silhouettes(
    silhouette_projector(camera, dyn.grid), dequantise_sdf(dyn.grid, np.concatenate(clips))
)
images = np.concatenate([dyn.render(frames) for frames in clips])
inside = dark_inside(images, water)
print(
    json.dumps(
        {
            "grey": grey,
            "worst_frame_fraction": float(dark_fractions(images).max()),
            "inside_water_all_frames": int(inside.sum()),
            "inside_water_worst_frame": int(inside.max()),
        }
    )
)
