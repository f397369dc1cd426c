"""The graph catalogue as the shells read it: the graphs, one graph's entry and size, and
a publication's edges.

Shells reach the store only through services (docs/design.md, "Layers"); this module is
that door for reads of the catalogue. A graph is handed out as a :class:`GraphEntry`, a
plain value, so that no shell keeps an ORM row past the session it came from.
"""

from __future__ import annotations

from dataclasses import dataclass

from sqlalchemy.orm import Session

from app.store.animations import count_missing_animations
from app.store.graph_catalogue import MAX_ROW_ID, get_graph_row, graph_ids, size_frames
from app.store.publications import (
    GraphListing,
    PublishedEdge,
    get_publication,
    graph_listings,
    latest_publication_id,
    published_edges,
)

__all__ = [
    "MAX_ROW_ID",
    "GraphEntry",
    "GraphListing",
    "PublishedEdge",
    "find_graph",
    "get_publication",
    "graph_ids",
    "graph_listings",
    "latest_publication_id",
    "missing_animations",
    "published_edges",
    "size_frames",
]

#: the frame rate of a graph whose scene does not say (every toy graph)
DEFAULT_FPS = 30.0


@dataclass(frozen=True)
class GraphEntry:
    """What shells need of a graph row: its identity and the shape of its clips."""

    id: int
    name: str
    n_controls: int
    frames_per_clip: int
    fps: float

    @property
    def frames_per_expansion(self) -> int:
        return self.n_controls * self.frames_per_clip


def find_graph(session: Session, name_or_id: str | int) -> GraphEntry:
    """The graph named (or numbered) so; :class:`~app.core.errors.NotFound` if none is."""
    row = get_graph_row(session, name_or_id)
    scene = row.scene or {}
    return GraphEntry(
        id=row.id,
        name=row.name,
        n_controls=row.n_controls,
        frames_per_clip=row.frames_per_clip,
        fps=float(scene.get("fps", DEFAULT_FPS)),
    )


def missing_animations(session: Session, name_or_id: str | int) -> int:
    """Edges of the graph a publication with renders would still have to render."""
    return count_missing_animations(session, get_graph_row(session, name_or_id).id)
