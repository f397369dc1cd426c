"""Growth request rows: a growth accepted by the admin route, from queued to its end.

The route writes the row before it answers 202; whoever runs the growth (this server's
background job, a worker's ``grow_epoch``) writes how it ended. A worker's request
ends with its epoch, so :func:`request_state` reads that epoch's status rather than
having every epoch step write the request too.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import StrEnum

from sqlalchemy import func, select
from sqlalchemy.orm import Session

from app.core.errors import SrgError
from app.models import GrowthEpoch, GrowthRequest
from app.store.epochs import EpochStatus

#: the longest reason kept (the column's length)
REASON_LENGTH = 500


class RequestState(StrEnum):
    QUEUED = "queued"
    RUNNING = "running"
    FINISHED = "finished"
    FAILED = "failed"


@dataclass(frozen=True)
class RequestView:
    """A request as its poll shows it."""

    id: int
    expansions: int
    runs_on: str
    state: RequestState
    reason: str | None
    epoch_id: int | None


def add_request(session: Session, graph_id: int, expansions: int, runs_on: str) -> int:
    row = GrowthRequest(
        graph_id=graph_id,
        expansions=expansions,
        runs_on=runs_on,
        state=RequestState.QUEUED,
        done=0,
    )
    session.add(row)
    session.flush()
    return row.id


def start_request(session: Session, request_id: int, epoch_id: int | None = None) -> None:
    row = session.get_one(GrowthRequest, request_id)
    row.state = RequestState.RUNNING
    row.epoch_id = epoch_id


def end_request(
    session: Session, request_id: int, *, done: int = 0, failure: str | None = None
) -> None:
    """Finish the request, or fail it with ``failure`` (one line, cut to the column)."""
    row = session.get_one(GrowthRequest, request_id)
    row.state = RequestState.FINISHED if failure is None else RequestState.FAILED
    row.reason = None if failure is None else failure.splitlines()[0][:REASON_LENGTH]
    row.done = done
    row.finished_at = func.now()


def failure_reason(exc: BaseException) -> str:
    """One line for a poll: a user's error as its message, a bug with its type.

    An OS error says what failed without the file it names: the poll is a client's, the
    server's paths are its log's (the job logs the whole exception).
    """
    text = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc).strip()
    if isinstance(exc, SrgError):
        return text or type(exc).__name__
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__


def latest_request(session: Session, graph_id: int) -> RequestView | None:
    """The graph's most recent request, its state read through its epoch on workers."""
    row = session.scalars(
        select(GrowthRequest)
        .where(GrowthRequest.graph_id == graph_id)
        .order_by(GrowthRequest.id.desc())
        .limit(1)
    ).one_or_none()
    if row is None:
        return None
    state = RequestState(row.state)
    if state is RequestState.RUNNING and row.epoch_id is not None:
        epoch = session.scalar(select(GrowthEpoch.status).where(GrowthEpoch.id == row.epoch_id))
        if epoch == EpochStatus.FINISHED:
            state = RequestState.FINISHED
    return RequestView(row.id, row.expansions, row.runs_on, state, row.reason, row.epoch_id)
