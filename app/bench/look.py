"""``srg bench look NAME``: how dark a stored graph's rendered clips are.

Every clip strip of the graph is decoded and each frame's share of near-black pixels
(:mod:`app.render.look`) measured; the report gives its percentiles over all frames,
the share of frames above half a percent, and the worst clip and frame, to look at
(docs/render.md). On the liquid it also counts the near-black pixels inside the water's
silhouette, computed from the SDF frames of the clip the strip was rendered from (the
first clip holding it: a strip may stand for nearly identical later clips,
docs/dedup.md), with the renderer's own camera.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from app.config import Settings
from app.core.errors import NotFound
from app.core.liquid.silhouette import silhouette_projector, silhouettes, tank_camera
from app.core.liquid.surface import dequantise_sdf
from app.db.sessions import database_sessions
from app.liquid.adapter import LiquidDynamics
from app.render.animation import decode_strip
from app.render.look import DARK_LEVEL, dark_fractions, dark_inside, fraction_percentiles
from app.services.loading import artifact_store, graph_dynamics
from app.store.animations import clip_animations
from app.store.array_codec import decode_arrays
from app.store.artifacts import ArtifactStore
from app.store.graph_catalogue import clip_bundle_digest, graph_entry

#: a frame with more near-black pixels than this share counts as showing shards
SHARD_FRAME = 0.005


def _inside_silhouette(
    dyn: LiquidDynamics,
    store: ArtifactStore,
    bundles: dict[int, str],
    images: dict[int, np.ndarray],
) -> np.ndarray:
    """Near-black pixels per frame inside the water, over the clips stored as ``bundles``."""
    height, width = next(iter(images.values())).shape[1:3]
    projector = silhouette_projector(tank_camera(dyn.scene.tank, width, height), dyn.grid)
    counts = []
    for clip, bundle in bundles.items():
        frames = decode_arrays(store.get_bytes(bundle), ("frames",))["frames"]
        water = silhouettes(projector, dequantise_sdf(dyn.grid, frames))
        counts.append(dark_inside(images[clip], water))
    return np.concatenate(counts)


def bench_look(settings: Settings, name: str) -> dict[str, Any]:
    with database_sessions(settings)() as session:
        entry = graph_entry(session, name)
        strips = clip_animations(session, entry.id)
        frames_per_clip = entry.frames_per_clip
        source = {digest: clip for clip, digest in sorted(strips.items(), reverse=True)}
        bundles = {clip: clip_bundle_digest(session, entry.id, clip) for clip in source.values()}
        dyn = graph_dynamics(entry, settings)
    if not strips:
        raise NotFound(f"graph {name!r} has no rendered clips: run srg publish {name}")
    store = artifact_store(settings)
    images = {digest: decode_strip(store.get_bytes(digest), frames_per_clip) for digest in source}
    per_clip = {clip: dark_fractions(images[digest]) for clip, digest in sorted(strips.items())}
    every = np.concatenate(list(per_clip.values()))
    worst_clip = max(per_clip, key=lambda clip: float(per_clip[clip].max()))
    report: dict[str, Any] = {
        "graph": name,
        "clips": len(per_clip),
        "frames": int(every.size),
        "dark_level": DARK_LEVEL,
        "dark_fraction": fraction_percentiles(every),
        "frames_above_half_percent": float(np.mean(every > SHARD_FRAME)),
        "worst": {"clip": worst_clip, "frame": int(per_clip[worst_clip].argmax())},
        "dark_inside_water": None,
    }
    if isinstance(dyn, LiquidDynamics):
        stored = {clip: bundle for clip, bundle in bundles.items() if bundle is not None}
        inside = _inside_silhouette(
            dyn, store, stored, {clip: images[strips[clip]] for clip in stored}
        )
        report["dark_inside_water"] = {
            "strips": len(bundles),
            "pixels": int(inside.sum()),
            "frames_with_any": int(np.count_nonzero(inside)),
            "max_per_frame": int(inside.max()),
        }
    return report
