"""Publications: frozen, playable copies of a graph's edges.

A publication copies every edge (destination, kind, error, score, animation) in one bulk
insert, so growth can rewrite the live edges while players keep playing, and a trace can
always be read against exactly the edges its player saw.
"""

from __future__ import annotations

from datetime import datetime
from typing import NamedTuple

import numpy as np
from sqlalchemy import func, select
from sqlalchemy.orm import Session

from app.core.errors import NotFound
from app.core.graph.publication import Publication, freeze
from app.core.graph.state_graph import StateGraph, edge_index, edge_vertex_control
from app.models import Edge, Graph, PublicationEdge
from app.models import Publication as PublicationRow
from app.store._sql import bulk_insert
from app.store.graph_catalogue import get_graph_row
from app.store.graph_persistence import require_saved


class GraphListing(NamedTuple):
    """A graph as the catalogue lists it, with its latest publication's number (None
    before one; as ``srg status`` shows it) and whether that publication has animations
    (those made for bots have none)."""

    name: str
    dynamics: str
    n_controls: int
    frames_per_clip: int
    latest_publication: int | None
    animated: bool


class PublishedEdge(NamedTuple):
    """One frozen edge as a client downloads it; ``animation`` is the strip's digest."""

    dst: int
    kind: int
    err: float
    score: float
    animation: str | None


class PublicationNotFound(NotFound):
    """No publication with that id."""


class NothingPublished(NotFound):
    """The graph has no publication to play yet."""


def publish(
    session: Session, graph_id: int, graph: StateGraph, *, threshold: float | None = None
) -> int:
    """Freeze the saved ``graph`` as the graph's next publication; return its id.

    The graph must be saved first (:class:`~app.store.graph_persistence.StaleGraph` otherwise), so
    the copied animations belong to the edges being published. ``threshold`` is the
    high-error threshold in force, stored with it for SQL over the analytics views (None:
    not known, as for a publication a test or benchmark makes of a bare graph).
    """
    require_saved(session, graph_id, graph)
    frozen = freeze(graph)
    last = session.scalar(
        select(func.max(PublicationRow.number)).where(PublicationRow.graph_id == graph_id)
    )
    row = PublicationRow(
        graph_id=graph_id,
        number=(last or 0) + 1,
        n_vertices=graph.n_vertices,
        n_edges=graph.n_edges,
        size_frames=graph.size_frames,
        start=graph.start,
        high_error_threshold=threshold,
    )
    session.add(row)
    session.flush()
    animations = {
        edge: animation
        for edge, animation in session.execute(
            select(edge_index(Edge.vertex, Edge.control, graph.n_controls), Edge.animation).where(
                Edge.graph_id == graph_id, Edge.animation.is_not(None)
            )
        )
    }
    bulk_insert(
        session,
        PublicationEdge,
        [
            {
                "publication_id": row.id,
                "vertex": vertex,
                "control": control,
                "dst": int(frozen.edge_dst[e]),
                "kind": int(frozen.edge_kind[e]),
                "err": float(frozen.edge_err[e]),
                "score": float(frozen.edge_score[e]),
                "animation": animations.get(e),
            }
            for e in range(graph.n_edges)
            for vertex, control in [edge_vertex_control(e, graph.n_controls)]
        ],
    )
    return row.id


class PublicationSummary(NamedTuple):
    """A publication's row as a value: what callers above the store read of it."""

    id: int
    graph_id: int
    number: int
    start: int
    size_frames: int
    n_vertices: int
    n_edges: int
    created_at: datetime


def _summary(row: PublicationRow) -> PublicationSummary:
    return PublicationSummary(
        row.id,
        row.graph_id,
        row.number,
        row.start,
        row.size_frames,
        row.n_vertices,
        row.n_edges,
        row.created_at,
    )


def _publication_row(session: Session, publication_id: int) -> PublicationRow:
    row = session.get(PublicationRow, publication_id)
    if row is None:
        raise PublicationNotFound(f"no publication {publication_id}")
    return row


def get_publication(session: Session, publication_id: int) -> PublicationSummary:
    return _summary(_publication_row(session, publication_id))


