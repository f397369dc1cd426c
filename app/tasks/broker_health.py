"""Does the broker answer, and how many workers? What ``GET /api/health`` reports beside
the database.

Both questions have short timeouts, because a health check is polled and a slow answer
is a failure to whoever polls it: connecting to the broker waits at most
:data:`CONNECT_TIMEOUT`, and the workers' replies to one ``ping`` broadcast are gathered
for :data:`PING_TIMEOUT` (Celery waits out the whole timeout to count every reply, so
that is also what a healthy check costs). Workers reply from their main process, not
the pool, so a worker busy simulating still answers.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import Literal

from celery import Celery

from app.config import Settings
from app.tasks.celery_app import BrokerUnavailable, make_celery, require_broker

log = logging.getLogger(__name__)
#: seconds to connect to the broker
CONNECT_TIMEOUT = 1.0
#: seconds to gather the workers' replies to a ping
PING_TIMEOUT = 0.5


@dataclass(frozen=True)
class BrokerHealth:
    broker: Literal["ok", "unreachable"]
    #: workers that answered the ping; None when the broker could not be asked
    workers: int | None


class BrokerProbe:
    """Asks the broker of ``settings`` (made into a Celery app once, on first use)."""

    def __init__(self, settings: Settings) -> None:
        self._settings = settings
        self._celery: Celery | None = None

    def check(self) -> BrokerHealth:
        try:
            require_broker(self._settings, timeout=CONNECT_TIMEOUT)
        except BrokerUnavailable as exc:
            log.warning("health: %s", exc)
            return BrokerHealth("unreachable", None)
        if self._celery is None:
            self._celery = make_celery(self._settings)
        try:
            replies = self._celery.control.ping(timeout=PING_TIMEOUT)
        except Exception as exc:  # the broker went away between the two questions
            log.warning("health: cannot ping the workers: %s", exc)
            return BrokerHealth("unreachable", None)
        return BrokerHealth("ok", len(replies))
