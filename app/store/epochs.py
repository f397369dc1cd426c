"""Growth epoch rows: one per ``grow_epoch`` run, numbered per graph.

The unique ``(graph_id, number)`` makes a second concurrent start of the same epoch fail
in the database (:class:`EpochTaken`), a backstop behind the per-graph growth lock.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from datetime import datetime
from enum import StrEnum

from sqlalchemy import func, select, update
from sqlalchemy.exc import IntegrityError
from sqlalchemy.orm import Session

from app.core.errors import Conflict, NotFound
from app.models import ExpansionClip, GrowthEpoch
from app.store._sql import insert_ignoring_duplicates


class EpochStatus(StrEnum):
    RUNNING = "running"
    FINISHED = "finished"
    FAILED = "failed"


class EpochTaken(Conflict):
    """Another writer opened the graph's next epoch first."""


class EpochNotFound(NotFound):
    """No growth epoch with that id."""


@dataclass(frozen=True)
class Epoch:
    """A growth epoch as it was read: what the workflow steps and the poll see of its row.
    A later step reads it again rather than holding on to it (another writer may have
    moved it on)."""

    id: int
    graph_id: int
    number: int
    strategy: str
    status: EpochStatus
    #: (edge, dead-end clip) in integration order; empty until the plan is recorded
    plan: tuple[tuple[int, int], ...]
    #: expansions done, set when the epoch finishes
    expansions: int
    relinks: int
    size_frames: int
    renders: bool
    heartbeat: float | None
    started_at: datetime
    finished_at: datetime | None

    @property
    def planned(self) -> int:
        """Expansions in the epoch's plan."""
        return len(self.plan)


def _value(row: GrowthEpoch) -> Epoch:
    return Epoch(
        id=row.id,
        graph_id=row.graph_id,
        number=row.number,
        strategy=row.strategy,
        status=EpochStatus(row.status),
        plan=tuple((int(edge), int(clip)) for edge, clip in row.plan or []),
        expansions=row.expansions,
        relinks=row.relinks,
        size_frames=row.size_frames,
        renders=row.renders,
        heartbeat=row.heartbeat,
        started_at=row.started_at,
        finished_at=row.finished_at,
    )


def _row(session: Session, epoch_id: int, *, fresh: bool = False) -> GrowthEpoch:
    row = session.get(GrowthEpoch, epoch_id, populate_existing=fresh)
    if row is None:
        raise EpochNotFound(f"no growth epoch {epoch_id}")
    return row


def start_epoch(session: Session, graph_id: int, strategy: str, *, renders: bool = True) -> int:
    """Open the graph's next epoch; return its id (:class:`EpochTaken` if another writer
    opened that number first)."""
    last = session.scalar(
        select(func.max(GrowthEpoch.number)).where(GrowthEpoch.graph_id == graph_id)
    )
    row = GrowthEpoch(
        graph_id=graph_id,
        number=(last or 0) + 1,
        strategy=strategy,
        status=EpochStatus.RUNNING,
        renders=renders,
        expansions=0,
        relinks=0,
        size_frames=0,
    )
    session.add(row)
    try:
        session.flush()
    except IntegrityError:
        raise EpochTaken(
            f"epoch {row.number} of graph {graph_id} was opened by another writer"
        ) from None
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
    row = _row(session, epoch_id)
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


def epochs_after(session: Session, graph_id: int, after: int, limit: int) -> list[Epoch]:
    """The graph's epochs numbered above ``after``, oldest first, at most ``limit``."""
    rows = session.scalars(
        select(GrowthEpoch)
        .where(GrowthEpoch.graph_id == graph_id, GrowthEpoch.number > after)
        .order_by(GrowthEpoch.number)
        .limit(limit)
    )
    return [_value(row) for row in rows]


def get_epoch(session: Session, epoch_id: int, *, fresh: bool = False) -> Epoch:
    """The epoch; ``fresh`` reads its row again from the database, past what this session
    read of it before (what a writer that just took the graph's lock needs)."""
    return _value(_row(session, epoch_id, fresh=fresh))


