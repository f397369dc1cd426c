"""infra/local-cluster.sh starts 2 workers, beat and Flower; Flower shows an epoch's tasks."""

from __future__ import annotations

import os
import subprocess
from collections.abc import Callable
from pathlib import Path

import httpx
import pytest
from tasks_cluster import ROOT, Cluster, free_port, wait_for
from tasks_helpers import client, run_epoch, seed_graph

pytestmark = [pytest.mark.slow, pytest.mark.postgres, pytest.mark.redis]
SCRIPT = ROOT / "infra" / "local-cluster.sh"


def _script(cluster: Cluster, *args: str) -> str:
    done = subprocess.run(
        ["bash", str(SCRIPT), *args],
        env=cluster.env,
        capture_output=True,
        text=True,
        timeout=60,
        check=True,
    )
    return done.stdout


def test_local_cluster_runs_an_epoch_that_flower_shows(
    cluster_env: Callable[..., Cluster], tmp_path: Path
) -> None:
    cluster = cluster_env(batch_size=2, beat_interval=3600)
    port = free_port()
    cluster.env.update(SRG_CLUSTER_DIR=str(tmp_path / "cluster"), SRG_FLOWER_PORT=str(port))
    graph_id = seed_graph(cluster.settings)
    out = _script(cluster, "start")
    try:
        assert out.count("started") == 4  # worker1, worker2, beat, flower
        pids = {p.stem: int(p.read_text()) for p in (tmp_path / "cluster").glob("*.pid")}
        assert set(pids) == {"worker1", "worker2", "beat", "flower"}
        api = f"http://127.0.0.1:{port}/api"

        def workers() -> set[str]:
            try:
                response = httpx.get(f"{api}/workers", params={"refresh": "1"}, timeout=5)
            except httpx.TransportError:
                return set()
            return set(response.json()) if response.status_code == 200 else set()

        wait_for(lambda: len(workers()) == 2, 60, "Flower to list both workers", every=1)
        assert {name.split("@")[0] for name in workers()} == {"worker1", "worker2"}
        run_epoch(cluster, client(cluster), graph_id)

        def task_names() -> set[str]:
            tasks = httpx.get(f"{api}/tasks", timeout=5).json()
            return {t["name"] for t in tasks.values() if t.get("state") == "SUCCESS"}

        expected = {"srg.grow_epoch", "srg.simulate", "srg.sdf", "srg.integrate"}
        wait_for(lambda: expected <= task_names(), 30, "Flower to show the epoch's tasks")
        assert "already running" in _script(cluster, "start")
    finally:
        _script(cluster, "stop")
    for pid in pids.values():
        assert not _alive(pid)


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    return True
