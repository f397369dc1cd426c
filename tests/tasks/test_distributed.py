"""Growth on real workers, Redis and PostgreSQL equals the eager run, faults included."""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path

import pytest
from celery import Celery
from sqlalchemy import func, select
from tasks_cluster import Cluster, RedisServer, wait_for
from tasks_helpers import (
    assert_no_duplicates,
    client,
    eager_reference,
    finished_epochs,
    run_epoch,
    seed_graph,
    snapshot,
)

from app.core.graph.toy import ToyDynamics
from app.models import GrowthEpoch, Publication, PublicationEdge
from app.store.epochs import EpochStatus

pytestmark = [pytest.mark.slow, pytest.mark.postgres, pytest.mark.redis]
EPOCHS = 3
N_CONTROLS = ToyDynamics().n_controls


def _final(cluster: Cluster, graph_id: int) -> dict[str, list[object]]:
    assert_no_duplicates(cluster, graph_id)
    with cluster.session() as session:
        return snapshot(session, cluster.settings, graph_id)


def test_workers_grow_the_same_graph_as_the_eager_run(
    cluster_env: Callable[..., Cluster], tmp_path: Path
) -> None:
    cluster = cluster_env(batch_size=4)
    graph_id = seed_graph(cluster.settings)
    cluster.start_worker("w1")
    cluster.start_worker("w2")
    app = client(cluster)
    for _ in range(EPOCHS):
        run_epoch(cluster, app, graph_id)
    final = _final(cluster, graph_id)
    assert len(final["vertex_control"]) == 1 + 3 + EPOCHS * 4
    assert final == eager_reference(tmp_path, EPOCHS)


def _tick_until_finished(cluster: Cluster, app: Celery, graph_id: int, timeout: float) -> None:
    """Beat's ticks, one a second, until the graph's first epoch has finished.

    Each tick is waited for, so none piles up behind the epoch's own tasks to open a
    second epoch afterwards; the last one may still open it, so wait for that to end."""
    deadline = time.monotonic() + timeout
    while finished_epochs(cluster, graph_id) < 1 and time.monotonic() < deadline:
        app.send_task("srg.grow_epoch", args=[graph_id]).get(timeout=timeout)
        time.sleep(1)
    assert finished_epochs(cluster, graph_id) >= 1, cluster.log_text()
    wait_for(lambda: _running_epochs(cluster, graph_id) == 0, timeout, "the last tick's epoch")


def _running_epochs(cluster: Cluster, graph_id: int) -> int:
    with cluster.session() as session:
        return len(
            session.scalars(
                select(GrowthEpoch.id).where(
                    GrowthEpoch.graph_id == graph_id, GrowthEpoch.status == EpochStatus.RUNNING
                )
            ).all()
        )


def _wait_until_simulating(cluster: Cluster, worker: str) -> None:
    def simulating() -> bool:  # "Task srg.simulate[id] received" (the banner lists the name)
        log = (cluster.logs / f"{worker}.log").read_text(errors="replace")
        return "Task srg.simulate[" in log

    wait_for(simulating, 30, "a simulate task to start")
    time.sleep(0.3)


def _wait_until_ready(cluster: Cluster, *workers: str) -> None:
    def ready() -> bool:
        logs = [(cluster.logs / f"{w}.log").read_text(errors="replace") for w in workers]
        return all(" ready." in log for log in logs)

    wait_for(ready, 60, "the workers to be ready")


# SRG_EPOCH_RESEND_AFTER stays at its default (30 minutes) in these tests: what re-sends
# the lost work within seconds is the workers' watchdog (app.tasks.watchdog)
def test_worker_killed_mid_simulate_loses_no_expansion(
    cluster_env: Callable[..., Cluster], tmp_path: Path
) -> None:
    # simulate_delay (tests/tasks/slow_simulate.py, a hook of the test workers) keeps `simulate`
    # busy long enough
    cluster = cluster_env(batch_size=2, simulate_delay=0.5, epoch_check_interval=2)
    graph_id = seed_graph(cluster.settings)
    doomed = cluster.start_worker("doomed")
    app = client(cluster)
    app.send_task("srg.grow_epoch", args=[graph_id])
    _wait_until_simulating(cluster, "doomed")
    cluster.kill(doomed)  # SIGKILL to the worker and its pool: mid-simulate
    cluster.start_worker("survivor")
    _tick_until_finished(cluster, app, graph_id, timeout=90)
    run_epoch(cluster, app, graph_id, timeout=90)
    epochs = finished_epochs(cluster, graph_id)
    assert _final(cluster, graph_id) == eager_reference(tmp_path, epochs, batch=2)


