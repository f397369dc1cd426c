"""What ``srg status`` shows of a graph: sizes, publications, epochs and play."""

from __future__ import annotations

from sqlalchemy.orm import Session

from app.core.graph.state_graph import EdgeKind
from app.store.animations import count_missing_animations
from app.store.epochs import epoch_count
from app.store.graph_catalogue import edge_kind_counts, graph_entry, size_frames
from app.store.publications import latest_publication
from app.store.traces import play_summary


def graph_summary(session: Session, name: str | int) -> dict[str, object]:
    """Sizes from the stored rows, the latest publication, epochs, play."""
    entry = graph_entry(session, name)
    kinds = edge_kind_counts(session, entry.id)
    latest = latest_publication(session, entry.id)
    return {
        "id": entry.id,
        "name": entry.name,
        "dynamics": entry.dynamics,
        "preset": entry.scene.preset,
        "strategy": entry.strategy,
        "player_model": entry.player_model,
        "growing": entry.growing,
        "size_frames": size_frames(session, entry.id),
        "sim_edges": int(kinds.get(int(EdgeKind.SIM), 0)),
        "blend_edges": int(kinds.get(int(EdgeKind.BLEND), 0)),
        "epochs": epoch_count(session, entry.id),
        "latest_publication": None if latest is None else latest.number,
        "unrendered_edges": count_missing_animations(session, entry.id),
        "play": play_summary(session, entry.id),
    }
