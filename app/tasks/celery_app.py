"""The Celery app, configured from :class:`~app.config.Settings` (nothing else).

With a broker (``SRG_BROKER_URL=redis://...``) tasks go through Redis to workers; with
none, ``task_always_eager`` runs every task in-process, so the embedded default needs
no service at all.

Delivery: ``acks_late`` with ``reject_on_worker_lost`` and a prefetch of one, so a task
whose worker dies goes back to the queue instead of vanishing; the Redis visibility
timeout (read by Celery from ``broker_transport_options``) is far above the hard time
limit, so a message is never handed to a second worker while the first still runs it.
Every task is idempotent, so a redelivery is harmless; :class:`SrgTask` caps
redeliveries so that a task that kills its worker every time does not loop forever, and
holds what every task works in: the settings, one artifact store and one scope a step
(:mod:`app.services.scope`).
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from contextlib import AbstractContextManager
from functools import partial
from typing import Any

from celery import Celery, Task
from celery.exceptions import Reject

from app.config import Settings, get_settings
from app.core.errors import Unavailable
from app.services.loading import artifact_store
from app.services.scope import Scope, step_scope

log = logging.getLogger(__name__)
DELIVERY_KEY = "srg:deliveries:"


def celery_config(settings: Settings) -> dict[str, Any]:
    broker = settings.broker_url or "memory://"
    transport = {"visibility_timeout": settings.runtime.visibility_timeout}
    return {
        "broker_url": broker,
        "result_backend": settings.result_backend or default_result_backend(settings.broker_url),
        "task_always_eager": settings.eager,
        "task_eager_propagates": True,
        "task_acks_late": True,
        "task_reject_on_worker_lost": True,
        "worker_prefetch_multiplier": 1,
        "task_soft_time_limit": settings.runtime.task_soft_time_limit,
        "task_time_limit": settings.runtime.task_time_limit,
        "broker_transport_options": transport,
        "result_backend_transport_options": transport,
        "broker_connection_retry_on_startup": True,
        "task_serializer": "json",
        "result_serializer": "json",
        "accept_content": ["json"],
        "result_expires": 24 * 3600,
        # Flower shows what it is told: task events and "started" states
        "worker_send_task_events": True,
        "task_send_sent_event": True,
        "task_track_started": True,
        "beat_schedule": beat_schedule(settings),
    }


def default_result_backend(broker: str) -> str:
    """Where results go without ``SRG_RESULT_BACKEND``: a Redis broker holds them too; an
    AMQP one has no result store (Celery 5 has no ``amqp`` backend), so they come back
    over its connection (``rpc://``); with no broker (eager), this process's memory."""
    if not broker:
        return "cache+memory://"
    redis = broker.startswith(("redis", "sentinel"))  # redis, rediss, redis+socket too
    return broker if redis else "rpc://"


def beat_schedule(settings: Settings) -> dict[str, dict[str, Any]]:
    """Growth ticks, and (unless its interval is 0) collection of orphaned artifacts."""
    schedule: dict[str, dict[str, Any]] = {
        "grow-graphs": {"task": "srg.schedule_growth", "schedule": settings.runtime.beat_interval}
    }
    if settings.runtime.artifact_gc_interval > 0:
        schedule["collect-artifacts"] = {
            "task": "srg.collect_artifacts",
            "schedule": settings.runtime.artifact_gc_interval,
        }
    return schedule


class SrgTask(Task):
    """Every srg task: delivered at most ``task_max_retries + 1`` times (counted in
    Redis), working in the worker's settings and one transaction a step.

    acks_late redelivers a task whose worker died; if the task itself kills the worker
    (out of memory, a crash in native code) that would never end. The count is keyed by
    the task id (which a redelivery keeps) and the retry number.
    """

    _settings: Settings
    _steps: Callable[[], AbstractContextManager[Scope]]

    @property
    def settings(self) -> Settings:
        """The settings this call works in, read once as it starts (:meth:`__call__`)."""
        return self._settings

    def scope(self) -> AbstractContextManager[Scope]:
        """One step's scope: a transaction on the settings' database, committed when the
        step ends well, with this call's settings and artifact store."""
        return self._steps()

    def __call__(self, *args: Any, **kwargs: Any) -> Any:
        self._settings = get_settings()  # once a call: the environment of this delivery
        self._steps = partial(step_scope, self._settings, artifact_store(self._settings))
        if not self.request.is_eager and self.request.id:
            self._count_delivery(f"{self.request.id}:{self.request.retries or 0}")
        return super().__call__(*args, **kwargs)

    def _count_delivery(self, task_id: str) -> None:
        settings = self.settings
        url = settings.resolved_redis_url
        if not url:
            return
        try:
            client = _redis(url)
            key = DELIVERY_KEY + task_id
            deliveries = client.incr(key)
            client.expire(
                key, settings.runtime.visibility_timeout * (settings.runtime.task_max_retries + 2)
            )
        except Exception as exc:  # counting is a safety net; Redis trouble must not block work
            log.warning("cannot count deliveries of %s: %s", task_id, exc)
            return
        if deliveries > settings.runtime.task_max_retries + 1:
            raise Reject(f"task {task_id} delivered {deliveries} times: dropped", requeue=False)


_clients: dict[str, Any] = {}


def _redis(url: str) -> Any:
    if url not in _clients:
        import redis

        _clients[url] = redis.Redis.from_url(url, socket_timeout=2.0)
    return _clients[url]


#: seconds to wait for the broker when checking it
BROKER_CHECK_TIMEOUT = 3.0


class BrokerUnavailable(Unavailable):
    """The configured broker cannot be reached, or cannot take the work sent."""


def require_broker(settings: Settings, timeout: float = BROKER_CHECK_TIMEOUT) -> None:
    """Connect to the configured broker once, before a command writes anything it would
    then strand (or, with a shorter ``timeout``, for ``GET /api/health``).

    Without this an unreachable broker surfaces at the first ``delay``: after the command
    stored its rows, as kombu's traceback (a URL of no transport Celery can use is refused
    with the settings: :data:`app.config_types.BROKER_SCHEMES`). The settings' URL is the one
    checked, not this process's app's, which was configured when first imported.
    """
    from kombu import Connection

    shown = "(SRG_BROKER_URL)"
    try:
        with Connection(settings.broker_url, connect_timeout=timeout) as connection:
            shown = connection.as_uri()  # the password masked
            connection.ensure_connection(
                max_retries=1, interval_start=0, interval_step=0.5, timeout=timeout
            )
    except Exception as exc:
        message = f"cannot reach the broker {shown}: {exc}".splitlines()[0]
        raise BrokerUnavailable(message) from None


def make_celery(settings: Settings) -> Celery:
    app = Celery("srg", task_cls=SrgTask)
    app.conf.update(celery_config(settings))
    return app


celery_app = make_celery(get_settings())
