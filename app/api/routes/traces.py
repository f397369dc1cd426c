"""Trace upload: validated, size-limited, rate-limited, idempotent.

Every check runs before anything is written: body size (413, before parsing; a declared
Content-Length over the limit is refused unread: :mod:`app.api.bodylimit`), bearer token
(401/403) and rate limits of the client address and of the player (429), both before the
body is read, so that whoever may not upload costs no upload's bytes; schema (422),
steps per trace (413, ``max_trace_steps``: longer than any session), publication (404),
every step following an edge (422, naming the first step that does not), key reuse for
another trace (409). The first upload of a key answers 201; a replay of it answers 200 with the same
trace id.
"""

from __future__ import annotations

import numpy as np
from fastapi import APIRouter, Depends, Request, Response
from pydantic import ValidationError
from sqlalchemy.orm import Session

from app.api.cache import FrozenCache
from app.api.deps import get_session, raw_body
from app.api.errors import ApiError, error_responses, validation_details
from app.api.ratelimit import limited_uploader
from app.api.schemas import TraceStored, TraceUpload
from app.core.graph.publication import Publication
from app.services.trace_upload import load_publication, store_trace

router = APIRouter(prefix="/api/traces", tags=["traces"])

_BODY_SCHEMA = {
    "requestBody": {
        "required": True,
        "content": {"application/json": {"schema": TraceUpload.model_json_schema()}},
    }
}


@router.post(
    "",
    status_code=201,
    openapi_extra=_BODY_SCHEMA,
    responses={
        200: {"description": "a replay of an idempotency key already stored"},
        **error_responses(
            401,
            403,
            404,
            409,
            413,
            422,
            429,
            s403="a token no player holds",
            s404="no such publication",
            s409="the idempotency key names another trace of this player",
            s413="body over max_trace_bytes, or more steps than max_trace_steps",
            s422="not a trace upload, or a step that does not follow an edge",
        ),
    },
)
def upload_trace(
    request: Request,
    response: Response,
    # in this order: a client without a token, or over a limit, is refused unread (and
    # the token's read transaction has ended: no connection is held while the body streams)
    player_id: int = Depends(limited_uploader),
    body: bytes = Depends(raw_body),
    session: Session = Depends(get_session),
) -> TraceStored:
    """Store one session's steps on a publication, once: a re-sent upload with the same
    idempotency key answers 200 with the stored trace, every step checked to follow an
    edge (docs/play.md, "Trace upload, check by check")."""
    try:
        upload = TraceUpload.model_validate_json(body)
    except ValidationError as exc:
        raise ApiError(422, "invalid trace upload", details=validation_details(exc)) from None
    max_steps: int = request.app.state.settings.api.max_trace_steps
    if len(upload.steps) > max_steps:  # no session is that long: it would skew growth's L
        raise ApiError(
            413,
            f"a trace of {len(upload.steps)} steps; at most {max_steps} are accepted per trace",
            details={"max_steps": max_steps},
        )
    publications: FrozenCache[Publication] = request.app.state.publications
    publication = publications.get_or_load(
        upload.publication_id, lambda: load_publication(session, upload.publication_id)
    )
    steps = np.asarray(upload.steps, dtype=np.int64).reshape(len(upload.steps), 2)
    # a step off the edges (422, naming it) or a reused key with other steps (409): the
    # store's SrgErrors
    trace_id, created = store_trace(
        session, publication, upload.publication_id, player_id, upload.idempotency_key, steps
    )
    response.status_code = 201 if created else 200
    return TraceStored(
        trace_id=trace_id,
        publication_id=upload.publication_id,
        n_steps=len(steps),
        created=created,
    )
