"""`srg experiment` with a broker: growth runs on a real worker through ``grow_epoch``.

The numbers equal those of the embedded run of the same plan (SQLite, in-process).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from sqlalchemy import func, select
from tasks_cluster import Cluster

from app.models import ExperimentCheckpoint, GrowthEpoch
from app.services.experiment.results import comparable_figures

pytestmark = [pytest.mark.slow, pytest.mark.postgres, pytest.mark.redis]
SRG = str(Path(sys.executable).with_name("srg"))
PLAN = (
    "--strategies", "baseline,sr-crowd", "--seeds", "4", "--checkpoints", "300,900",
    "--sessions", "6",
)  # fmt: skip


def experiment(env: dict[str, str], out: Path) -> dict[str, Any]:
    done = subprocess.run(
        [SRG, "experiment", *PLAN, "--result", str(out)],
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    return dict(json.loads(out.read_text()))


def test_the_experiment_grows_on_workers_to_the_embedded_numbers(
    cluster_env: Callable[..., Cluster], tmp_path: Path
) -> None:
    cluster = cluster_env()
    subprocess.run([SRG, "db", "upgrade"], env=cluster.env, check=True, capture_output=True)
    cluster.start_worker("w1", concurrency=2)
    on_workers = experiment(cluster.env, tmp_path / "workers.json")
    log = (cluster.logs / "w1.log").read_text(errors="replace")
    assert "Task srg.grow_epoch[" in log and "Task srg.integrate[" in log
    assert "Task srg.render[" not in log  # the experiment grows without renders
    with cluster.session() as session:
        # baseline, sr-heuristic (sr-crowd's control) and sr-crowd at two checkpoints
        assert session.scalar(select(func.count()).select_from(ExperimentCheckpoint)) == 6
        assert session.scalar(select(func.count()).select_from(GrowthEpoch)) > 0

    embedded_env = {k: v for k, v in os.environ.items() if not k.startswith("SRG_")}
    embedded_env["SRG_VAR_DIR"] = str(tmp_path / "embedded")
    subprocess.run([SRG, "db", "upgrade"], env=embedded_env, check=True, capture_output=True)
    embedded = experiment(embedded_env, tmp_path / "embedded.json")
    assert comparable_figures(on_workers) == comparable_figures(embedded)
    for bot, crowd in on_workers["crowds"].items():
        assert crowd["summary"] == embedded["crowds"][bot]["summary"]
    assert on_workers["comparison"] == embedded["comparison"]
