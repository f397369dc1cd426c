"""Request dependencies: the database session, settings, bearer tokens, the trace body,
the unit of work of background growth.

Routes own their transaction (STYLE habit 7): they call ``session.commit()`` once; any
exception rolls the session back here, so a rejected request writes nothing.
"""

from __future__ import annotations

import secrets
from collections.abc import Iterator

from fastapi import Depends, Request
from sqlalchemy.orm import Session

from app.api.errors import ApiError
from app.config import Settings
from app.db import Scope, transaction
from app.store.traces import player_for_token

BEARER_CHALLENGE = {"WWW-Authenticate": "Bearer"}
ADMIN_ROUTES_OFF = "admin routes are off: set SRG_ADMIN_TOKEN"


def get_settings(request: Request) -> Settings:
    settings: Settings = request.app.state.settings
    return settings


def get_session(request: Request) -> Iterator[Session]:
    session: Session = request.app.state.session_factory()
    try:
        yield session
    except BaseException:
        session.rollback()
        raise
    finally:
        session.close()


def bearer_token(request: Request) -> str:
    """The token of ``Authorization: Bearer <token>``; 401 when absent or malformed."""
    scheme, _, token = request.headers.get("authorization", "").partition(" ")
    if scheme.lower() != "bearer" or not token.strip():
        raise ApiError(
            401, "missing bearer token (Authorization: Bearer <token>)", headers=BEARER_CHALLENGE
        )
    return token.strip()


def current_player(
    token: str = Depends(bearer_token), session: Session = Depends(get_session)
) -> int:
    """The id of the player holding the token; 403 for a token no player holds."""
    player_id = player_for_token(session, token)
    # End the read transaction: its connection goes back to the pool instead of being
    # held while the request waits for a worker thread to run the route itself.
    session.commit()
    if player_id is None:
        raise ApiError(403, "unknown player token; register again with POST /api/players")
    return player_id


def require_admin(request: Request, settings: Settings = Depends(get_settings)) -> None:
    """``Authorization: Bearer <admin_token>``, compared in constant time.

    With no token configured the admin routes are off: 403 for every request, whatever
    it presents, so no default secret ever opens them.
    """
    if not settings.admin_routes_on:
        raise ApiError(403, ADMIN_ROUTES_OFF)
    token = bearer_token(request)
    if not secrets.compare_digest(token.encode(), settings.admin_token.encode()):
        raise ApiError(403, "admin token required")


def growth_scope(request: Request) -> Scope:
    """The unit of work of growth run off the request: a transaction per step, on the
    app's database, so each finished step is kept whatever happens to the server."""
    factory = request.app.state.session_factory
    return lambda: transaction(factory)


async def limited_body(request: Request) -> bytes:
    """The raw request body, refused with 413 as soon as it exceeds ``max_trace_bytes``.

    A declared ``Content-Length`` over the limit is refused before reading anything; a
    body without one (chunked) is counted while it streams in and never parsed.
    """
    limit: int = request.app.state.settings.max_trace_bytes
    declared = request.headers.get("content-length")
    too_large = ApiError(413, f"body larger than {limit} bytes", max_bytes=limit)
    if declared is not None and declared.isdigit() and int(declared) > limit:
        raise too_large
    chunks: list[bytes] = []
    size = 0
    async for chunk in request.stream():
        size += len(chunk)
        if size > limit:
            raise too_large
        chunks.append(chunk)
    return b"".join(chunks)
