"""Trace upload: validated, size-limited, rate-limited, idempotent.

Every check runs before anything is written: body size (413, before parsing; a declared
Content-Length over the limit is refused unread), bearer token (401/403), rate limit
(429), schema (422), steps per trace (413, ``max_trace_steps``: longer than any session),
publication (404), every step following an edge (422), key reuse for another trace
(409). The first upload of a key answers 201; a replay of it answers 200 with the same
trace id.
"""

from __future__ import annotations

import numpy as np
from fastapi import APIRouter, Depends, Request, Response
from pydantic import ValidationError
from sqlalchemy.orm import Session

from app.api.cache import FrozenCache
from app.api.deps import current_player, get_session, limited_body
from app.api.errors import ApiError, validation_details
from app.api.ratelimit import TokenBucketLimiter, retry_after_header
from app.api.retry import in_transaction
from app.api.schemas import TraceStored, TraceUpload
from app.core.publication import Publication
from app.store.publications import load_publication
from app.store.traces import IdempotencyConflict, InvalidTrace, record_trace

router = APIRouter(prefix="/api/traces", tags=["traces"])

_BODY_SCHEMA = {
    "requestBody": {
        "required": True,
        "content": {"application/json": {"schema": TraceUpload.model_json_schema()}},
    }
}


def rate_limited_player(request: Request, player_id: int = Depends(current_player)) -> int:
    limiter: TokenBucketLimiter = request.app.state.limiter
    wait = limiter.acquire(player_id)
    if wait > 0:
        raise ApiError(
            429,
            "too many uploads; retry later",
            headers={"Retry-After": retry_after_header(wait)},
            retry_after_seconds=round(wait, 3),
        )
    return player_id


@router.post(
    "",
    status_code=201,
    openapi_extra=_BODY_SCHEMA,
    responses={200: {"description": "a replay of an idempotency key already stored"}},
)
def upload_trace(
    request: Request,
    response: Response,
    body: bytes = Depends(limited_body),  # read first: no connection held while it streams
    player_id: int = Depends(rate_limited_player),
    session: Session = Depends(get_session),
) -> TraceStored:
    try:
        upload = TraceUpload.model_validate_json(body)
    except ValidationError as exc:
        raise ApiError(422, "invalid trace upload", details=validation_details(exc)) from None
    max_steps: int = request.app.state.settings.max_trace_steps
    if len(upload.steps) > max_steps:  # no session is that long: it would skew growth's L
        raise ApiError(
            413,
            f"a trace of {len(upload.steps)} steps; at most {max_steps} are accepted per trace",
            max_steps=max_steps,
        )
    publications: FrozenCache[Publication] = request.app.state.publications
    publication = publications.get_or_load(
        upload.publication_id, lambda: load_publication(session, upload.publication_id)
    )
    steps = np.asarray(upload.steps, dtype=np.int64).reshape(len(upload.steps), 2)
    try:
        trace_id, created = in_transaction(
            session,
            lambda: record_trace(
                session,
                upload.publication_id,
                player_id,
                upload.idempotency_key,
                steps,
                publication=publication,
            ),
        )
    except IdempotencyConflict as exc:
        raise ApiError(409, str(exc)) from None
    except InvalidTrace as exc:
        raise ApiError(422, str(exc)) from None
    response.status_code = 201 if created else 200
    return TraceStored(
        trace_id=trace_id,
        publication_id=upload.publication_id,
        n_steps=len(steps),
        created=created,
    )
