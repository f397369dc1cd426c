"""``srg bench bytes``: everything a stored graph keeps, per simulated frame and by kind.

``srg bench clip`` sizes what one new clip adds; a grown graph also keeps a strip for
every blend edge (about two per simulated clip with three controls), shares strips and
bundles between equal or nearly equal clips, and holds array columns in its rows. This
measures the whole, as the paper counts its graphs (bytes over simulated frames).
"""

from __future__ import annotations

from collections import Counter
from typing import Any

from app.config import Settings
from app.db.sessions import transaction
from app.services.loading import artifact_store
from app.store.array_codec import read_member_sizes
from app.store.footprint import graph_bundles, graph_footprint
from app.store.graph_catalogue import get_graph_row


def bench_bytes(settings: Settings, name: str) -> dict[str, Any]:
    """The graph's bytes by kind, in all and per simulated frame, and its counts.

    ``array_columns``: the clips' descriptor and potential columns; the fixed-size columns
    of the rows (a few dozen bytes each) are reported as row counts only.
    ``unshown_clip_strips``: the part of ``clip_strips`` that no edge shows (strips of
    clips that end on a blend edge, shown only once that edge is expanded).
    ``bundle_members_per_frame``: the bundles' bytes by member (end state, frames; the
    older bundles' occupancy and descriptor), read from each bundle's header; bundles
    written before the arrays codec (npz) are counted under ``npz``.
    """
    with transaction(settings) as session:
        row = get_graph_row(session, name)
        footprint = graph_footprint(session, row.id)
        bundles = graph_bundles(session, row.id)
        frames_per_clip = row.frames_per_clip
    artifacts = artifact_store(settings)
    members: Counter[str] = Counter()
    for digest in bundles:
        path = artifacts.path_for(digest)
        with path.open("rb") as stream:
            sizes = read_member_sizes(stream)
        members.update({"npz": path.stat().st_size} if sizes is None else sizes)
    frames = footprint.clips * frames_per_clip
    stored = {
        "bundles": footprint.bundle_bytes,
        "clip_strips": footprint.sim_strip_bytes,
        "blend_strips": footprint.blend_strip_bytes,
        "array_columns": footprint.array_column_bytes,
    }
    stored["total"] = sum(stored.values())
    return {
        "graph": name,
        "simulated_frames": frames,
        "counts": {
            "clips": footprint.clips,
            "vertices": footprint.vertices,
            "sim_edges": footprint.sim_edges,
            "blend_edges": footprint.blend_edges,
        },
        "bytes": stored,
        "bytes_per_frame": {kind: round(size / max(frames, 1)) for kind, size in stored.items()},
        "unshown_clip_strips_per_frame": round(footprint.unshown_strip_bytes / max(frames, 1)),
        "bundle_members_per_frame": {
            member: round(size / max(frames, 1)) for member, size in sorted(members.items())
        },
    }
