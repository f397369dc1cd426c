"""``srg bench completion``: how long the shell waits when the user presses tab.

Tab completion starts ``srg`` anew with the completion variables set: the process imports
the CLI, walks its command tree and prints the candidates. This times that process (wall
and CPU, the median of a few) and, apart, the import of ``app.cli.main`` in a fresh
interpreter, against the target of 0.3 s a completion. On a shared machine the wall time
is an upper bound.
"""

from __future__ import annotations

import os
import resource
import statistics
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

SRG = str(Path(sys.executable).with_name("srg"))
#: what the shell may wait for a completion
TARGET_SECONDS = 0.3


def bench_completion(repeats: int = 5, line: str = "srg exp") -> dict[str, Any]:
    """Median wall and CPU seconds of completing ``line`` and of importing the CLI."""
    env = {
        **os.environ,
        "_SRG_COMPLETE": "complete_bash",
        "COMP_WORDS": line,
        "COMP_CWORD": str(len(line.split()) - 1),
        "_TYPER_COMPLETE_ARGS": line,
    }
    completion = [_timed([SRG], env) for _ in range(repeats)]
    importer = [sys.executable, "-c", "import app.cli.main"]
    importing = [_timed(importer, None) for _ in range(repeats)]
    candidates = subprocess.run([SRG], env=env, capture_output=True, text=True, check=True)
    wall = statistics.median(seconds for seconds, _ in completion)
    return {
        "line": line,
        "candidates": candidates.stdout.split(),
        "repeats": repeats,
        "completion_wall_seconds": wall,
        "completion_cpu_seconds": statistics.median(cpu for _, cpu in completion),
        "import_cli_wall_seconds": statistics.median(seconds for seconds, _ in importing),
        "import_cli_cpu_seconds": statistics.median(cpu for _, cpu in importing),
        "target_seconds": TARGET_SECONDS,
        "met": wall <= TARGET_SECONDS,
    }


def _timed(command: list[str], env: dict[str, str] | None) -> tuple[float, float]:
    """Wall and CPU seconds (user and system, the child's) of running ``command`` once."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    started = time.perf_counter()
    subprocess.run(command, env=env, capture_output=True, check=True)
    wall = time.perf_counter() - started
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu
