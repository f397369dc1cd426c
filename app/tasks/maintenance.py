"""Upkeep tasks that beat schedules besides growth."""

from __future__ import annotations

from dataclasses import asdict
from typing import Any

from app.services.artifact_gc import collect_artifacts as collect_orphaned
from app.tasks.celery_app import SrgTask, celery_app


@celery_app.task(name="srg.collect_artifacts", bind=True)
def collect_artifacts(self: SrgTask) -> dict[str, Any]:
    """``srg gc``: orphaned artifacts older than SRG_ARTIFACT_GC_GRACE; what it freed."""
    return asdict(collect_orphaned(self.settings))