def test_a_lost_worker_costs_under_a_minute_without_beat(
    cluster_env: Callable[..., Cluster], tmp_path: Path
) -> None:
    # default settings: what bounds the loss is the workers' own look at their epochs
    cluster = cluster_env(batch_size=2, simulate_delay=2.0)
    graph_id = seed_graph(cluster.settings)
    doomed = cluster.start_worker("doomed")
    cluster.start_worker("survivor")
    _wait_until_ready(cluster, "doomed", "survivor")
    app = client(cluster)
    app.send_task("srg.grow_epoch", args=[graph_id])  # once: no beat, no second tick
    _wait_until_simulating(cluster, "doomed")
    cluster.kill(doomed)  # the whole worker, pool included, while other clips wait
    killed = time.monotonic()
    wait_for(lambda: finished_epochs(cluster, graph_id) == 1, 60, "the epoch, re-sent")
    print(f"kill -> epoch finished: {time.monotonic() - killed:.1f} s")
    assert "no worker or queue holds its work" in (cluster.logs / "survivor.log").read_text()
    assert _running_epochs(cluster, graph_id) == 0
    assert _final(cluster, graph_id) == eager_reference(tmp_path, 1, batch=2)


def test_redis_restarted_mid_epoch_loses_no_expansion(
    cluster_env: Callable[..., Cluster], redis_server: RedisServer, tmp_path: Path
) -> None:
    cluster = cluster_env(batch_size=2, simulate_delay=0.5, epoch_check_interval=2)
    graph_id = seed_graph(cluster.settings)
    cluster.start_worker("w1")
    app = client(cluster)
    app.send_task("srg.grow_epoch", args=[graph_id])
    _wait_until_simulating(cluster, "w1")
    redis_server.stop()
    redis_server.start()  # same port, empty: the queued clips and the chord are gone
    app = client(cluster)
    _tick_until_finished(cluster, app, graph_id, timeout=90)
    epochs = finished_epochs(cluster, graph_id)
    assert _final(cluster, graph_id) == eager_reference(tmp_path, epochs, batch=2)


def test_a_slow_epoch_whose_work_is_queued_or_running_is_not_resent(
    cluster_env: Callable[..., Cluster], tmp_path: Path
) -> None:
    # each clip takes 2 s, one at a time: the watchdog looks a dozen times meanwhile
    cluster = cluster_env(batch_size=1, simulate_delay=2.0, epoch_check_interval=1)
    graph_id = seed_graph(cluster.settings)
    cluster.start_worker("w1")
    app = client(cluster)
    _tick_until_finished(cluster, app, graph_id, timeout=60)
    log = (cluster.logs / "w1.log").read_text(errors="replace")
    assert "no worker or queue holds its work" not in log
    first_epoch = log[: log.index("epoch finished")]
    simulated = first_epoch.count("Task srg.simulate[")  # "received", "succeeded" per clip
    assert simulated == 2 * N_CONTROLS, log
    epochs = finished_epochs(cluster, graph_id)
    assert _final(cluster, graph_id) == eager_reference(tmp_path, epochs, batch=1)


def test_redis_restarted_between_epochs(
    cluster_env: Callable[..., Cluster], redis_server: RedisServer, tmp_path: Path
) -> None:
    cluster = cluster_env(batch_size=4)
    graph_id = seed_graph(cluster.settings)
    cluster.start_worker("w1")
    app = client(cluster)
    run_epoch(cluster, app, graph_id)
    redis_server.stop()
    redis_server.start()  # same port, empty: nothing queued survives
    app = client(cluster)
    run_epoch(cluster, app, graph_id, timeout=90)
    run_epoch(cluster, app, graph_id)
    assert _final(cluster, graph_id) == eager_reference(tmp_path, 3)


