"""An experiment's run processes die with the experiment's process, whatever they are doing.

The run process here is busy the way a run is at its worst for a watcher thread of its
own: its main thread holds the GIL (``sum`` over an endless iterator, in C, as a run is
inside a long NumPy call), so no other thread of it ever runs again. Its parent is
SIGKILLed meanwhile; the run must end with it, not after its busy stretch (here: never).
"""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

from process_helpers import alive

#: the experiment's process: one run process spawned from its main thread and set up as
#: the experiment sets its own, busy with ``exec(RUN)``; the parent then waits to be killed
PARENT = """
import os, sys, time
from multiprocessing import get_context
setup = f"from app.services.experiment.runs import die_with_parent; die_with_parent({os.getpid()})"
get_context("spawn").Process(target=exec, args=(setup + "\\n" + sys.argv[1],)).start()
time.sleep(600)
"""
#: the run: says it started (with its pid), then holds the GIL for ever
RUN = """
import itertools, os, pathlib
pathlib.Path({started!r}).write_text(str(os.getpid()))
sum(itertools.repeat(1))
"""
#: seconds a starting run and a killed one get, against the machine's load (a run that
#: does not die with its parent never ends)
PATIENCE = 120


def test_a_run_process_holding_the_gil_dies_with_its_killed_parent(tmp_path: Path) -> None:
    started = tmp_path / "started"
    parent = subprocess.Popen(
        [sys.executable, "-c", PARENT, RUN.format(started=str(started))],
        start_new_session=True,
    )
    try:
        deadline = time.monotonic() + PATIENCE
        while not started.exists() or not started.read_text():
            assert parent.poll() is None and time.monotonic() < deadline, "no run started"
            time.sleep(0.05)
        run = int(started.read_text())
        parent.kill()
        parent.wait(10)
        deadline = time.monotonic() + PATIENCE
        while alive(run):
            assert time.monotonic() < deadline, "the run process outlived its killed parent"
            time.sleep(0.05)
    finally:
        with contextlib.suppress(ProcessLookupError):  # the run too, should it live on
            os.killpg(parent.pid, signal.SIGKILL)
