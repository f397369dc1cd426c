"""Which of the epochs' work is still held? Asked of the workers and of the broker.

Held means:

- a live worker runs, holds or schedules the task (a control broadcast answers only from
  running workers, so the answer is their heartbeat);
- or its message waits in the broker's queue.

A task held by neither was lost: a SIGKILLed worker's unacknowledged message only comes
back after the visibility timeout, and a restarted Redis keeps nothing. What an epoch
still needs (:func:`app.services.epochs.epoch_work`) against what is held is
:func:`unheld_work`; :mod:`app.tasks.watchdog` asks it of every running epoch. When the
answer is unknown (no Redis broker, the broadcast failed) :func:`held_work` says so, and
``SRG_EPOCH_RESEND_AFTER`` stays the backstop. See docs/runtime.md, "Lost work".
"""

from __future__ import annotations

import ast
import base64
import json
import logging
from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass
from typing import Any

from celery import Celery

from app.services.epochs import EpochWork

log = logging.getLogger(__name__)

#: where the epoch id sits in each epoch task's arguments
EPOCH_ARG = {"srg.simulate": 0, "srg.integrate": 0, "srg.blend": 0, "srg.sdf": 1, "srg.render": 1}
#: the steps of one clip: their epoch id is followed by the clip's position and control
CLIP_STEPS = frozenset({"srg.simulate", "srg.sdf", "srg.render"})
#: seconds to wait for the workers' replies to one broadcast
REPLY_TIMEOUT = 1.0


@dataclass(frozen=True)
class HeldWork:
    """The epoch tasks that live workers run, hold or schedule, or that wait in the queue."""

    #: (epoch, position, control) of every clip step held
    clips: frozenset[tuple[int, int, int]]
    #: every epoch of which any step is held, clip or integrating
    epochs: frozenset[int]


def held_work(app: Celery) -> HeldWork | None:
    """What the live workers and the broker's queue hold; None when that cannot be told."""
    if not app.conf.broker_url.startswith(("redis://", "rediss://")):
        return None
    try:
        requests = [*_queued(app), *_held_by_workers(app)]
    except Exception as exc:  # a broker that is restarting: unknown, so keep waiting
        log.warning("cannot tell which epoch work is held: %s", exc)
        return None
    held = list(_epoch_tasks(requests))
    return HeldWork(
        clips=frozenset((e, *clip) for e, clip in held if clip is not None),
        epochs=frozenset(e for e, _ in held),
    )


def unheld_work(work: EpochWork, held: HeldWork) -> list[str]:
    """The parts of a running epoch's missing work that nobody holds, named for the log.

    A missing clip must be held by one of its steps; once no clip is missing, some step
    of the epoch must be held (the integrating chain, or a step about to hand over to
    it). An epoch with nothing left pending has finished: nothing to hold.
    """
    if work.missing_clips:
        e = work.epoch_id
        return [f"clip {p}/{c}" for p, c in work.missing_clips if (e, p, c) not in held.clips]
    if work.pending and work.epoch_id not in held.epochs:
        return ["integration"]
    return []


def _held_by_workers(app: Celery) -> Iterator[Mapping[str, Any]]:
    """Asked in the order a task moves (queue, then scheduled or reserved, then active),
    so that one moving on between two questions is seen by the later one."""
    inspect = app.control.inspect(timeout=REPLY_TIMEOUT)
    for replies in (inspect.scheduled(), inspect.reserved(), inspect.active()):
        for requests in (replies or {}).values():
            # scheduled() wraps each request with its ETA
            yield from (r.get("request", r) for r in requests)


def _queued(app: Celery) -> list[dict[str, Any]]:
    queue = app.conf.task_default_queue
    with app.connection_for_read() as connection:
        client = connection.default_channel.client
        raw = client.lrange(queue, 0, -1)
    return [_request_of(json.loads(m)) for m in raw]


def _request_of(message: Mapping[str, Any]) -> dict[str, Any]:
    """A queued message as a request: its task name and positional arguments."""
    body = message["body"]
    if message.get("properties", {}).get("body_encoding") == "base64":
        body = base64.b64decode(body)
    args, _kwargs, _embed = json.loads(body)
    return {"name": message.get("headers", {}).get("task"), "args": args}


def _epoch_tasks(
    requests: Iterable[Mapping[str, Any]],
) -> Iterator[tuple[int, tuple[int, int] | None]]:
    """(epoch, (position, control) of a clip step or None) of each epoch task."""
    for request in requests:
        name = request.get("name") or request.get("type", "")
        position = EPOCH_ARG.get(name)
        if position is None:
            continue
        args = request.get("args") or []
        if isinstance(args, str):  # some Celery versions report args as their repr
            args = ast.literal_eval(args)
        if len(args) <= position:
            continue
        if name in CLIP_STEPS and len(args) >= position + 3:
            yield args[position], (args[position + 1], args[position + 2])
        else:
            yield args[position], None
