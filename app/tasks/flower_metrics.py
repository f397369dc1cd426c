"""Flower's ``/metrics`` behind the login of the rest of Flower.

Flower 2 serves its Prometheus metrics without asking for its basic auth (every page and
its ``/api`` ask): task names, worker host names and queue lengths to anyone who can
reach the port. :func:`guard_metrics` swaps its handler for one that asks as Flower's
pages do (``tornado.web.authenticated``: 401 without the password of
``SRG_FLOWER_BASIC_AUTH``; open only where no auth is configured, like every page). A
Prometheus scrape job gives the same user and password (``basic_auth`` in its config).
``/healthcheck`` stays open: it answers "OK" and nothing else.
"""

from __future__ import annotations

import tornado.web
from flower import urls
from flower.views.monitor import Metrics

METRICS_PATH = r"/metrics"


class AuthenticatedMetrics(Metrics):
    @tornado.web.authenticated
    async def get(self) -> None:
        await super().get()


def guard_metrics() -> None:
    """Serve ``/metrics`` with :class:`AuthenticatedMetrics`, before Flower builds its app
    (its list of handlers is the one :mod:`flower.app` reads)."""
    for index, handler in enumerate(urls.handlers):
        if isinstance(handler, tuple) and handler[0] == METRICS_PATH:
            urls.handlers[index] = (METRICS_PATH, AuthenticatedMetrics, *handler[2:])
            return
    raise RuntimeError("Flower serves no /metrics to guard: its routes have changed")