def running_epoch(session: Session, graph_id: int) -> Epoch | None:
    """The graph's running epoch, if one runs (the oldest, should there be two)."""
    row = session.scalars(
        select(GrowthEpoch)
        .where(GrowthEpoch.graph_id == graph_id, GrowthEpoch.status == EpochStatus.RUNNING)
        .order_by(GrowthEpoch.number)
    ).first()
    return None if row is None else _value(row)


def running_epoch_ids(session: Session) -> list[int]:
    """Every graph's running epochs, oldest first."""
    return list(
        session.scalars(
            select(GrowthEpoch.id)
            .where(GrowthEpoch.status == EpochStatus.RUNNING)
            .order_by(GrowthEpoch.id)
        )
    )


def epoch_count(session: Session, graph_id: int) -> int:
    return int(session.scalar(select(func.count()).where(GrowthEpoch.graph_id == graph_id)) or 0)


def finished_epoch_count(session: Session, graph_id: int) -> int:
    return int(
        session.scalar(
            select(func.count()).where(
                GrowthEpoch.graph_id == graph_id, GrowthEpoch.status == EpochStatus.FINISHED
            )
        )
        or 0
    )


def latest_warm_start(session: Session, graph_id: int) -> str | None:
    """The artifact of the last STATERANK pi stored on one of the graph's epochs."""
    return session.scalar(
        select(GrowthEpoch.warm_start)
        .where(GrowthEpoch.graph_id == graph_id, GrowthEpoch.warm_start.is_not(None))
        .order_by(GrowthEpoch.number.desc())
        .limit(1)
    )


def record_plan(
    session: Session,
    epoch_id: int,
    *,
    plan: list[tuple[int, int]],
    relinks: int,
    warm_start: str | None,
) -> Epoch:
    """Write an opened epoch's plan, (edge, dead-end clip) in integration order."""
    row = _row(session, epoch_id)
    row.plan = [list(pair) for pair in plan]
    row.relinks = relinks
    row.heartbeat = time.time()
    if warm_start is not None:
        row.warm_start = warm_start
    session.flush()
    return _value(row)


def record_heartbeat(session: Session, epoch_id: int) -> None:
    """The epoch made progress now (what tells a stalled epoch from a slow one)."""
    session.execute(
        update(GrowthEpoch).where(GrowthEpoch.id == epoch_id).values(heartbeat=time.time())
    )


def stored_clips(session: Session, epoch_id: int) -> set[tuple[int, int]]:
    """(position, control) of every clip of the epoch recorded so far."""
    return {
        (position, control)
        for position, control in session.execute(
            select(ExpansionClip.position, ExpansionClip.control).where(
                ExpansionClip.epoch_id == epoch_id
            )
        )
    }


def expansion_clip(session: Session, epoch_id: int, position: int, control: int) -> str | None:
    """The clip artifact recorded for one planned clip, if it has been."""
    row = session.get(ExpansionClip, (epoch_id, position, control))
    return None if row is None else row.clip


def expansion_clips(session: Session, epoch_id: int, position: int) -> dict[int, str]:
    """The recorded clip artifacts of one planned expansion, by control."""
    rows = session.execute(
        select(ExpansionClip.control, ExpansionClip.clip).where(
            ExpansionClip.epoch_id == epoch_id, ExpansionClip.position == position
        )
    )
    return {control: clip for control, clip in rows}


def record_clip(session: Session, epoch_id: int, position: int, control: int, clip: str) -> None:
    """Note a planned clip's artifact on ``expansion_clips`` (once), and the epoch's
    heartbeat.

    The heartbeat comes first: every writer of an epoch's clips takes the epoch's row
    before any clip row, so two transactions recording the same clips (a worker
    simulating others' clips with its own) wait for each other instead of deadlocking.
    """
    record_heartbeat(session, epoch_id)
    insert_ignoring_duplicates(
        session,
        ExpansionClip,
        [{"epoch_id": epoch_id, "position": position, "control": control, "clip": clip}],
    )
