"""The workers' watchdog: a running epoch's missing work is held by someone, or re-sent.

A worker SIGKILLed mid-task takes the task with it: its unacknowledged message comes back
only after the visibility timeout (an hour), and meanwhile the epoch's chord waits for a
part that never reports. Nothing outside the workers can be relied on to notice: beat may
be off, and a quiet-time rule cannot tell a lost clip from a slow one while the epoch's
other clips keep its heartbeat moving. So every worker runs this watchdog, a daemon
thread of its main process started on ``worker_ready`` (not a periodic task, which a
dead worker could take with it), and the cluster looks every ``SRG_EPOCH_CHECK_INTERVAL``
seconds: the worker whose turn it is (a short Redis key, so that they do not all
broadcast) asks, for every running epoch, which of its missing work no live worker or
queue holds (:mod:`app.tasks.liveness`). What is unheld on two looks in a row (a step
hands over to the next between two questions, and one look can miss it) is lost, and the
epoch is re-sent as ``grow_epoch`` sends one: its missing clips and pending integrations
(:func:`app.services.epochs.resend_epoch`, :func:`app.tasks.growth.epoch_canvas`). Every
step is idempotent, so the message that comes back an hour later is a no-op. A lost
clip is re-sent within about two intervals and a broadcast of the loss; see
docs/runtime.md, "Lost work".

The thread opens a database connection per look and keeps none (``NullPool``): the
prefork pool forks new children from this process, and must not share a connection.
"""

from __future__ import annotations

import json
import logging
import threading
from typing import Any

from celery.signals import worker_ready, worker_shutting_down
from sqlalchemy.orm import Session, sessionmaker
from sqlalchemy.pool import NullPool

from app.config import Settings, get_settings
from app.db.engines import make_engine
from app.db.sessions import session_factory, unit_of_work
from app.services import epochs
from app.tasks.celery_app import celery_app
from app.tasks.growth import epoch_canvas
from app.tasks.liveness import held_work, unheld_work

log = logging.getLogger(__name__)

#: Redis key held by the worker that looks now; it lapses after half an interval
TURN_KEY = "srg:watchdog:turn"
#: Redis key of the last look's unheld work, {epoch id: [part, ...]}, for the next look
UNHELD_KEY = "srg:watchdog:unheld"
#: how many intervals the last look's findings count: older ones are no evidence
UNHELD_FOR = 3

_stopping = threading.Event()


@worker_ready.connect
def _start_watching(sender: Any, **_: Any) -> None:
    settings = get_settings()
    if not settings.broker_url.startswith(("redis://", "rediss://")):
        return  # liveness cannot be told: SRG_EPOCH_RESEND_AFTER is all there is
    threading.Thread(
        target=_watch, args=(settings, sender.hostname), name="srg-watchdog", daemon=True
    ).start()


@worker_shutting_down.connect
def _stop_watching(**_: Any) -> None:
    _stopping.set()  # a worker on its way out re-sends nothing


def _watch(settings: Settings, hostname: str) -> None:
    factory = session_factory(make_engine(settings.resolved_database_url, poolclass=NullPool))
    interval = settings.runtime.epoch_check_interval
    while not _stopping.wait(interval):
        try:
            _look(factory, settings, hostname)
        except Exception:  # the database or Redis is away: the next look tries again
            log.exception("the epoch watchdog could not look; it looks again in %gs", interval)


def _look(factory: sessionmaker[Session], settings: Settings, hostname: str) -> None:
    """One look at every running epoch, if it is this worker's turn (see the module doc)."""
    interval_ms = max(1, int(settings.runtime.epoch_check_interval * 1000))
    with celery_app.connection_for_write() as connection:
        client = connection.default_channel.client
        if not client.set(TURN_KEY, hostname, nx=True, px=max(1, interval_ms // 2)):
            return
        if not _running_work(factory):
            client.delete(UNHELD_KEY)
            return
        held = held_work(celery_app)
        if held is None:
            return
        works = _running_work(factory)  # after the broadcast: what was recorded meanwhile
        before = json.loads(client.get(UNHELD_KEY) or "{}")
        unheld = {str(work.epoch_id): unheld_work(work, held) for work in works}
        for work in works:
            key = str(work.epoch_id)
            lost = [part for part in unheld[key] if part in before.get(key, [])]
            if lost and _resend(factory, work.epoch_id, lost):
                del unheld[key]  # what it re-sent is held now: two fresh looks to doubt it
        client.set(UNHELD_KEY, json.dumps(unheld), px=UNHELD_FOR * interval_ms)


def _running_work(factory: sessionmaker[Session]) -> list[epochs.EpochWork]:
    with unit_of_work(factory) as session:
        return epochs.running_work(session)


def _resend(factory: sessionmaker[Session], epoch_id: int, lost: list[str]) -> bool:
    """Send what is left of a running epoch again (rendering as the epoch was planned
    to); whether it still ran."""
    with unit_of_work(factory) as session:
        plan = epochs.resend_epoch(session, epoch_id)
        if plan is None:
            return False
        work = epochs.epoch_work(session, epoch_id)
    epoch_canvas(work).apply_async()
    log.warning(
        "graph %d epoch %d: no worker or queue holds its work (%s): re-sent",
        plan.graph_id,
        epoch_id,
        ", ".join(lost),
    )
    return True