def load_publication(session: Session, publication_id: int) -> Publication:
    row = _publication_row(session, publication_id)
    n_controls = get_graph_row(session, row.graph_id).n_controls
    edges = session.execute(
        select(
            PublicationEdge.dst, PublicationEdge.kind, PublicationEdge.err, PublicationEdge.score
        )
        .where(PublicationEdge.publication_id == publication_id)
        .order_by(PublicationEdge.vertex, PublicationEdge.control)
    ).all()
    columns = np.array(edges, dtype=np.float64).reshape(len(edges), 4)
    return Publication(
        n_controls=n_controls,
        start=row.start,
        edge_dst=columns[:, 0].astype(np.int64),
        edge_kind=columns[:, 1].astype(np.int8),
        edge_err=columns[:, 2],
        edge_score=columns[:, 3],
    )


def graph_publication(session: Session, graph_id: int, publication_id: int) -> PublicationSummary:
    """The publication ``publication_id`` if it is one of the graph's.

    :class:`PublicationNotFound` for another graph's too: ids count every graph's
    publications, so a caller that names the graph must not be handed another's.
    """
    row = session.get(PublicationRow, publication_id)
    if row is None or row.graph_id != graph_id:
        name = get_graph_row(session, graph_id).name
        raise PublicationNotFound(f"no publication {publication_id} of graph {name!r}")
    return _summary(row)


def graph_publications(session: Session, graph_id: int) -> list[PublicationSummary]:
    """Every publication of the graph, oldest first (by number: publication order)."""
    rows = session.scalars(
        select(PublicationRow)
        .where(PublicationRow.graph_id == graph_id)
        .order_by(PublicationRow.number)
    )
    return [_summary(row) for row in rows]


def latest_publication(session: Session, graph_id: int) -> PublicationSummary | None:
    """The graph's most recent publication, or None before the first."""
    row = session.scalars(
        select(PublicationRow)
        .where(PublicationRow.graph_id == graph_id)
        .order_by(PublicationRow.number.desc())
        .limit(1)
    ).one_or_none()
    return None if row is None else _summary(row)


def latest_publication_id(session: Session, graph: str | int) -> int:
    """The id of the latest publication of the graph named (or numbered) ``graph``.

    :class:`~app.store.graph_catalogue.GraphNotFound` without the graph, :class:`NothingPublished`
    before its first publication.
    """
    row = get_graph_row(session, graph)
    latest = latest_publication(session, row.id)
    if latest is None:
        raise NothingPublished(f"graph {row.name!r} has no publication yet: run `srg publish`")
    return latest.id


def graph_listings(session: Session) -> list[GraphListing]:
    """Every graph, in creation order, with the number of its latest publication (the
    one :func:`latest_publication` finds) and whether any of that publication's edges has
    an animation (the scan stops at the first that has one)."""
    highest = (
        select(PublicationRow.graph_id, func.max(PublicationRow.number).label("number"))
        .group_by(PublicationRow.graph_id)
        .subquery()
    )
    latest = (
        select(PublicationRow.id, PublicationRow.graph_id, PublicationRow.number)
        .join(
            highest,
            (highest.c.graph_id == PublicationRow.graph_id)
            & (highest.c.number == PublicationRow.number),
        )
        .subquery()
    )
    animated = (
        select(PublicationEdge.publication_id)
        .where(
            PublicationEdge.publication_id == latest.c.id,
            PublicationEdge.animation.is_not(None),
        )
        .exists()
    )
    rows = session.execute(
        select(
            Graph.name,
            Graph.dynamics,
            Graph.n_controls,
            Graph.frames_per_clip,
            latest.c.number,
            animated,
        )
        .outerjoin(latest, latest.c.graph_id == Graph.id)
        .order_by(Graph.id)
    )
    return [GraphListing(*row) for row in rows]


def published_edges(session: Session, publication_id: int) -> list[PublishedEdge]:
    """Every edge of the publication in edge order (vertex, then control)."""
    rows = session.execute(
        select(
            PublicationEdge.dst,
            PublicationEdge.kind,
            PublicationEdge.err,
            PublicationEdge.score,
            PublicationEdge.animation,
        )
        .where(PublicationEdge.publication_id == publication_id)
        .order_by(PublicationEdge.vertex, PublicationEdge.control)
    )
    return [PublishedEdge(*row) for row in rows]