def test_integrating_task_delivered_twice(
    cluster_env: Callable[..., Cluster], tmp_path: Path
) -> None:
    cluster = cluster_env(batch_size=4)
    graph_id = seed_graph(cluster.settings)
    cluster.start_worker("w1")
    cluster.start_worker("w2")
    app = client(cluster)
    app.send_task("srg.grow_epoch", args=[graph_id])

    def epoch_id() -> int | None:
        with cluster.session() as session:
            return session.scalar(select(GrowthEpoch.id).where(GrowthEpoch.graph_id == graph_id))

    wait_for(lambda: epoch_id() is not None, 30, "the epoch to be planned")
    for position in range(4):  # duplicates of every integrating step, racing the chain
        for _ in range(2):
            app.send_task("srg.integrate", args=[epoch_id(), position])
    wait_for(lambda: finished_epochs(cluster, graph_id) == 1, 60, "the epoch")
    duplicates = [app.send_task("srg.integrate", args=[epoch_id(), p]) for p in range(4)]
    vertices = [d.get(timeout=30) for d in duplicates]  # redelivered after the fact
    assert all(v is not None for v in vertices)
    assert _final(cluster, graph_id) == eager_reference(tmp_path, 1)


def test_two_beat_ticks_at_once_open_one_epoch(
    cluster_env: Callable[..., Cluster], tmp_path: Path
) -> None:
    cluster = cluster_env(batch_size=4, publish_every=0)  # ticks that only grow
    graph_id = seed_graph(cluster.settings)
    cluster.start_worker("w1", concurrency=2)
    cluster.start_worker("w2", concurrency=1)
    app = client(cluster)
    with cluster.session() as session:
        from app.services.rank_relink_publish import set_growing

        set_growing(session, graph_id, True)
        session.commit()
    ticks = [app.send_task("srg.schedule_growth") for _ in range(2)]
    for tick in ticks:
        tick.get(timeout=30)
    wait_for(lambda: finished_epochs(cluster, graph_id) >= 1, 60, "the epoch")
    time.sleep(2)  # a second epoch, had one been opened, would show by now
    with cluster.session() as session:
        numbers = list(
            session.scalars(select(GrowthEpoch.number).where(GrowthEpoch.graph_id == graph_id))
        )
    assert numbers == [1]
    assert _final(cluster, graph_id) == eager_reference(tmp_path, 1)


def test_beat_publishes_on_the_workers_what_they_grew(cluster_env: Callable[..., Cluster]) -> None:
    """Ticks on real workers: the graph published at once, grown, then published again
    once it has grown SRG_PUBLISH_EVERY frames, every edge with its animation."""
    cluster = cluster_env(batch_size=4, publish_every=120)
    graph_id = seed_graph(cluster.settings)
    cluster.start_worker("w1", concurrency=2)
    app = client(cluster)
    with cluster.session() as session:
        from app.services.rank_relink_publish import set_growing

        set_growing(session, graph_id, True)
        session.commit()

    def tick(expected: dict[str, list[int]]) -> None:
        assert app.send_task("srg.schedule_growth").get(timeout=30) == expected

    def published() -> list[tuple[int, int, int]]:
        """(number, frames, edges without animation) of each publication."""
        with cluster.session() as session:
            rows = session.execute(
                select(
                    Publication.number,
                    Publication.size_frames,
                    func.count().filter(PublicationEdge.animation.is_(None)),
                )
                .join(PublicationEdge)
                .where(Publication.graph_id == graph_id)
                .group_by(Publication.id)
                .order_by(Publication.number)
            )
            return [tuple(row) for row in rows]  # type: ignore[misc]

    tick({"grow": [], "publish": [graph_id]})
    wait_for(lambda: len(published()) == 1, 60, "the first publication")
    tick({"grow": [graph_id], "publish": []})
    wait_for(lambda: finished_epochs(cluster, graph_id) == 1, 60, "the epoch")
    tick({"grow": [], "publish": [graph_id]})
    wait_for(lambda: len(published()) == 2, 60, "the second publication")
    assert published() == [(1, 120, 0), (2, 240, 0)]
    tick({"grow": [graph_id], "publish": []})
