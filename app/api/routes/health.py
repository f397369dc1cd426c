"""``GET /api/health``: whether this server can serve, for load balancers and monitors.

200 when the database answers ``SELECT 1``, naming its dialect, where the rate limit
windows are (shared in Redis while it answers, else per process: the server still
serves then, with looser limits), whether the broker answers and how many workers do;
503 when the database does not answer, or when a SQLite file fails ``PRAGMA
quick_check``.

A SQLite file damaged or overwritten under a running server answers ``SELECT 1`` and
every read that misses the damaged pages, so only a check that reads every page notices
it. quick_check costs about a second per GB (:func:`app.db.engines.require_intact`),
too much for every probe of a load balancer: it runs at most once a minute
(:data:`QUICK_CHECK_INTERVAL_S`), each probe in between answering its last verdict. A
database server checks its own pages.

Only the database decides the status. Players need the database and the artifact files,
never the broker: a broker that restarts, or no worker running, stops growth and the
admin routes' growth jobs (which answer for themselves), not play. A health check that
failed on it would have a load balancer or an orchestrator pull every API server at
once while they could still serve; monitors read ``broker`` and ``workers`` instead.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable
from typing import TYPE_CHECKING

from fastapi import APIRouter, Depends, Request
from sqlalchemy import Engine
from sqlalchemy.exc import SQLAlchemyError
from sqlalchemy.orm import Session
from sqlalchemy.pool import NullPool

from app.api.deps import get_session
from app.api.errors import ApiError, error_responses
from app.api.ratelimit import RateLimits
from app.api.schemas import Health
from app.config import Settings
from app.db.engines import make_engine, require_engine_intact
from app.db.errors import DatabaseUnavailable
from app.db.sessions import ping

if TYPE_CHECKING:  # Celery is imported only where a broker is configured
    from app.tasks.broker_health import BrokerProbe

router = APIRouter(prefix="/api/health", tags=["health"])

#: seconds between two quick_checks of a SQLite file
QUICK_CHECK_INTERVAL_S = 60.0


class SqliteIntegrity:
    """The verdict of SQLite's quick_check on the settings' file, at most once an interval.

    One check runs at a time; probes that come meanwhile wait for its verdict rather than
    start their own. Each check reads the file through a new connection: the server's
    pooled ones keep pages they have read (WAL mode), and would find a file overwritten
    since still sound.
    """

    def __init__(
        self,
        settings: Settings,
        *,
        interval_s: float = QUICK_CHECK_INTERVAL_S,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self._url = settings.resolved_database_url
        self._engine: Engine | None = None
        self._interval_s = interval_s
        self._clock = clock
        self._lock = threading.Lock()
        self._checked_at = -math.inf
        self._problem: str | None = None

    def problem(self) -> str | None:
        """What is wrong with the file in a few words ("corrupt"), ``None`` when sound."""
        with self._lock:
            if self._clock() - self._checked_at >= self._interval_s:
                if self._engine is None:
                    self._engine = make_engine(self._url, poolclass=NullPool)
                try:
                    require_engine_intact(self._engine)
                    self._problem = None
                except DatabaseUnavailable as exc:
                    self._problem = exc.problem
                self._checked_at = self._clock()
            return self._problem


@router.get(
    "",
    responses=error_responses(
        503, s503="the database does not answer, or its SQLite file fails quick_check"
    ),
)
def health(request: Request, session: Session = Depends(get_session)) -> Health:
    """Whether the database answers (and the broker, when set): for load balancers."""
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
    integrity: SqliteIntegrity = request.app.state.sqlite_integrity
    problem = integrity.problem() if dialect == "sqlite" else None
    if problem is not None:  # the problem alone: the file's path is the server's
        raise ApiError(
            503,
            "the sqlite database fails its integrity check",
            details={"database": dialect, "reason": problem},
        )
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
