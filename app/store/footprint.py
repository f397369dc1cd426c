"""What one stored graph occupies: its artifacts by kind, its array columns, its rows.

Artifacts are content-addressed, so each is counted once per graph however many clips or
edges point at it (a strip shared by two clips, a bundle of two equal clips); one held
by another graph as well is counted in both.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from sqlalchemy import Select, func, select
from sqlalchemy.orm import Session

from app.core.graph.state_graph import EdgeKind
from app.models import Artifact, Clip, Edge, Vertex


@dataclass(frozen=True)
class GraphFootprint:
    """Bytes and rows of one graph (``strips``: by the kind of edge that shows them)."""

    clips: int
    vertices: int
    sim_edges: int
    blend_edges: int
    bundle_bytes: int
    sim_strip_bytes: int
    blend_strip_bytes: int
    #: of ``sim_strip_bytes``, the strips of clips on blend edges that no edge shows
    unshown_strip_bytes: int
    array_column_bytes: int


def graph_footprint(session: Session, graph_id: int) -> GraphFootprint:
    """The graph's footprint; a strip shown by both kinds of edge counts as a clip's."""
    bundles = select(Clip.bundle).where(Clip.graph_id == graph_id)
    clip_strips = select(Clip.animation).where(Clip.graph_id == graph_id)
    sim_strips = select(Edge.animation).where(Edge.graph_id == graph_id, Edge.kind == EdgeKind.SIM)
    blend_strips = select(Edge.animation).where(
        Edge.graph_id == graph_id, Edge.kind == EdgeKind.BLEND
    )
    sim_edge = _sizes(session, sim_strips)
    sim = _sizes(session, clip_strips) | sim_edge
    blend = _sizes(session, blend_strips)
    shown = set(sim_edge) | set(blend)
    on_blend_edges = (
        select(Clip.animation)
        .join(Edge, (Edge.graph_id == Clip.graph_id) & (Edge.clip_idx == Clip.idx))
        .where(Clip.graph_id == graph_id, Edge.kind == EdgeKind.BLEND)
    )
    unshown = _sizes(session, on_blend_edges)
    edges = dict(
        session.execute(
            select(Edge.kind, func.count()).where(Edge.graph_id == graph_id).group_by(Edge.kind)
        ).all()
    )
    columns = session.execute(
        select(
            func.count(),
            func.coalesce(func.sum(func.length(Clip.descriptor) + func.length(Clip.potential)), 0),
        ).where(Clip.graph_id == graph_id)
    ).one()
    vertices = session.scalar(select(func.count()).where(Vertex.graph_id == graph_id)) or 0
    return GraphFootprint(
        clips=int(columns[0]),
        vertices=int(vertices),
        sim_edges=int(edges.get(EdgeKind.SIM, 0)),
        blend_edges=int(edges.get(EdgeKind.BLEND, 0)),
        bundle_bytes=sum(_sizes(session, bundles).values()),
        sim_strip_bytes=sum(sim.values()),
        blend_strip_bytes=sum(size for digest, size in blend.items() if digest not in sim),
        unshown_strip_bytes=sum(size for digest, size in unshown.items() if digest not in shown),
        array_column_bytes=int(columns[1]),
    )


def graph_bundles(session: Session, graph_id: int) -> list[str]:
    """The distinct bundle artifacts of a graph's clips."""
    return list(
        session.scalars(select(Clip.bundle).where(Clip.graph_id == graph_id).distinct()).all()
    )


def _sizes(session: Session, digests: Select[Any]) -> dict[str, int]:
    """Size of each distinct artifact among ``digests`` (a select of hashes)."""
    chosen = select(Artifact.hash, Artifact.size).where(Artifact.hash.in_(digests))
    return {digest: int(size) for digest, size in session.execute(chosen).all()}
