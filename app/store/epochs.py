"""Growth epoch rows: one per ``grow_epoch`` run, numbered per graph.

The unique ``(graph_id, number)`` makes a second concurrent start of the same epoch fail
in the database, a backstop behind the per-graph growth lock.
"""

from __future__ import annotations

from enum import StrEnum

from sqlalchemy import func, select
from sqlalchemy.orm import Session

from app.models import GrowthEpoch


class EpochStatus(StrEnum):
    RUNNING = "running"
    FINISHED = "finished"
    FAILED = "failed"


def start_epoch(session: Session, graph_id: int, strategy: str) -> int:
    """Open the graph's next epoch; return its id."""
    last = session.scalar(
        select(func.max(GrowthEpoch.number)).where(GrowthEpoch.graph_id == graph_id)
    )
    row = GrowthEpoch(
        graph_id=graph_id,
        number=(last or 0) + 1,
        strategy=strategy,
        status=EpochStatus.RUNNING,
        expansions=0,
        relinks=0,
        size_frames=0,
    )
    session.add(row)
    session.flush()
    return row.id


def finish_epoch(
    session: Session,
    epoch_id: int,
    *,
    expansions: int,
    relinks: int,
    size_frames: int,
    status: EpochStatus = EpochStatus.FINISHED,
) -> None:
    row = session.get_one(GrowthEpoch, epoch_id)
    row.status = status
    row.expansions = expansions
    row.relinks = relinks
    row.size_frames = size_frames
    row.finished_at = func.now()  # the database's clock
    session.flush()
