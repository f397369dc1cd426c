"""Loaded into the test cluster's workers (``celery worker --include=slow_simulate``):
``srg.simulate`` sleeps ``TESTS_SIMULATE_DELAY`` seconds first, a window in which a
test kills the worker mid-task. A test's knob, so it lives with the tests, not in srg's
settings.
"""

from __future__ import annotations

import os
import time
from typing import Any

from celery.signals import task_prerun

#: the environment variable the cluster sets (not ``SRG_``: no setting of srg)
SIMULATE_DELAY = "TESTS_SIMULATE_DELAY"


@task_prerun.connect
def _slow_simulate(sender: Any = None, **_: Any) -> None:
    delay = float(os.environ.get(SIMULATE_DELAY, "0"))
    if delay > 0 and getattr(sender, "name", None) == "srg.simulate":
        time.sleep(delay)
