"""``GET /api/health``: whether this server can serve, for load balancers and monitors.

200 when the database answers ``SELECT 1``, naming its dialect and where the rate
limit windows are (shared in Redis while it answers, else per process: the server
still serves then, with looser limits); 503 when the database does not answer.
"""

from __future__ import annotations

from fastapi import APIRouter, Depends, Request
from sqlalchemy.exc import SQLAlchemyError
from sqlalchemy.orm import Session

from app.api.deps import get_session
from app.api.errors import ApiError, error_responses
from app.api.ratelimit import RateLimits
from app.api.schemas import Health
from app.db import ping

router = APIRouter(prefix="/api/health", tags=["health"])


@router.get("", responses=error_responses(503, s503="the database does not answer"))
def health(request: Request, session: Session = Depends(get_session)) -> Health:
    dialect = session.get_bind().dialect.name
    try:
        ping(session)
        session.commit()
    except SQLAlchemyError as exc:
        raise ApiError(
            503,
            f"the {dialect} database does not answer",
            details={"database": dialect, "reason": type(exc).__name__},
        ) from None
    limits: RateLimits = request.app.state.rate_limits
    return Health(status="ok", database=dialect, rate_limits=limits.storage_state())
