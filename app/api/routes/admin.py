"""Admin actions on a graph: publish the current version, queue growth, follow its epochs.

All need ``Authorization: Bearer <admin_token>`` and are off (403) while no token is
configured. Publishing is done by the graph service the CLI calls too, in one write
transaction (:func:`~app.services.publishing.publish_in_transaction`); growth is only
queued here (:mod:`app.api.growth_jobs`) and answered with 202 and the epochs to poll.
"""

from __future__ import annotations

from typing import Annotated, Literal
from urllib.parse import quote

from fastapi import APIRouter, BackgroundTasks, Depends, Query, Request
from fastapi.encoders import jsonable_encoder
from sqlalchemy.orm import Session

from app.api.deps import get_session, growth_transactions, require_admin
from app.api.errors import ApiError, error_responses
from app.api.growth_jobs import GrowthJobs, grow_in_background, send_to_workers
from app.api.schemas import (
    INT32_MAX,
    AdminResult,
    EpochOut,
    GraphEpochs,
    GrowQueued,
    GrowRequest,
    GrowthOut,
)
from app.config import Settings
from app.core.errors import Unavailable
from app.db.sessions import Transactions
from app.services.catalogue import find_graph
from app.services.growth_tracking import (
    RequestState,
    RequestView,
    epochs_after,
    fail_request,
    last_epoch_number,
    latest_request,
    queue_request,
    refuse_if_growing_elsewhere,
    running_epoch_number,
)

router = APIRouter(
    prefix="/api/graphs",
    tags=["admin"],
    dependencies=[Depends(require_admin)],
    responses=error_responses(
        401, 403, s403="admin routes off (SRG_ADMIN_TOKEN unset), or not the admin token"
    ),
)

#: epochs listed per poll
EPOCHS_LISTED = 100


@router.post(
    "/{name}/publish",
    responses=error_responses(404, 413, s404="no such graph", s413="a body over max_body_bytes"),
)
def publish(name: str, request: Request, session: Session = Depends(get_session)) -> AdminResult:
    """Publish the graph now (an admin token): relink, render what is missing, freeze."""
    from app.services.publishing import publish_in_transaction

    result = publish_in_transaction(session, request.app.state.settings, name)
    return AdminResult(graph=name, result=_as_dict(result))


@router.post(
    "/{name}/grow",
    status_code=202,
    responses=error_responses(
        400,
        404,
        409,
        413,
        422,
        503,
        s404="no such graph",
        s409="the graph is growing already: poll it (details.poll), then grow",
        s503="the database cannot serve, or the broker cannot take the growth (the request "
        "is then failed, with the reason)",
    ),
)
def grow(
    name: str,
    request: Request,
    background: BackgroundTasks,
    body: GrowRequest | None = None,
    session: Session = Depends(get_session),
    transactions: Transactions = Depends(growth_transactions),
) -> GrowQueued:
    """Queue growth by ``expansions`` and answer 202 at once, naming the epochs to poll.

    With a broker: one Celery ``grow_epoch`` of that many expansions, which a worker plans
    and fans out; a broker that cannot take it is a 503, and the request written for it
    fails with the reason. Without (embedded): a background job of this server, growing in
    epochs of ``SRG_BATCH_SIZE`` after the response is sent.
    """
    expansions = (body or GrowRequest()).expansions
    settings: Settings = request.app.state.settings
    jobs: GrowthJobs = request.app.state.growth_jobs
    graph = find_graph(session, name)
    graph_id, graph_name = graph.id, graph.name
    after = last_epoch_number(session, graph_id)
    running = running_epoch_number(session, graph_id)
    session.commit()  # only reads: end them before queueing
    poll = f"{router.prefix}/{quote(graph_name, safe='')}/epochs?after={after}"
    runs_on: Literal["workers", "server"] = "server" if settings.eager else "workers"
    if not settings.eager and running is not None:
        raise ApiError(
            409,
            f"epoch {running} of graph {graph_name!r} is running on the workers; "
            "grow once it has finished",
            details={"poll": poll},
        )
    if settings.eager and not jobs.claim(graph_id):
        raise ApiError(
            409, f"graph {graph_name!r} is already growing in this server", details={"poll": poll}
        )
    try:
        if settings.eager:
            refuse_if_growing_elsewhere(session, graph_id, graph_name, details={"poll": poll})
        request_id = queue_request(session, graph_id, expansions, runs_on)
    except BaseException:
        if settings.eager:
            jobs.release(graph_id)
        raise
    if settings.eager:
        background.add_task(
            grow_in_background, jobs, transactions, settings, graph_id, expansions, request_id
        )
    else:
        try:
            send_to_workers(settings, graph_id, expansions, request_id)
        except Unavailable as exc:  # the broker cannot take it: nothing will run the request
            fail_request(session, request_id, exc)
            raise
    return GrowQueued(
        graph=graph_name,
        expansions=expansions,
        runs_on=runs_on,
        request=request_id,
        after_epoch=after,
        poll=poll,
    )


@router.get("/{name}/epochs", responses=error_responses(404, 422, s404="no such graph"))
def epochs(
    name: str,
    request: Request,
    after: Annotated[int, Query(ge=0, le=INT32_MAX)] = 0,
    session: Session = Depends(get_session),
) -> GraphEpochs:
    """The graph's growth epochs numbered above ``after``, oldest first: a grow's progress."""
    graph = find_graph(session, name)
    jobs: GrowthJobs = request.app.state.growth_jobs
    listed = epochs_after(session, graph.id, after, EPOCHS_LISTED)
    running = jobs.running(graph.id) or running_epoch_number(session, graph.id) is not None
    return GraphEpochs(
        graph=graph.name,
        running=running,
        growth=_growth_out(latest_request(session, graph.id), jobs.running(graph.id)),
        epochs=[EpochOut.model_validate(epoch, from_attributes=True) for epoch in listed],
    )


def _growth_out(view: RequestView | None, job_running: bool) -> GrowthOut | None:
    """The request as its poll shows it. A server request left queued or running with no
    job of this server on its graph lost its job (the server stopped, or could not
    write the end): it is reported failed, not running for ever."""
    if view is None:
        return None
    state, reason = view.state, view.reason
    ended = state in (RequestState.FINISHED, RequestState.FAILED)
    if view.runs_on == "server" and not ended and not job_running:
        state = RequestState.FAILED
        reason = "its job in this server ended without recording how (the server stopped?)"
    return GrowthOut(
        request=view.id, expansions=view.expansions, runs_on=view.runs_on, state=state,
        reason=reason,
    )  # fmt: skip


def _as_dict(result: object) -> dict[str, object]:
    encoded = jsonable_encoder(result)
    return encoded if isinstance(encoded, dict) else {"value": encoded}
