"""Helpers of the browser tests: whether they can drive headless Chromium, and the traces
they leave. The browser, its arguments and a player's keys are ``srg bench client``'s
(:mod:`app.bench.client`), which plays the same way."""

from __future__ import annotations

import os

import numpy as np
import pytest
from sqlalchemy import select
from sqlalchemy.orm import Session

from app.bench.client import CHROMIUM
from app.models import TraceStep


def require_chromium() -> None:
    """Skip without Chromium, except in CI (CI=true), where a missing browser is a failure:
    infra installs it there."""
    if CHROMIUM.exists():
        return
    if os.environ.get("CI") == "true":
        pytest.fail(f"{CHROMIUM} is missing in CI (infra/services.sh installs it)")
    pytest.skip(f"{CHROMIUM} is missing (apt-get install -y chromium)")


def trace_steps(session: Session, trace_id: int) -> np.ndarray:
    """(n, 2) int64 (vertex, control) of one stored trace, in play order."""
    rows = session.execute(
        select(TraceStep.vertex, TraceStep.control)
        .where(TraceStep.trace_id == trace_id)
        .order_by(TraceStep.step)
    ).all()
    return np.array(rows, dtype=np.int64)
