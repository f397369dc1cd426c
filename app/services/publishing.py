"""Publishing a graph: pre-publish relinking, every missing animation, a frozen copy.

A strip whose file is missing or fails its hash counts as missing: it is rendered again
from its clip (:func:`~app.services.animations.forget_unreadable_strips`), so a file that
rotted is never frozen into a new publication.

Players and bots only ever play publications (docs/play.md), so growth can go on
rewriting the live graph under them. Publishing is a writer of the graph (its relinks
are saved) and takes the graph's lock as growth's steps do (:mod:`app.store.locks`):
beside a running growth it waits for the integration under way and freezes the graph as
that left it, a version the graph had, while growth's next step waits for it.
"""

from __future__ import annotations

from dataclasses import dataclass

from sqlalchemy.orm import Session

from app.config import Settings
from app.core.growth.expansion import relink_all
from app.services.animations import (
    forget_unreadable_strips,
    render_missing_animations,
    reuse_error_limit,
)
from app.services.loading import LoadedGraph, loaded_graph
from app.services.progress import Advance
from app.store.graph_persistence import save_graph
from app.store.locks import lock_named_graph
from app.store.publications import get_publication, publish
from app.store.transactions import in_transaction


@dataclass
class PublishResult:
    graph: str
    publication_id: int
    number: int
    relinked: int
    #: edges given a strip
    rendered: int
    #: strips whose file was missing or failed its hash: their edges are among ``rendered``
    rerendered_strips: int
    size_frames: int


def relink_blends(session: Session, settings: Settings, loaded: LoadedGraph) -> int:
    """Relink every BLEND edge to its best target now and save what moved; how many."""
    moved = relink_all(
        loaded.graph, loaded.bank, loaded.dynamics, prefilter_k=settings.growth.prefilter_k
    )
    if moved:
        save_graph(session, loaded.entry.id, loaded.graph, loaded.bank, loaded.artifacts)
    return len(moved)


def publish_graph(
    session: Session,
    settings: Settings,
    *,
    name: str | int,
    render: bool = True,
    progress: Advance | None = None,
) -> PublishResult:
    """Pre-publish relinking, animations for every edge, then a frozen publication.

    ``render=False`` freezes the graph without animations: the experiment's bots play
    edges, not pictures, and rendering would cost more than growing.
    """
    loaded = loaded_graph(session, settings, lock_named_graph(session, name))
    relinked = relink_blends(session, settings, loaded)
    rendered = rerendered = 0
    if render:
        rerendered = len(forget_unreadable_strips(session, loaded))
        limit = reuse_error_limit(settings, loaded.context)
        rendered = render_missing_animations(session, loaded, limit, progress)
    publication_id = publish(
        session, loaded.entry.id, loaded.graph, threshold=loaded.context.threshold
    )
    return PublishResult(
        graph=loaded.entry.name,
        publication_id=publication_id,
        number=get_publication(session, publication_id).number,
        relinked=relinked,
        rendered=rendered,
        rerendered_strips=rerendered,
        size_frames=loaded.graph.size_frames,
    )


def publish_in_transaction(session: Session, settings: Settings, name: str | int) -> PublishResult:
    """:func:`publish_graph` with renders in one write transaction of ``session`` (on
    SQLite: the write lock first, since background growth commits between its reads and
    its writes)."""
    return in_transaction(session, lambda: publish_graph(session, settings, name=name))
