"""How rendered water looks, as numbers: near-black pixels, in the frame and in the water.

The scene (white walls, a backlight, blue water) holds little that is black, so a pixel
whose every channel is dark is most often a ray the path tracer gave up on (thin sheets
of water that trap it past the bounce limit) or a seam of air between the water and a
wall: the splashes' black shards. Counting them, over the frame and inside the water's
own silhouette (where a shard is seen), is how a change to the renderer is judged
(docs/render.md).
"""

from __future__ import annotations

import numpy as np

#: a pixel is near-black when every channel is below this (of 255)
DARK_LEVEL = 24
#: percentiles a report gives of the per-frame share of near-black pixels
PERCENTILES = {"median": 50, "p90": 90, "p99": 99, "max": 100}


def dark_pixels(frames: np.ndarray, level: int = DARK_LEVEL) -> np.ndarray:
    """(k, H, W) bool: the pixels of (k, H, W, 3) uint8 images dark in every channel."""
    return np.all(np.asarray(frames) < level, axis=-1)


def dark_fractions(frames: np.ndarray, level: int = DARK_LEVEL) -> np.ndarray:
    """Per frame of (k, H, W, 3) uint8 images, the share of pixels dark in every channel."""
    dark = dark_pixels(frames, level)
    return dark.reshape(dark.shape[0], -1).mean(axis=1)


def dark_inside(frames: np.ndarray, masks: np.ndarray, level: int = DARK_LEVEL) -> np.ndarray:
    """Per frame, the count of near-black pixels inside the (k, H, W) bool water masks."""
    inside = dark_pixels(frames, level) & np.asarray(masks, dtype=bool)
    return inside.reshape(inside.shape[0], -1).sum(axis=1)


def fraction_percentiles(fractions: np.ndarray) -> dict[str, float]:
    """The per-frame shares' median, 90th and 99th percentiles and maximum."""
    values = np.asarray(fractions, dtype=np.float64)
    return {name: float(np.percentile(values, q)) for name, q in PERCENTILES.items()}
