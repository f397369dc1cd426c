"""Removing the speckle a few samples per pixel leave in a path-traced frame.

At 4 spp the noise left after the scene's backlight (``app.render.mitsuba_scene``) is
isolated pixels: a path that found a light where its neighbours did not, or none where
they did. A small median window replaces exactly those outliers by their neighbourhood
and keeps edges (the water's outline, the wall's corners) where an averaging filter
would blur them; docs/render.md compares it with total-variation denoising and with
more samples.
"""

from __future__ import annotations

import numpy as np
from scipy.ndimage import median_filter


def median_denoise(image: np.ndarray, window: int) -> np.ndarray:
    """The (H, W, 3) image with each channel median-filtered over ``window`` x ``window``.

    ``window`` 1 (or less) returns the image unchanged.
    """
    if window <= 1:
        return image
    return median_filter(image, size=(window, window, 1), mode="nearest")
