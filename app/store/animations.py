"""Which clips and edges have an animation strip, attaching new ones, taking rotted ones
off, and what a stored strip was rendered from.

A SIM edge shows its clip's strip (rendered once per clip, kept on the clip row); a BLEND
edge shows its own blend. Saving a changed edge drops its strip
(:func:`app.store.graph_persistence.save_graph`), so these queries find what to render again.
"""

from __future__ import annotations

from collections.abc import Collection, Iterable, Mapping
from typing import NamedTuple

import numpy as np
from sqlalchemy import ColumnElement, func, select, update
from sqlalchemy.orm import Session

from app.core.errors import NotFound
from app.core.graph.dynamics import ClipFeatures
from app.core.graph.state_graph import EdgeKind, edge_index, edge_vertex_control
from app.models import Artifact, Clip, Edge, PublicationEdge
from app.store.artifacts import ArtifactStore
from app.store.clipbank import ShapeOf
from app.store.graph_catalogue import clip_bundle_digest, get_graph_row
from app.store.graph_persistence import (
    CLIP_FEATURE_COLUMNS,
    stored_descriptor,
    stored_potential,
)

#: animations are videos (image strips before); every other artifact is internal
ANIMATION_MEDIA_PREFIXES = ("image/", "video/")


def set_animations(
    session: Session,
    graph_id: int,
    *,
    clips: Mapping[int, str] | None = None,
    edges: Mapping[int, str] | None = None,
) -> None:
    """Attach rendered animation artifacts to clips (by index) and edges (by edge index)."""
    row = get_graph_row(session, graph_id)
    if clips:
        session.execute(
            update(Clip),
            [{"graph_id": graph_id, "idx": i, "animation": h} for i, h in clips.items()],
        )
    if edges:
        n = row.n_controls
        session.execute(
            update(Edge),
            [
                {"graph_id": graph_id, "vertex": v, "control": c, "animation": h}
                for e, h in edges.items()
                for v, c in [edge_vertex_control(e, n)]
            ],
        )


def drop_animations(session: Session, graph_id: int, digests: Collection[str]) -> None:
    """Take the strips ``digests`` off every clip and edge of the graph that shows them, so
    that rendering what is missing gives those clips and edges a strip again."""
    if not digests:
        return
    for table in (Clip, Edge):
        session.execute(
            update(table)
            .where(table.graph_id == graph_id, table.animation.in_(list(digests)))
            .values(animation=None)
        )


def edges_without_animation(
    session: Session,
    graph_id: int,
    n_controls: int,
    *,
    vertices: Iterable[int] | None = None,
    kind: EdgeKind | None = None,
) -> list[int]:
    """The graph's edges (by index) that have no strip, optionally only of ``vertices``
    and of one ``kind``."""
    stmt = select(Edge.vertex, Edge.control).where(
        Edge.graph_id == graph_id, Edge.animation.is_(None)
    )
    if vertices is not None:
        stmt = stmt.where(Edge.vertex.in_(list(vertices)))
    if kind is not None:
        stmt = stmt.where(Edge.kind == int(kind))
    return [edge_index(vertex, control, n_controls) for vertex, control in session.execute(stmt)]


def clip_animations(session: Session, graph_id: int) -> dict[int, str]:
    """The strip of every clip that has one, by clip index."""
    rows = session.execute(
        select(Clip.idx, Clip.animation).where(
            Clip.graph_id == graph_id, Clip.animation.is_not(None)
        )
    )
    return {clip: animation for clip, animation in rows if animation is not None}


class ClipRow(NamedTuple):
    """A clip of the graph with the columns comparing clips needs, and its strip if any."""

    clip: int
    control: int
    kinetic: float
    potential: np.ndarray
    score: float
    descriptor: np.ndarray
    bundle: str
    animation: str | None


def rendered_clips(session: Session, graph_id: int, control: int) -> list[ClipRow]:
    """Every clip of the graph under ``control`` that has a strip, in clip order
    (descriptors as stored): the only clips that may stand in for one of that control."""
    return _clip_columns(
        session,
        (Clip.graph_id == graph_id, Clip.control == control, Clip.animation.is_not(None)),
    )


def stored_clip(session: Session, graph_id: int, clip: int) -> ClipRow:
    """One clip of the graph, with or without a strip."""
    found = _clip_columns(session, (Clip.graph_id == graph_id, Clip.idx == clip))
    if not found:
        raise NotFound(f"graph {graph_id} has no clip {clip}")
    return found[0]


def _clip_columns(session: Session, where: tuple[ColumnElement[bool], ...]) -> list[ClipRow]:
    rows = session.execute(
        select(Clip.idx, *CLIP_FEATURE_COLUMNS, Clip.animation).where(*where).order_by(Clip.idx)
    )
    return [
        ClipRow(
            clip=idx,
            control=control,
            kinetic=kinetic,
            potential=stored_potential(potential),
            score=score,
            descriptor=stored_descriptor(descriptor),
            bundle=bundle,
            animation=animation,
        )
        for idx, control, kinetic, potential, score, descriptor, bundle, animation in rows
    ]


