"""How rendered water looks, as numbers: the share of near-black pixels in a frame.

The scene (white walls, a backlight, blue water) holds nothing black, so a pixel whose
every channel is dark is a ray the path tracer gave up on (thin sheets of water that
trap it past the bounce limit) or a faceted, self-crossing patch of mesh: the splashes'
black shards. Counting them is how a change to the renderer is judged.
"""

from __future__ import annotations

import numpy as np

#: a pixel is near-black when every channel is below this (of 255)
DARK_LEVEL = 24


def dark_fractions(frames: np.ndarray, level: int = DARK_LEVEL) -> np.ndarray:
    """Per frame of (k, H, W, 3) uint8 images, the share of pixels dark in every channel."""
    dark = np.all(np.asarray(frames) < level, axis=-1)
    return dark.reshape(dark.shape[0], -1).mean(axis=1)
