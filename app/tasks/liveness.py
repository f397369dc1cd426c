"""Is anything still working on an epoch? Asked of the workers and of the broker.

An epoch's heartbeat moves only when a clip is recorded or an expansion integrated, and
one clip of a big preset may take minutes, so a quiet epoch is not yet a dead one. When
it has been quiet for ``SRG_EPOCH_CHECK_AFTER`` seconds, ``grow_epoch`` asks:

- the live workers (a control broadcast answers only from running workers, so it is
  their heartbeat): does one run, hold or schedule a task of the epoch?
- the broker: does a message of the epoch wait in the queue?

If neither, the work was lost (a SIGKILLed worker's unacknowledged message only comes
back after the visibility timeout; a restarted Redis keeps nothing) and the epoch is
re-sent at once. Every step is idempotent, so the message that comes back late costs
a no-op, never a second clip. When the answer is unknown (no Redis broker, the broadcast
failed) the work counts as alive and ``SRG_EPOCH_RESEND_AFTER`` stays the backstop.
See docs/runtime.md, "Lost work".
"""

from __future__ import annotations

import ast
import base64
import json
import logging
from collections.abc import Iterable, Mapping
from typing import Any

from celery import Celery

log = logging.getLogger(__name__)

#: where the epoch id sits in each epoch task's arguments
EPOCH_ARG = {"srg.simulate": 0, "srg.integrate": 0, "srg.blend": 0, "srg.sdf": 1, "srg.render": 1}
#: seconds to wait for the workers' replies to one broadcast
REPLY_TIMEOUT = 1.0


def epoch_work_alive(app: Celery, epoch_id: int) -> bool:
    """Whether a live worker or the broker's queue still holds a task of ``epoch_id``."""
    if not app.conf.broker_url.startswith(("redis://", "rediss://")):
        return True
    try:
        return _held_by_workers(app, epoch_id) or _queued(app, epoch_id)
    except Exception as exc:  # a broker that is restarting: unknown, so keep waiting
        log.warning("cannot tell whether epoch %d is alive: %s", epoch_id, exc)
        return True


def _held_by_workers(app: Celery, epoch_id: int) -> bool:
    inspect = app.control.inspect(timeout=REPLY_TIMEOUT)
    for replies in (inspect.active(), inspect.reserved(), inspect.scheduled()):
        for requests in (replies or {}).values():
            # scheduled() wraps each request with its ETA
            if _of_epoch((r.get("request", r) for r in requests), epoch_id):
                return True
    return False


def _queued(app: Celery, epoch_id: int) -> bool:
    queue = app.conf.task_default_queue
    with app.connection_for_read() as connection:
        client = connection.default_channel.client
        raw = client.lrange(queue, 0, -1)
    return _of_epoch((_request_of(json.loads(m)) for m in raw), epoch_id)


def _request_of(message: Mapping[str, Any]) -> dict[str, Any]:
    """A queued message as a request: its task name and positional arguments."""
    body = message["body"]
    if message.get("properties", {}).get("body_encoding") == "base64":
        body = base64.b64decode(body)
    args, _kwargs, _embed = json.loads(body)
    return {"name": message.get("headers", {}).get("task"), "args": args}


def _of_epoch(requests: Iterable[Mapping[str, Any]], epoch_id: int) -> bool:
    for request in requests:
        position = EPOCH_ARG.get(request.get("name") or request.get("type", ""))
        if position is None:
            continue
        args = request.get("args") or []
        if isinstance(args, str):  # some Celery versions report args as their repr
            args = ast.literal_eval(args)
        if len(args) > position and args[position] == epoch_id:
            return True
    return False
