"""Growth as its callers follow it: requests queued by the admin route, and the epochs
that serve them.

A request row says who asked for how much growth and how it ended; the epochs say what
growth did. The route queues and polls, the background job and ``grow_epoch`` start and
end requests, and the client side of :mod:`app.tasks.growth` waits on the running epoch.
"""

from __future__ import annotations

from sqlalchemy.orm import Session

from app.store.epochs import epochs_after, last_epoch_number, running_epoch
from app.store.growth_claims import refuse_if_claimed
from app.store.growth_requests import (
    RequestState,
    RequestView,
    add_request,
    end_request,
    failure_reason,
    latest_request,
    start_request,
)
from app.store.transactions import in_transaction

__all__ = [
    "RequestState",
    "RequestView",
    "end_request",
    "epochs_after",
    "fail_request",
    "failure_reason",
    "last_epoch_number",
    "latest_request",
    "queue_request",
    "refuse_if_growing_elsewhere",
    "running_epoch_number",
    "running_epoch_state",
    "start_request",
]


def queue_request(session: Session, graph_id: int, expansions: int, runs_on: str) -> int:
    """The id of a new queued request, in its own write transaction."""
    return in_transaction(session, lambda: add_request(session, graph_id, expansions, runs_on))


def fail_request(session: Session, request_id: int, exc: BaseException) -> None:
    """End a request that nothing will run (its work could not be sent) as failed, with
    why, in its own write transaction: its poll says so rather than ``queued`` for ever."""
    in_transaction(session, lambda: end_request(session, request_id, failure=failure_reason(exc)))


def refuse_if_growing_elsewhere(
    session: Session, graph_id: int, graph_name: str, *, details: object = None
) -> None:
    """``GrowingElsewhere`` if another process (an ``srg grow``, another server) grows
    the graph itself now: a growth queued here would be refused when it starts."""
    refuse_if_claimed(session.get_bind().engine, graph_id, graph_name, details=details)


def running_epoch_number(session: Session, graph_id: int) -> int | None:
    """The number of the graph's running epoch, if one runs."""
    running = running_epoch(session, graph_id)
    return None if running is None else running.number


def running_epoch_state(session: Session, graph_id: int) -> tuple[int, float | None] | None:
    """``(id, last heartbeat)`` of the graph's running epoch, if one runs: what changes
    while its work progresses."""
    running = running_epoch(session, graph_id)
    return None if running is None else (running.id, running.heartbeat)
