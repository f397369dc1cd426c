"""Animation strips: a clip's frames, or eq. 8's blend of an edge, rendered and stored.

The epochs render the strips of what they add; publishing renders whatever is still
missing. Both call these, so a strip is the same whoever renders it.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from sqlalchemy.orm import Session

from app.core.dynamics import Dynamics
from app.core.graph import EdgeKind
from app.render.animation import STRIP_MEDIA_TYPE, encode_strip
from app.services.loading import LoadedGraph
from app.store.animations import clip_animations, edges_without_animation, set_animations
from app.store.artifacts import ArtifactStore

Progress = Callable[[int], None]


def frames_strip(
    session: Session, artifacts: ArtifactStore, dynamics: Dynamics, frames: np.ndarray
) -> str:
    """Render ``frames`` and store the encoded strip; its artifact digest."""
    return artifacts.put_bytes(
        encode_strip(dynamics.render(frames)), media_type=STRIP_MEDIA_TYPE, session=session
    )


def blend_strip(session: Session, loaded: LoadedGraph, edge: int) -> str:
    """The strip of a BLEND edge: its dead-end clip blended into its target's clip."""
    graph, bank = loaded.graph, loaded.bank
    target_clip = graph.edge_clip[graph.edge_target[edge]]
    frames = loaded.dynamics.blend(bank.frames(graph.edge_clip[edge]), bank.frames(target_clip))
    return frames_strip(session, loaded.artifacts, loaded.dynamics, frames)


def render_missing_animations(
    session: Session, loaded: LoadedGraph, progress: Progress | None = None
) -> int:
    """Render every edge that has no animation yet; return how many were rendered.

    A SIM edge shows its clip (rendered once per clip and kept on the clip row); a BLEND
    edge shows eq. 8's blend of its dead-end clip into its target's clip.
    """
    graph_id, graph = loaded.row.id, loaded.graph
    missing = edges_without_animation(session, graph_id, graph.n_controls)
    rendered_clips = clip_animations(session, graph_id)
    new_clips: dict[int, str] = {}
    edges: dict[int, str] = {}
    for edge in missing:
        clip = graph.edge_clip[edge]
        if graph.edge_kind[edge] == EdgeKind.SIM:
            digest = rendered_clips.get(clip) or new_clips.get(clip)
            if digest is None:
                frames = loaded.bank.frames(clip)
                digest = frames_strip(session, loaded.artifacts, loaded.dynamics, frames)
                new_clips[clip] = digest
        else:
            digest = blend_strip(session, loaded, edge)
        edges[edge] = digest
        if progress is not None:
            progress(1)
    set_animations(session, graph_id, clips=new_clips, edges=edges)
    return len(edges)
