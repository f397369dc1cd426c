"""The paper's resolution grown on real workers: ``srg init --preset paper``'s initial tree,
then beat's tick plans an epoch that two workers simulate, render and integrate.

The slowest test of the suite (minutes: 43,824 particles), kept to one expansion.
"""

from __future__ import annotations

from collections.abc import Callable

import pytest
from tasks_cluster import Cluster, wait_for
from tasks_helpers import client, finished_epochs, snapshot

from app.db.engines import make_engine
from app.db.sessions import session_factory
from app.services.creation import init_graph
from app.services.rank_relink_publish import set_growing
from app.services.status import graph_summary

pytestmark = [pytest.mark.slow, pytest.mark.postgres, pytest.mark.redis]


def test_a_paper_graph_grows_on_two_workers_with_its_animations(
    cluster_env: Callable[..., Cluster],
) -> None:
    # beat only grows here (publish_every 0): a first publication would render the tree
    cluster = cluster_env(batch_size=1, growth_renders=True, publish_every=0)
    sessions = session_factory(make_engine(cluster.settings.resolved_database_url))
    with sessions() as session:
        made = init_graph(
            session, cluster.settings, name="paper", dynamics="liquid", preset="paper"
        )
        session.commit()
    graph_id = int(made["id"])  # type: ignore[call-overload]
    assert (made["preset"], made["size_frames"], made["sim_edges"]) == ("paper", 120, 3)
    assert made["unrendered_edges"] == 12  # the tree's 3 SIM and 9 BLEND edges
    cluster.start_worker("w1")
    cluster.start_worker("w2")
    app = client(cluster)
    with sessions() as session:
        set_growing(session, graph_id, True)
        session.commit()
    assert app.send_task("srg.schedule_growth").get(timeout=60) == {
        "grow": [graph_id],
        "publish": [],
    }
    wait_for(lambda: finished_epochs(cluster, graph_id) == 1, 1800, "the paper epoch", every=2)
    with cluster.session() as session:
        grown = graph_summary(session, graph_id)
        final = snapshot(session, cluster.settings, graph_id)  # checks the graph whole
    assert grown["size_frames"] == 150 and grown["sim_edges"] == 4
    assert len(final["vertex_control"]) == 1 + 3 + 1
    # the expanded edge's clip and the new vertex's 3 blends were rendered on the workers
    assert grown["unrendered_edges"] == 12 - 1
    logs = "".join(path.read_text(errors="replace") for path in cluster.logs.glob("*.log"))
    for task in ("simulate", "sdf", "render", "integrate", "blend"):
        assert f"Task srg.{task}[" in logs and "succeeded" in logs, task
