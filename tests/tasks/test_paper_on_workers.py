"""The paper's resolution grown on the local cluster: ``srg init --preset paper``'s
initial tree, ``set-growing`` on, and beat's tick plans an epoch that the two workers of
``infra/local-cluster.sh`` simulate, render and integrate.

The slowest test of the suite (minutes: 43,824 particles), kept to one expansion.
"""

from __future__ import annotations

import re
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import pytest
from sqlalchemy import select
from tasks_cluster import ROOT, Cluster, wait_for
from tasks_helpers import finished_epochs, snapshot

from app.db.engines import make_engine
from app.db.sessions import session_factory
from app.models import GrowthEpoch
from app.services.creation import init_graph
from app.services.rank_relink_publish import set_growing
from app.services.status import graph_summary

pytestmark = [pytest.mark.slow, pytest.mark.postgres, pytest.mark.redis]
SCRIPT = ROOT / "infra" / "local-cluster.sh"
BLENDED = re.compile(r"Task srg\.blend\[[^\]]+\] succeeded")


def test_beat_grows_a_paper_graph_on_the_local_cluster_with_its_animations(
    cluster_env: Callable[..., Cluster], tmp_path: Path
) -> None:
    # beat ticks every 2 s and only grows (publish_every 0: a first publication would
    # render the whole tree first)
    cluster = cluster_env(batch_size=1, growth_renders=True, publish_every=0, beat_interval=2)
    cluster.env["SRG_CLUSTER_DIR"] = str(tmp_path / "cluster")
    cluster.env["SRG_COMMAND"] = str(Path(sys.executable).parent / "srg")  # this venv's
    sessions = session_factory(make_engine(cluster.settings.resolved_database_url))
    with sessions() as session:
        made = init_graph(
            session, cluster.settings, name="paper", dynamics="liquid", preset="paper"
        )
        session.commit()
    graph_id = int(made["id"])  # type: ignore[call-overload]
    assert (made["preset"], made["size_frames"], made["sim_edges"]) == ("paper", 120, 3)
    assert made["unrendered_edges"] == 12  # the tree's 3 SIM and 9 BLEND edges

    def script(command: str) -> None:
        subprocess.run(["bash", str(SCRIPT), command], env=cluster.env, timeout=120, check=True)

    def logs() -> str:
        found = (tmp_path / "cluster").glob("worker*.log")
        return "".join(log.read_text(errors="replace") for log in found)

    def epochs() -> int:
        with cluster.session() as session:
            rows = session.scalars(select(GrowthEpoch.id).where(GrowthEpoch.graph_id == graph_id))
            return len(rows.all())

    script("start")
    try:
        with sessions() as session:
            set_growing(session, graph_id, True)
            session.commit()
        wait_for(lambda: epochs() == 1, 120, "beat to open an epoch", every=1)
        with sessions() as session:  # one epoch is enough: no tick opens a second
            set_growing(session, graph_id, False)
            session.commit()
        wait_for(lambda: finished_epochs(cluster, graph_id) == 1, 1800, "the epoch", every=2)
        wait_for(lambda: BLENDED.search(logs()) is not None, 900, "the blend strips", every=2)
    finally:
        script("stop")
    with cluster.session() as session:
        grown = graph_summary(session, graph_id)
        final = snapshot(session, cluster.settings, graph_id)  # checks the graph whole
    assert epochs() == 1
    assert grown["size_frames"] == 150 and grown["sim_edges"] == 4
    assert len(final["vertex_control"]) == 1 + 3 + 1
    # 15 edges: the new vertex's 3 blends were rendered by the workers' blend task; the
    # tree's 12 (the expanded one among them) wait for a publication to render them
    assert grown["unrendered_edges"] == 15 - 3
    for task in ("simulate", "sdf", "render", "integrate", "blend"):
        assert f"Task srg.{task}[" in logs(), task
