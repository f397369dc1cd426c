"""``srg bench experiment``: the wall time of the paper's evaluation on this machine.

It runs ``srg experiment`` as a user would, in a temporary embedded database, and reports
wall and CPU time (the command and its run processes), frames grown per second, and per
run the growth seconds and peak resident memory per frame. CPU seconds over wall seconds
says how busy the cores were kept; on a shared machine the wall time is an upper bound.
"""

from __future__ import annotations

import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from app.core.errors import InvalidInput
from app.core.growth.kinds import parse_strategy
from app.db.engines import make_engine
from app.db.sessions import session_factory
from app.store.simulated_clips import reuse_counts

SRG = str(Path(sys.executable).with_name("srg"))


def bench_experiment(arguments: list[str]) -> dict[str, Any]:
    """Time ``srg experiment ARGUMENTS`` from an empty database; JSON-able figures."""
    with tempfile.TemporaryDirectory(prefix="srg-bench-experiment-") as var:
        env = {k: v for k, v in os.environ.items() if not k.startswith("SRG_")}
        env["SRG_VAR_DIR"] = var
        subprocess.run([SRG, "db", "upgrade"], env=env, check=True, capture_output=True)
        out = Path(var) / "result.json"
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        started = time.perf_counter()
        done = subprocess.run(
            [SRG, "experiment", *arguments, "--result", str(out)],
            env=env,
            capture_output=True,
            text=True,
        )
        wall = time.perf_counter() - started
        if done.returncode != 0:
            raise InvalidInput(done.stderr.strip().splitlines()[-1].removeprefix("srg: error: "))
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        result = json.loads(out.read_text())
        engine = make_engine(f"sqlite:///{Path(var) / 'srg.sqlite3'}")
        with session_factory(engine)() as session:
            grown, simulated = reuse_counts(session)
        engine.dispose()
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    # a run that reads no traces is played by every crowd: one graph per seed for all
    runs = {
        _run_key(strategy, bot, seed): {
            "frames": rows[-1]["size_frames"],
            "grow_s": round(sum(float(r["grow_seconds"]) for r in rows), 1),
            "peak_resident_mb": rows[-1]["resident_mb"],
            "resident_kb_per_frame": round(
                1024 * rows[-1]["resident_mb"] / rows[-1]["size_frames"], 2
            ),
        }
        for bot, crowd in result["crowds"].items()
        for strategy, by_seed in crowd["results"].items()
        for seed, rows in by_seed.items()
    }
    frames = sum(run["frames"] for run in runs.values())
    return {
        "command": " ".join(["srg", "experiment", *arguments]),
        "plan": result["plan"],
        "wall_s": round(wall, 1),
        "cpu_s": round(cpu, 1),
        "cores_busy": round(cpu / wall, 2),
        "cores": os.cpu_count(),
        "frames": frames,
        "frames_per_s": round(frames / wall, 2),
        "load_average_1min": round(os.getloadavg()[0], 2),
        # clips the epochs grew, and how many of them were simulated rather than reused
        # (docs/runtime.md, "Each simulation once")
        "clips_grown": grown,
        "clips_simulated": simulated,
        "runs": runs,
    }


def _run_key(strategy: str, bot: str, seed: str) -> str:
    if parse_strategy(strategy).learns_from_traces:
        return f"{strategy}/{bot}/{seed}"
    return f"{strategy}/{seed}"
