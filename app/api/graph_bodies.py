"""The bodies of the graph routes (:mod:`app.api.routes.graphs`): what clients download,
the graph list, a graph's publications and a publication.

The rows come from :mod:`app.services.catalogue`; here they become the schemas, with
the figures a player reads beside the game (the graph's size when published, how much
of it is blends and how far those blends are from the simulation).
"""

from __future__ import annotations

from sqlalchemy.orm import Session

from app.api.schemas import EdgeOut, GraphSummary, PublicationListed, PublicationOut
from app.core.graph.state_graph import EdgeKind
from app.services.catalogue import (
    GraphEntry,
    PublishedEdge,
    get_publication,
    graph_listings,
    graph_publications,
    published_edges,
)


def list_graphs(session: Session) -> list[GraphSummary]:
    return [GraphSummary(**listing._asdict()) for listing in graph_listings(session)]


def list_publications(session: Session, graph: GraphEntry) -> list[PublicationListed]:
    """The graph's publications, oldest first."""
    return [
        PublicationListed(
            publication_id=row.id,
            number=row.number,
            created_at=row.created_at,
            size_frames=row.size_frames,
            n_vertices=row.n_vertices,
            n_edges=row.n_edges,
        )
        for row in graph_publications(session, graph.id)
    ]


def blend_figures(edges: list[PublishedEdge]) -> tuple[float, float]:
    """The share of blend edges and their mean error (0 for a publication without blends)."""
    errors = [edge.err for edge in edges if edge.kind == EdgeKind.BLEND]
    if not errors:
        return 0.0, 0.0
    return len(errors) / len(edges), sum(errors) / len(errors)


def publication_out(session: Session, graph: GraphEntry, publication_id: int) -> PublicationOut:
    """Every edge of the publication, grouped per vertex in control order."""
    row = get_publication(session, publication_id)
    edges = published_edges(session, publication_id)
    n, k = graph.n_controls, graph.frames_per_clip
    out = [
        EdgeOut(
            dst=edge.dst,
            kind="sim" if edge.kind == EdgeKind.SIM else "blend",
            err=edge.err,
            score=edge.score,
            animation=None if edge.animation is None else f"/api/animations/{edge.animation}",
            poster=None
            if edge.animation is None
            else f"/api/animations/{edge.animation}/poster?frames={k}",
        )
        for edge in edges
    ]
    blend_share, mean_blend_error = blend_figures(edges)
    return PublicationOut(
        graph=graph.name,
        publication_id=row.id,
        number=row.number,
        start=row.start,
        n_controls=n,
        frames_per_clip=graph.frames_per_clip,
        fps=graph.fps,
        size_frames=row.size_frames,
        blend_share=blend_share,
        mean_blend_error=mean_blend_error,
        n_vertices=len(out) // n,
        vertices=[out[v * n : (v + 1) * n] for v in range(len(out) // n)],
    )
