"""Admin growth off the request: a Celery ``grow_epoch`` with a broker, a background job of
this server without one.

Growing by up to 10,000 expansions takes minutes to hours, far longer than an HTTP request
should hold a connection and a worker thread, so the admin grow route only queues the
growth and answers 202 with the epochs to poll. In the embedded mode the job runs
:func:`app.services.growing.grow_graph` after the response, one transaction per step, so
every finished step is kept if the server stops, and the next grow finishes the epoch that
was interrupted. One job per graph at a time in a server process: two would run the
same epoch twice over.
"""

from __future__ import annotations

import logging
import threading

from app.config import Settings
from app.db.sessions import Transactions
from app.services.growth_tracking import end_request, failure_reason, start_request

log = logging.getLogger(__name__)
#: seconds the admin grow route waits for the broker to take a growth: its client waits
SEND_TIMEOUT = 3.0


class GrowthJobs:
    """The graphs this server process is growing in the background."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._graphs: set[int] = set()

    def claim(self, graph_id: int) -> bool:
        """Take the graph for a new job; False if a job of this server grows it already."""
        with self._lock:
            if graph_id in self._graphs:
                return False
            self._graphs.add(graph_id)
            return True

    def release(self, graph_id: int) -> None:
        with self._lock:
            self._graphs.discard(graph_id)

    def running(self, graph_id: int) -> bool:
        with self._lock:
            return graph_id in self._graphs


def grow_in_background(
    jobs: GrowthJobs,
    transactions: Transactions,
    settings: Settings,
    graph_id: int,
    expansions: int,
    request_id: int,
) -> None:
    """Grow a claimed graph by ``expansions``, then release it. Nobody waits on a
    background job to raise to, so how it ended goes to its request row, which the poll
    route shows (and to the log)."""
    from app.services import growing  # growth is loaded when something grows

    try:
        with transactions() as session:
            start_request(session, request_id)
        result = growing.grow_graph(transactions, settings, name=graph_id, expansions=expansions)
    except Exception as exc:
        log.exception("background growth of graph %d failed", graph_id)
        _record_failure(transactions, request_id, exc)
    else:
        with transactions() as session:
            end_request(session, request_id, done=result.expansions)
        log.info(
            "graph %d grew by %d expansions in %d epochs (%d frames)",
            graph_id,
            result.expansions,
            result.epochs,
            result.size_frames,
        )
    finally:
        jobs.release(graph_id)


def _record_failure(transactions: Transactions, request_id: int, exc: Exception) -> None:
    try:
        with transactions() as session:
            end_request(session, request_id, failure=failure_reason(exc))
    except Exception:  # the database itself failed: the poll then reports a lost job
        log.exception("could not record the failure of growth request %d", request_id)


def send_to_workers(settings: Settings, graph_id: int, expansions: int, request_id: int) -> None:
    """One ``srg.grow_epoch`` of ``expansions``: a worker plans the epoch and fans it out.

    Sent to the broker of ``settings`` (the one the route judged eager or not by) over a
    connection of its own that waits :data:`SEND_TIMEOUT` at most and is never retried:
    a broker that cannot take the work is a :class:`BrokerUnavailable` (a 503) while the
    client waits, not Celery's retries. No result is kept: nobody reads it, and Redis's
    result backend would first subscribe to it, retrying for about 19 s with Redis down.
    """
    from kombu.exceptions import OperationalError

    from app.tasks import growth
    from app.tasks.celery_app import BrokerUnavailable, make_celery

    workers = make_celery(settings)
    arguments = (graph_id, expansions, settings.render.growth_renders, request_id)
    try:
        with workers.connection_for_write(connect_timeout=SEND_TIMEOUT) as connection:
            workers.send_task(
                growth.grow_epoch.name,
                arguments,
                connection=connection,
                ignore_result=True,
                retry_policy={"max_retries": 0},
            )
    except OperationalError as exc:
        raise BrokerUnavailable(f"the broker cannot take the growth: {exc}") from None
