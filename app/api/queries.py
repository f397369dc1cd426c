"""Read-side SQL of the API: the graph list and a publication as clients download it."""

from __future__ import annotations

from typing import Any

from sqlalchemy import func, select
from sqlalchemy.orm import Session

from app.api.schemas import EdgeOut, GraphSummary, PublicationOut
from app.core.graph import EdgeKind
from app.models import Artifact, Graph, PublicationEdge
from app.models import Publication as PublicationRow

DEFAULT_FPS = 30.0
ANIMATION_MEDIA_PREFIX = "image/"


def list_graphs(session: Session) -> list[GraphSummary]:
    latest = (
        select(PublicationRow.graph_id, func.max(PublicationRow.id).label("publication_id"))
        .group_by(PublicationRow.graph_id)
        .subquery()
    )
    rows = session.execute(
        select(
            Graph.name,
            Graph.dynamics,
            Graph.n_controls,
            Graph.frames_per_clip,
            latest.c.publication_id,
        )
        .outerjoin(latest, latest.c.graph_id == Graph.id)
        .order_by(Graph.id)
    ).all()
    return [
        GraphSummary(
            name=name,
            dynamics=dynamics,
            n_controls=n_controls,
            frames_per_clip=frames,
            latest_publication=publication_id,
        )
        for name, dynamics, n_controls, frames, publication_id in rows
    ]


def publication_out(session: Session, graph: Graph, publication_id: int) -> PublicationOut:
    """Every edge of the publication, grouped per vertex in control order."""
    row = session.get(PublicationRow, publication_id)
    assert row is not None
    edges = session.execute(
        select(
            PublicationEdge.dst,
            PublicationEdge.kind,
            PublicationEdge.err,
            PublicationEdge.score,
            PublicationEdge.animation,
        )
        .where(PublicationEdge.publication_id == publication_id)
        .order_by(PublicationEdge.vertex, PublicationEdge.control)
    ).all()
    n, k = graph.n_controls, graph.frames_per_clip
    out = [
        EdgeOut(
            dst=dst,
            kind="sim" if kind == EdgeKind.SIM else "blend",
            err=err,
            score=score,
            animation=None if animation is None else f"/api/animations/{animation}",
            poster=None if animation is None else f"/api/animations/{animation}/poster?frames={k}",
        )
        for dst, kind, err, score, animation in edges
    ]
    scene: dict[str, Any] = graph.scene or {}
    return PublicationOut(
        graph=graph.name,
        publication_id=row.id,
        number=row.number,
        start=row.start,
        n_controls=n,
        frames_per_clip=graph.frames_per_clip,
        fps=float(scene.get("fps", DEFAULT_FPS)),
        n_vertices=len(out) // n,
        vertices=[out[v * n : (v + 1) * n] for v in range(len(out) // n)],
    )


def animation_media_type(session: Session, digest: str) -> str | None:
    """The media type of an animation artifact; None for unknown or non-image artifacts."""
    media_type = session.scalar(select(Artifact.media_type).where(Artifact.hash == digest))
    if media_type is None or not media_type.startswith(ANIMATION_MEDIA_PREFIX):
        return None
    return media_type
