"""What changes a graph between its growth epochs: ranking it, relinking, publishing.

Each takes the graph's lock and refuses while an epoch runs (:class:`EpochRunning`),
so it never writes into the middle of an epoch's integrations; the tasks retry later.
Beat publishes a growing graph by itself (:func:`beat_tick`, :func:`publish_if_due`).
"""

from __future__ import annotations

from dataclasses import dataclass

from sqlalchemy.orm import Session

from app.config import Settings
from app.core.errors import Conflict
from app.core.graph.graph_entry import GraphEntry
from app.services.loading import keep_graph, loaded_graph
from app.services.publishing import publish_graph, relink_blends
from app.services.refining import rank_stored, refiner_for
from app.services.scope import Scope
from app.store.epochs import running_epoch
from app.store.graph_catalogue import graph_entry, growing_graph_ids, mark_growing, size_frames
from app.store.locks import lock_graph, lock_graph_if_free
from app.store.publications import latest_publication


class EpochRunning(Conflict):
    """An epoch of the graph is running: wait for it before changing the graph."""


def _between_epochs(session: Session, graph_id: int) -> GraphEntry:
    graph = lock_graph(session, graph_id)
    if running_epoch(session, graph_id) is not None:
        raise EpochRunning(f"graph {graph_id} has an epoch running")
    return graph


def rank_graph(scope: Scope, graph_id: int) -> str | None:
    """STATERANK of the graph as it is, warm-started like an epoch's; the pi artifact.

    None for strategies that do not rank. The stored pi is what planning an epoch
    computes too; this exists to look at the ranking without growing.
    """
    session, settings = scope.session, scope.settings
    loaded = loaded_graph(session, settings, graph_entry(session, graph_id))
    ranked = rank_stored(session, loaded, refiner_for(session, settings, loaded))
    keep_graph(session, loaded)
    if ranked.rank is None:
        return None
    return loaded.artifacts.put_arrays({"pi": ranked.rank.pi}, session=session)


def relink_graph(scope: Scope, graph_id: int) -> int:
    """Pre-publish relinking of every BLEND edge, between epochs; how many moved."""
    session, settings = scope.session, scope.settings
    loaded = loaded_graph(session, settings, _between_epochs(session, graph_id))
    moved = relink_blends(session, settings, loaded)
    keep_graph(session, loaded)
    return moved


def publish_between_epochs(scope: Scope, graph_id: int) -> int:
    """``publish_graph`` under the graph's lock, never in the middle of an epoch."""
    session, settings = scope.session, scope.settings
    _between_epochs(session, graph_id)
    return publish_graph(session, settings, name=graph_id).publication_id


def publication_due(session: Session, settings: Settings, graph_id: int) -> bool:
    """Whether beat publishes the graph now: no epoch runs, and it has no publication yet
    or has grown ``SRG_PUBLISH_EVERY`` simulated frames since its latest (0: never).

    Counted in frames, not minutes, because a publication is worth its cost (a copy of
    every edge, the animations still missing) only when there is something new to play:
    a graph whose growth stopped or stalls is not published again and again, and a
    faster cluster publishes as often as its graph changes by that much.
    """
    every = settings.runtime.publish_every
    if every == 0 or running_epoch(session, graph_id) is not None:
        return False
    latest = latest_publication(session, graph_id)
    return latest is None or size_frames(session, graph_id) - latest.size_frames >= every


@dataclass(frozen=True)
class BeatTick:
    """What one tick of beat sends: an epoch for each growing graph, or its publication."""

    grow: list[int]
    publish: list[int]


def beat_tick(scope: Scope) -> BeatTick:
    """The growing graphs, split into those to grow and those due for publication.

    A due graph is published instead of grown, so its next epoch waits for the
    publication (the lock would hold it anyway): players are never more than
    ``SRG_PUBLISH_EVERY`` frames (and an epoch) behind the graph, and a publication
    that keeps failing holds growth back rather than letting the two drift apart.
    """
    session, settings = scope.session, scope.settings
    grow: list[int] = []
    publish: list[int] = []
    for graph_id in growing_graph_ids(session):
        (publish if publication_due(session, settings, graph_id) else grow).append(graph_id)
    return BeatTick(grow=grow, publish=publish)


def publish_if_due(scope: Scope, graph_id: int) -> int | None:
    """``publish_graph`` if the graph is still due under its lock; the publication's id.

    None when it is not (an epoch started, a tick before published it), or while another
    writer holds the graph: a tick sent during a long publication returns at once, and
    the next tick asks again.
    """
    session, settings = scope.session, scope.settings
    if lock_graph_if_free(session, graph_id) is None:
        return None
    if not publication_due(session, settings, graph_id):
        return None
    return publish_graph(session, settings, name=graph_id).publication_id


def set_growing(session: Session, name: str | int, growing: bool) -> dict[str, object]:
    """Mark a graph for (or take it off) beat's periodic growth."""
    graph = mark_growing(session, name, growing)
    return {"id": graph.id, "name": graph.name, "growing": graph.growing}
