"""Removing the speckle a few samples per pixel leave in a path-traced frame.

At 4 spp the noise left after the scene's backlight (``app.render.mitsuba_scene``) is
isolated pixels: a path that found a light where its neighbours did not, or none where
they did. A 3 x 3 median replaces exactly those outliers by their neighbourhood and
keeps edges (the water's outline, the wall's corners) where an averaging filter would
blur them; docs/render.md compares it with total-variation denoising and with more
samples. It is computed by a fixed network of 19 compare-exchanges over the nine
shifted images (min and max of whole arrays), which gives ``scipy.ndimage``'s median
filter exactly, 15 times faster: the time it saves pays for deeper paths. The renderer
applies it twice: paths deep enough to leave a folded sheet of water (depth 12) also
bring back sparkles of two or three pixels inside the water, which one pass leaves and
the video codec pays for (docs/render.md, "Same cost").
"""

from __future__ import annotations

import numpy as np

#: compare-exchanges whose 5th output is the median of 9 (Paeth's network)
MEDIAN_OF_NINE = (
    (1, 2), (4, 5), (7, 8), (0, 1), (3, 4), (6, 7), (1, 2), (4, 5), (7, 8), (0, 3),
    (5, 8), (4, 7), (3, 6), (1, 4), (2, 5), (4, 7), (4, 2), (6, 4), (4, 2),
)  # fmt: skip


def median_denoise(image: np.ndarray) -> np.ndarray:
    """The (H, W, 3) image with each channel's 3 x 3 median (edges repeat outwards)."""
    h, w = image.shape[:2]
    padded = np.pad(image, ((1, 1), (1, 1), (0, 0)), mode="edge")
    values = [padded[i : i + h, j : j + w] for i in range(3) for j in range(3)]
    for a, b in MEDIAN_OF_NINE:
        values[a], values[b] = np.minimum(values[a], values[b]), np.maximum(values[a], values[b])
    return values[4]
