"""``GET /api/health``: whether this server can serve, for load balancers and monitors.

200 when the database answers ``SELECT 1``, naming its dialect, where the rate limit
windows are (shared in Redis while it answers, else per process: the server still
serves then, with looser limits), whether the broker answers and how many workers do;
503 when the database does not answer.

Only the database decides the status. Players need the database and the artifact files,
never the broker: a broker that restarts, or no worker running, stops growth and the
admin routes' growth jobs (which answer for themselves), not play. A health check that
failed on it would have a load balancer or an orchestrator pull every API server at
once while they could still serve; monitors read ``broker`` and ``workers`` instead.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from fastapi import APIRouter, Depends, Request
from sqlalchemy.exc import SQLAlchemyError
from sqlalchemy.orm import Session

from app.api.deps import get_session
from app.api.errors import ApiError, error_responses
from app.api.ratelimit import RateLimits
from app.api.schemas import Health
from app.db.sessions import ping

if TYPE_CHECKING:  # Celery is imported only where a broker is configured
    from app.tasks.broker_health import BrokerProbe

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
    probe: BrokerProbe | None = request.app.state.broker_probe
    answer = probe.check() if probe is not None else None
    return Health(
        status="ok",
        database=dialect,
        rate_limits=limits.storage_state(),
        broker=answer.broker if answer is not None else "not configured",
        workers=answer.workers if answer is not None else None,
    )
