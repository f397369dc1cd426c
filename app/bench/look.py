"""``srg bench look NAME``: how dark a stored graph's rendered clips are.

Every clip strip of the graph is decoded and each frame's share of near-black pixels
(:func:`app.render.look.dark_fractions`) measured; the report gives its percentiles over
all frames, the share of frames above half a percent, and the worst clip and frame, to
look at (docs/render.md).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from app.config import Settings
from app.core.errors import NotFound
from app.db import session_factory
from app.render.animation import decode_strip
from app.render.look import DARK_LEVEL, dark_fractions
from app.services.loading import artifact_store
from app.store.animations import clip_animations
from app.store.graphs import get_graph_row

#: a frame with more near-black pixels than this share counts as showing shards
SHARD_FRAME = 0.005


def bench_look(settings: Settings, name: str) -> dict[str, Any]:
    with session_factory()() as session:
        row = get_graph_row(session, name)
        strips = clip_animations(session, row.id)
        frames_per_clip = row.frames_per_clip
    if not strips:
        raise NotFound(f"graph {name!r} has no rendered clips: run srg publish {name}")
    store = artifact_store(settings)
    per_clip = {
        clip: dark_fractions(decode_strip(store.get_bytes(digest), frames_per_clip))
        for clip, digest in sorted(strips.items())
    }
    every = np.concatenate(list(per_clip.values()))
    worst_clip = max(per_clip, key=lambda clip: float(per_clip[clip].max()))
    return {
        "graph": name,
        "clips": len(per_clip),
        "frames": int(every.size),
        "dark_level": DARK_LEVEL,
        "dark_fraction": {
            "median": float(np.median(every)),
            "p90": float(np.percentile(every, 90)),
            "p99": float(np.percentile(every, 99)),
            "max": float(every.max()),
        },
        "frames_above_half_percent": float(np.mean(every > SHARD_FRAME)),
        "worst": {"clip": worst_clip, "frame": int(per_clip[worst_clip].argmax())},
    }