def rendered_clip_features(
    artifacts: ArtifactStore, clip: ClipRow, shape_of: ShapeOf
) -> ClipFeatures:
    """The clip's features, its occupancy and descriptor derived from its bundle's frames."""
    return clip_features(clip, shape_of(artifacts.get_arrays(clip.bundle, ("frames",))["frames"]))


def clip_features(clip: ClipRow, shape: tuple[np.ndarray, np.ndarray]) -> ClipFeatures:
    """The clip's features from its columns and its (occupancy, descriptor)."""
    occupancy, descriptor = shape
    return ClipFeatures(
        control=clip.control,
        kinetic=clip.kinetic,
        potential=clip.potential,
        occupancy=occupancy,
        descriptor=descriptor,
        score=clip.score,
    )


def count_missing_animations(session: Session, graph_id: int) -> int:
    """How many of the graph's edges have no strip yet."""
    count = session.scalar(
        select(func.count()).where(Edge.graph_id == graph_id, Edge.animation.is_(None))
    )
    return int(count or 0)


class PublishedStrip(NamedTuple):
    """An edge of a publication that has a strip."""

    vertex: int
    control: int
    kind: int
    err: float
    animation: str


def publication_animations(session: Session, publication_id: int) -> list[PublishedStrip]:
    """Every edge of the publication that has a strip, in edge order."""
    rows = session.execute(
        select(
            PublicationEdge.vertex,
            PublicationEdge.control,
            PublicationEdge.kind,
            PublicationEdge.err,
            PublicationEdge.animation,
        )
        .where(
            PublicationEdge.publication_id == publication_id,
            PublicationEdge.animation.is_not(None),
        )
        .order_by(PublicationEdge.vertex, PublicationEdge.control)
    )
    return [
        PublishedStrip(vertex, control, kind, err, animation)
        for vertex, control, kind, err, animation in rows
        if animation is not None
    ]


def animation_media_type(session: Session, digest: str) -> str | None:
    """The media type of an animation artifact; None for unknown artifacts and those that
    are neither images nor videos (clip bundles are internal data, never served)."""
    media_type = session.scalar(select(Artifact.media_type).where(Artifact.hash == digest))
    if media_type is None or not media_type.startswith(ANIMATION_MEDIA_PREFIXES):
        return None
    return media_type


def graph_animations(session: Session, graph_id: int) -> set[str]:
    """Every strip the graph's clips and edges hold (each stored once)."""
    clips = select(Clip.animation).where(Clip.graph_id == graph_id, Clip.animation.is_not(None))
    edges = select(Edge.animation).where(Edge.graph_id == graph_id, Edge.animation.is_not(None))
    return {digest for digest in session.scalars(clips.union(edges)) if digest is not None}


class StripSource(NamedTuple):
    """What a stored strip shows: the frames of the clip stored as ``bundle``, blended into
    those of ``blend_into`` when not None (a BLEND edge's eq. 8)."""

    graph_id: int
    bundle: str
    blend_into: str | None


def strip_source(session: Session, digest: str) -> StripSource | None:
    """What the strip ``digest`` was rendered from, read off the first clip holding it (its
    owner, :func:`app.core.graph.dedup.animation_owners`: later clips holding it stand in), else
    the first edge holding it; None when neither does (only older publications show it).

    A live edge's strip shows the edge as it is: saving a changed edge drops its strip.
    """
    owner = session.execute(
        select(Clip.graph_id, Clip.bundle)
        .where(Clip.animation == digest)
        .order_by(Clip.graph_id, Clip.idx)
        .limit(1)
    ).first()
    if owner is not None:
        return StripSource(int(owner[0]), owner[1], None)
    edge = session.execute(
        select(Edge.graph_id, Edge.kind, Edge.clip_idx, Edge.target)
        .where(Edge.animation == digest)
        .order_by(Edge.graph_id, Edge.vertex, Edge.control)
        .limit(1)
    ).first()
    if edge is None:
        return None
    graph_id, kind, clip, target = int(edge[0]), int(edge[1]), int(edge[2]), edge[3]
    bundle = clip_bundle_digest(session, graph_id, clip)
    if bundle is None:
        return None
    if kind != EdgeKind.BLEND or target is None:
        return StripSource(graph_id, bundle, None)
    vertex, control = edge_vertex_control(int(target), get_graph_row(session, graph_id).n_controls)
    target_clip = session.scalar(
        select(Edge.clip_idx).where(
            Edge.graph_id == graph_id, Edge.vertex == vertex, Edge.control == control
        )
    )
    into = None if target_clip is None else clip_bundle_digest(session, graph_id, target_clip)
    return None if into is None else StripSource(graph_id, bundle, into)
