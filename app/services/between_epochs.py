"""What changes a graph between its growth epochs: ranking it, relinking, publishing.

Each takes the graph's lock and refuses while an epoch runs (:class:`EpochRunning`),
so it never writes into the middle of an epoch's integrations; the tasks retry later.
"""

from __future__ import annotations

from sqlalchemy.orm import Session

from app.config import Settings
from app.core.errors import Conflict
from app.models import Graph
from app.services.loading import keep_graph, loaded_graph
from app.services.publishing import publish_graph, relink_blends
from app.services.refining import rank_stored, refiner_for
from app.store.epochs import running_epoch
from app.store.graphs import get_graph_row, mark_growing
from app.store.locks import lock_graph


class EpochRunning(Conflict):
    """An epoch of the graph is running: wait for it before changing the graph."""


def _between_epochs(session: Session, graph_id: int) -> Graph:
    row = lock_graph(session, graph_id)
    if running_epoch(session, graph_id) is not None:
        raise EpochRunning(f"graph {graph_id} has an epoch running")
    return row


def rank_graph(session: Session, settings: Settings, graph_id: int) -> str | None:
    """STATERANK of the graph as it is, warm-started like an epoch's; the pi artifact.

    None for strategies that do not rank. The stored pi is what planning an epoch
    computes too; this exists to look at the ranking without growing.
    """
    loaded = loaded_graph(session, settings, get_graph_row(session, graph_id))
    ranked = rank_stored(session, loaded, refiner_for(session, settings, loaded))
    keep_graph(session, loaded)
    if ranked.rank is None:
        return None
    return loaded.artifacts.put_arrays({"pi": ranked.rank.pi}, session=session)


def relink_graph(session: Session, settings: Settings, graph_id: int) -> int:
    """Pre-publish relinking of every BLEND edge, between epochs; how many moved."""
    row = _between_epochs(session, graph_id)
    loaded = loaded_graph(session, settings, row)
    moved = relink_blends(session, settings, loaded)
    keep_graph(session, loaded)
    return moved


def publish_between_epochs(session: Session, settings: Settings, graph_id: int) -> int:
    """``publish_graph`` under the graph's lock, never in the middle of an epoch."""
    _between_epochs(session, graph_id)
    return publish_graph(session, settings, name=graph_id).publication_id


def set_growing(session: Session, name: str | int, growing: bool) -> dict[str, object]:
    """Mark a graph for (or take it off) beat's periodic growth."""
    row = mark_growing(session, name, growing)
    return {"id": row.id, "name": row.name, "growing": row.growing}
