"""Request dependencies: the database session, settings, bearer tokens, the raw body,
the unit of work of background growth.

The two bearer tokens (a player's, the admin's) are declared as the OpenAPI security
schemes ``playerToken`` and ``adminToken``; their absence is answered here, in the API's
error shape (401 with ``WWW-Authenticate: Bearer``), not by FastAPI's own.

A route that writes does so through a service that writes in one transaction of the
request's session (docs/play.md, "Trace upload, check by check"; on SQLite: the write
lock first, and a retry on its lock error); any exception rolls the session back here,
so a rejected request writes nothing.
"""

from __future__ import annotations

import secrets
from collections.abc import Iterator

from fastapi import Depends, Request, Security
from fastapi.security import HTTPAuthorizationCredentials, HTTPBearer
from sqlalchemy.orm import Session
from starlette.requests import ClientDisconnect

from app.api.errors import ApiError
from app.config import Settings
from app.db.sessions import Transactions, unit_of_work
from app.services.players import player_for_token

BEARER_CHALLENGE = {"WWW-Authenticate": "Bearer"}
ADMIN_ROUTES_OFF = "admin routes are off: set SRG_ADMIN_TOKEN"
PLAYER_TOKEN = HTTPBearer(
    scheme_name="playerToken",
    description="the token of POST /api/players",
    auto_error=False,
)
ADMIN_TOKEN = HTTPBearer(
    scheme_name="adminToken",
    description="the server's SRG_ADMIN_TOKEN (admin routes answer 403 while it is unset)",
    auto_error=False,
)


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


def bearer_token(credentials: HTTPAuthorizationCredentials | None) -> str:
    """The token of ``Authorization: Bearer <token>``; 401 when absent or malformed."""
    token = credentials.credentials.strip() if credentials is not None else ""
    if not token:
        raise ApiError(
            401, "missing bearer token (Authorization: Bearer <token>)", headers=BEARER_CHALLENGE
        )
    return token


def current_player(
    credentials: HTTPAuthorizationCredentials | None = Security(PLAYER_TOKEN),
    session: Session = Depends(get_session),
) -> int:
    """The id of the player holding the token; 403 for a token no player holds."""
    token = bearer_token(credentials)
    player_id = player_for_token(session, token)
    # End the read transaction: its connection goes back to the pool instead of being
    # held while the request waits for a worker thread to run the route itself.
    session.commit()
    if player_id is None:
        raise ApiError(403, "unknown player token; register again with POST /api/players")
    return player_id


def require_admin(
    credentials: HTTPAuthorizationCredentials | None = Security(ADMIN_TOKEN),
    settings: Settings = Depends(get_settings),
) -> None:
    """``Authorization: Bearer <admin_token>``, compared in constant time.

    With no token configured the admin routes are off: 403 for every request, whatever
    it presents, so no default secret ever opens them.
    """
    if not settings.api.admin_routes_on:
        raise ApiError(403, ADMIN_ROUTES_OFF)
    token = bearer_token(credentials)
    if not secrets.compare_digest(token.encode(), settings.api.admin_token.encode()):
        raise ApiError(403, "admin token required")


def growth_transactions(request: Request) -> Transactions:
    """The unit of work of growth run off the request: a transaction per step, on the
    app's database, so each finished step is kept whatever happens to the server."""
    factory = request.app.state.session_factory
    return lambda: unit_of_work(factory)


async def raw_body(request: Request) -> bytes:
    """The raw request body, bounded by :class:`~app.api.bodylimit.BodyLimit` as it streams.

    A client that hangs up before its body ends is an :class:`ApiError` like any refusal,
    not a bug: no traceback in the log, and the answer goes to nobody (uvicorn writes no
    access line for a closed connection).
    """
    try:
        return await request.body()
    except ClientDisconnect:
        raise ApiError(400, "the client hung up before its body ended") from None
