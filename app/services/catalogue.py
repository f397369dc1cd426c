"""The graph catalogue as the shells read it: the graphs, one graph's entry and size, its
publications, and a publication's edges.

Shells reach the store only through services (docs/design.md, "Layers"); this module is
that door for reads of the catalogue. A graph is handed out as a
:class:`~app.core.graph.graph_entry.GraphEntry`, a value, so that no shell keeps an ORM row past
the session it came from.
"""

from __future__ import annotations

from sqlalchemy.orm import Session

from app.core.graph.graph_entry import GraphEntry
from app.store.animations import count_missing_animations
from app.store.graph_catalogue import graph_entry as find_graph
from app.store.graph_catalogue import graph_ids, size_frames
from app.store.publications import (
    GraphListing,
    PublicationSummary,
    PublishedEdge,
    get_publication,
    graph_listings,
    graph_publication,
    graph_publications,
    latest_publication_id,
    published_edges,
)

__all__ = [
    "GraphEntry",
    "GraphListing",
    "PublicationSummary",
    "PublishedEdge",
    "find_graph",
    "get_publication",
    "graph_ids",
    "graph_listings",
    "graph_publication",
    "graph_publications",
    "latest_publication_id",
    "missing_animations",
    "published_edges",
    "size_frames",
]


def missing_animations(session: Session, name_or_id: str | int) -> int:
    """Edges of the graph a publication with renders would still have to render."""
    return count_missing_animations(session, find_graph(session, name_or_id).id)
