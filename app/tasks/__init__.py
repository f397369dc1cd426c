"""Celery: the app (``celery -A app.tasks worker``), the growth and upkeep tasks it runs,
and the watchdog each worker runs beside them."""

from app.tasks.celery_app import celery_app

app = celery_app

# register the tasks, and the watchdog's start on worker_ready, on the app
from app.tasks import growth as _growth  # noqa: E402,F401
from app.tasks import maintenance as _maintenance  # noqa: E402,F401
from app.tasks import watchdog as _watchdog  # noqa: E402,F401

__all__ = ["app", "celery_app"]
