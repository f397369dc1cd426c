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


def last_epoch_number(session: Session, graph_id: int) -> int:
    """The number of the graph's latest epoch; 0 before its first."""
    last = session.scalar(
        select(func.max(GrowthEpoch.number)).where(GrowthEpoch.graph_id == graph_id)
    )
    return int(last or 0)


def epochs_after(session: Session, graph_id: int, after: int, limit: int) -> list[GrowthEpoch]:
    """The graph's epochs numbered above ``after``, oldest first, at most ``limit``."""
    return list(
        session.scalars(
            select(GrowthEpoch)
            .where(GrowthEpoch.graph_id == graph_id, GrowthEpoch.number > after)
            .order_by(GrowthEpoch.number)
            .limit(limit)
        )
    )
