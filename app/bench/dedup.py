"""Benchmark of shared animations (the paper's section 8) on a stored graph.

Replays the search of :mod:`app.core.graph.dedup` over the graph's rendered clips in index
order, as growth and publishing meet them, for several limits (fractions of the
high-error threshold): how many clips would show another's strip, the bytes that saves
per simulated frame, and what it costs to look at. The cost is measured twice: the
substitution error (eq. 3 both ways) against the high-error threshold, and the pixels of
the two rendered strips (each clip's own strip against the one shown instead). Run it on
a graph grown with ``SRG_DEDUP_ERROR_FRACTION=0``, whose clips each hold their own strip,
so both strips exist. Two references come with it: each clip's smallest substitution
error over the earlier clips (what any limit could reuse), and the pixels that change
from one frame of a clip to the next (1/30 s of motion).
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np
from PIL import Image

from app.config import Settings
from app.db.sessions import transaction
from app.render.animation import decode_strip
from app.reports.contact_sheet import Tile, contact_sheet
from app.services.animations import AnimationReuse
from app.services.loading import open_graph
from app.store.animations import clip_animations, graph_animations

DEFAULT_FRACTIONS = (0.05, 0.1, 0.2, 0.5)
#: a pixel differs visibly when one channel moves by more than this (of 255)
VISIBLE_LEVELS = 32
#: substitutions drawn on the sheet, each as two frames
SHEET_PAIRS = 6


def _quantiles(values: Sequence[float]) -> dict[str, float] | None:
    if not values:
        return None
    v = np.asarray(values, dtype=np.float64)
    return {
        "min": float(v.min()),
        "median": float(np.median(v)),
        "p90": float(np.quantile(v, 0.9)),
        "max": float(v.max()),
    }


def bench_dedup(
    settings: Settings,
    name: str,
    fractions: Sequence[float] = DEFAULT_FRACTIONS,
    sheet: Path | None = None,
) -> dict[str, Any]:
    """The replay's figures per fraction, as JSON-ready data.

    ``sheet``: a PNG of the largest limit's worst substitutions, to look at: each clip's
    own middle frame beside the one shown instead.
    """
    with transaction(settings) as session:
        loaded = open_graph(session, settings, name)
        strips = clip_animations(session, loaded.entry.id)
        stored = graph_animations(session, loaded.entry.id)
    graph, artifacts = loaded.graph, loaded.artifacts
    threshold = loaded.context.threshold
    k = loaded.entry.frames_per_clip
    size = {digest: len(artifacts.get_bytes(digest)) for digest in stored}
    frames = max(graph.size_frames, 1)

    @lru_cache(maxsize=64)
    def images(digest: str) -> np.ndarray:
        return decode_strip(artifacts.get_bytes(digest), k).astype(np.int16)

    clips = sorted(strips)
    features = {clip: loaded.bank.features(clip) for clip in clips}
    runs = []
    for fraction in fractions:
        reuse = AnimationReuse.of_graph(loaded, {}, fraction * threshold)
        errors, distances, mean_pixels, visible_pixels = [], [], [], []
        shown, substitutes = {}, {}
        start = time.perf_counter()
        for clip in clips:
            found = reuse.substitute(features[clip])
            if found is None:
                reuse.note(clip, strips[clip], rendered=True)
            else:
                reuse.note(clip, reuse.animations[found.clip], rendered=False)
                substitutes[clip] = found
                errors.append(found.error / threshold)
                distances.append(found.descriptor_distance)
            shown[clip] = reuse.animations[clip]
        seconds = time.perf_counter() - start
        for clip in clips:
            if shown[clip] != strips[clip]:
                difference = np.abs(images(strips[clip]) - images(shown[clip]))
                mean_pixels.append(float(difference.mean()))
                visible_pixels.append(float((difference.max(axis=-1) > VISIBLE_LEVELS).mean()))
        blend_strips = stored - set(strips.values())
        kept = set(shown.values()) | blend_strips
        saved = sum(size[d] for d in stored - kept)
        runs.append(
            {
                "fraction": fraction,
                "max_error": fraction * threshold,
                "reused": len(errors),
                "reused_share": len(errors) / max(len(clips), 1),
                "bytes_saved_per_frame": saved / frames,
                "strip_bytes_per_frame_after": sum(size[d] for d in kept) / frames,
                "error_over_threshold": _quantiles(errors),
                "zero_error": sum(1 for e in errors if e == 0.0),
                "descriptor_distance": _quantiles(distances),
                "pixel_mean_abs_difference": _quantiles(mean_pixels),
                "pixel_visible_share": _quantiles(visible_pixels),
                "search_seconds_per_clip": seconds / max(len(clips), 1),
            }
        )
    if sheet is not None and substitutes:
        worst = sorted(substitutes.items(), key=lambda item: -item[1].error)[:SHEET_PAIRS]
        tiles = []
        for clip, found in worst:
            middle = k // 2
            tiles.append(Tile(images(strips[clip])[middle].astype(np.uint8), (f"clip {clip}",)))
            caption = (
                f"clip {found.clip}, shown instead",
                f"error {found.error / threshold:.2f} x threshold",
            )
            tiles.append(Tile(images(strips[found.clip])[middle].astype(np.uint8), caption))
        title = (
            f"{loaded.entry.name}: worst substitutions at {fractions[-1]} x the high-error "
            f"threshold, frame {k // 2 + 1} of {k}"
        )
        picture = Image.fromarray(contact_sheet(title, tiles, columns=4))
        picture.quantize(colors=128, method=Image.Quantize.MEDIANCUT).save(sheet, optimize=True)
    shared = len(strips) - len(set(strips.values()))
    nearest = AnimationReuse.of_graph(loaded, {}, np.inf)
    nearest_errors = []
    for clip in clips:
        found = nearest.substitute(features[clip])
        if found is not None:
            nearest_errors.append(found.error / threshold)
        nearest.note(clip, strips[clip], rendered=True)
    motion = [float(np.abs(np.diff(images(strips[clip]), axis=0)).mean()) for clip in clips[:64]]
    return {
        "graph": loaded.entry.name,
        "size_frames": graph.size_frames,
        "clips": graph.n_clips,
        "clips_with_strips": len(strips),
        "clips_already_sharing": shared,
        "high_error_threshold": threshold,
        "configured_fraction": settings.render.dedup_error_fraction,
        "strip_bytes_per_frame": sum(size.values()) / frames,
        "clip_strip_bytes_per_frame": sum(size[d] for d in set(strips.values())) / frames,
        "visible_levels": VISIBLE_LEVELS,
        "nearest_error_over_threshold": _quantiles(nearest_errors),
        "frame_to_frame_pixel_mean_abs_difference": _quantiles(motion),
        "runs": runs,
    }
