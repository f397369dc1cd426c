"""Shared steps of the runtime tests: seed a graph, grow the eager reference, compare."""

from __future__ import annotations

from pathlib import Path

from celery import Celery
from database_helpers import migrate
from sqlalchemy import func, select
from sqlalchemy.orm import Session
from tasks_cluster import Cluster, wait_for

from app.config import Settings
from app.db.engines import make_engine
from app.db.sessions import session_factory
from app.models import Clip, Edge, GrowthEpoch, Vertex
from app.services.creation import init_graph
from app.services.epochs import in_session
from app.services.graph_cache import graph_cache
from app.services.growing import grow_graph
from app.services.loading import open_graph
from app.store.epochs import EpochStatus
from app.tasks.celery_app import make_celery

STRATEGY = "sr-heuristic"
BATCH = 4


def seed_graph(settings: Settings, name: str = "g", **graph: str) -> int:
    """A new graph (the toy unless ``graph`` names another dynamics); its id."""
    with session_factory(make_engine(settings.resolved_database_url))() as session:
        summary = init_graph(session, settings, name=name, strategy=STRATEGY, **graph)
        session.commit()
    return int(summary["id"])  # type: ignore[call-overload]


def snapshot(session: Session, settings: Settings, graph_id: int) -> dict[str, list[object]]:
    """Vertices, clips, edges and errors of the stored graph (checked complete)."""
    graph_cache.clear()
    loaded = open_graph(session, settings, graph_id)
    graph = loaded.graph
    graph.check()
    return {
        "vertex_control": list(graph.vertex_control),
        "vertex_clip": list(graph.vertex_clip),
        "clip_source": list(graph.clip_source),
        "clip_control": list(graph.clip_control),
        "edge_kind": [int(k) for k in graph.edge_kind],
        "edge_clip": list(graph.edge_clip),
        "edge_dst": list(graph.edge_dst),
        "edge_target": list(graph.edge_target),
        "edge_err": [float(e) for e in graph.edge_err],
    }


def eager_reference(
    tmp_path: Path, epochs: int, batch: int = BATCH, **graph: str
) -> dict[str, list[object]]:
    """The same seed grown in-process on SQLite: what every distributed run must equal."""
    url = f"sqlite:///{tmp_path / 'eager.sqlite3'}"
    if not (tmp_path / "eager.sqlite3").exists():
        migrate(url)
    settings = Settings().replace(
        database_url=url,
        var_dir=tmp_path / "eager-var",
        artifact_dir=tmp_path / "eager-artifacts",
        growth_renders=False,
        batch_size=batch,
    )
    graph_id = seed_graph(settings, "eager", **graph)
    with session_factory(make_engine(url))() as session:
        grow_graph(in_session(session), settings, name=graph_id, expansions=epochs * batch)
        session.commit()
        return snapshot(session, settings, graph_id)


def client(cluster: Cluster) -> Celery:
    return make_celery(cluster.settings)


def finished_epochs(cluster: Cluster, graph_id: int) -> int:
    with cluster.session() as session:
        return int(
            session.scalar(
                select(func.count()).where(
                    GrowthEpoch.graph_id == graph_id,
                    GrowthEpoch.status == EpochStatus.FINISHED,
                )
            )
            or 0
        )


def run_epoch(cluster: Cluster, app: Celery, graph_id: int, timeout: float = 60) -> None:
    """Send one grow_epoch (as beat does) and wait until that epoch has finished."""
    before = finished_epochs(cluster, graph_id)
    app.send_task("srg.grow_epoch", args=[graph_id])
    try:
        wait_for(lambda: finished_epochs(cluster, graph_id) > before, timeout, "the epoch")
    except AssertionError:
        print(cluster.log_text())
        raise


def assert_no_duplicates(cluster: Cluster, graph_id: int) -> None:
    """Row counts match the graph's own sizes: one vertex row per vertex, etc."""
    with cluster.session() as session:
        vertices = session.scalar(select(func.count()).where(Vertex.graph_id == graph_id))
        edges = session.scalar(select(func.count()).where(Edge.graph_id == graph_id))
        clips = session.scalar(select(func.count()).where(Clip.graph_id == graph_id))
        expanded = session.scalar(
            select(func.coalesce(func.sum(GrowthEpoch.expansions), 0)).where(
                GrowthEpoch.graph_id == graph_id
            )
        )
    n = 3
    # the depth-2 tree has 1 + N vertices and N + N^2 clips; an expansion adds 1 and N
    assert vertices == 1 + n + expanded
    assert edges == n * vertices
    assert clips == n + n * n + n * expanded
