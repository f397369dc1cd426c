"""Helpers of the browser tests: the headless Chromium they drive, and a player's keys."""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pytest
from sqlalchemy import select
from sqlalchemy.orm import Session

from app.models import TraceStep

if TYPE_CHECKING:
    from playwright.sync_api import Page

CHROMIUM = Path("/usr/bin/chromium")
CHROMIUM_ARGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
]
DESKTOP = {"width": 1280, "height": 800}
#: key held, and for how long (ms): left and right tilts, level between
KEY_PATTERN = [("ArrowLeft", 700), (None, 400), ("ArrowRight", 800), ("ArrowUp", 300)]


def require_chromium() -> None:
    """Skip without Chromium, except in CI (CI=true), where a missing browser is a failure:
    infra installs it there."""
    if CHROMIUM.exists():
        return
    if os.environ.get("CI") == "true":
        pytest.fail(f"{CHROMIUM} is missing in CI (infra/services.sh installs it)")
    pytest.skip(f"{CHROMIUM} is missing (apt-get install -y chromium)")


def play_with_keys(page: Page) -> None:
    """One round of :data:`KEY_PATTERN`."""
    for key, ms in KEY_PATTERN:
        if key:
            page.keyboard.down(key)
        page.wait_for_timeout(ms)
        if key:
            page.keyboard.up(key)


def trace_steps(session: Session, trace_id: int) -> np.ndarray:
    """(n, 2) int64 (vertex, control) of one stored trace, in play order."""
    rows = session.execute(
        select(TraceStep.vertex, TraceStep.control)
        .where(TraceStep.trace_id == trace_id)
        .order_by(TraceStep.step)
    ).all()
    return np.array(rows, dtype=np.int64)
