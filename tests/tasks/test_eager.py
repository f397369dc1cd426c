"""The tasks run eagerly (no broker): the embedded default, and the steps' guarantees."""

from __future__ import annotations

import logging
import os
import time
from dataclasses import replace
from functools import partial
from pathlib import Path

import numpy as np
import pytest
from sqlalchemy import func, select, update
from tasks_cluster import RedisServer
from tasks_helpers import eager_reference, seed_graph, snapshot

from app.config import Settings, get_settings
from app.core.graph.clipbank import MemoryClipBank
from app.core.graph.dynamics import Dynamics
from app.core.graph.state_graph import EdgeKind
from app.core.graph.toy import ToyDynamics
from app.core.growth.expansion import expand_blend_edge, initial_tree
from app.core.growth.refinement import RefinerConfig
from app.core.players.kinds import PlayerModelKind
from app.db.engines import make_engine
from app.db.sessions import database_sessions, session_factory, transaction
from app.models import Clip, Graph, GrowthEpoch, GrowthRequest, Publication, PublicationEdge
from app.services import clips, epochs, growing, rank_relink_publish, refining
from app.services.loading import open_graph
from app.services.scope import Scope
from app.store.animations import clip_animations, edges_without_animation
from app.store.artifacts import ArtifactStore
from app.store.epochs import start_epoch
from app.store.graph_catalogue import create_graph
from app.store.graph_persistence import load_graph, save_graph
from app.store.growth_requests import add_request, latest_request
from app.store.locks import lock_graph
from app.store.occupancy_cache import RedisShapeCache
from app.tasks import celery_app
from app.tasks.celery_app import celery_config
from app.tasks.growth import grow_epoch, integrate, publish_if_due, schedule_growth
from app.tasks.maintenance import collect_artifacts


def test_without_a_broker_tasks_run_eagerly() -> None:
    assert celery_app.conf.task_always_eager


def test_celery_is_configured_for_at_least_once_delivery() -> None:
    settings = Settings().replace(broker_url="redis://127.0.0.1:6379/0", task_time_limit=900)
    conf = celery_config(settings)
    assert conf["task_acks_late"] and conf["task_reject_on_worker_lost"]
    assert conf["worker_prefetch_multiplier"] == 1
    assert not conf["task_always_eager"]
    assert conf["task_soft_time_limit"] < conf["task_time_limit"]
    assert conf["broker_transport_options"]["visibility_timeout"] >= 2 * conf["task_time_limit"]


def test_grow_epoch_task_grows_what_grow_graph_grows(settings: Settings, tmp_path: Path) -> None:
    graph_id = seed_graph(settings)
    for _ in range(2):
        assert grow_epoch.delay(graph_id).get() is not None
    with database_sessions(get_settings())() as session:
        grown = snapshot(session, settings, graph_id)
    assert len(grown["vertex_control"]) == 4 + 8
    assert grown == eager_reference(tmp_path / "ref", 2)


def test_grow_epoch_tells_its_request_which_epoch_serves_it_or_why_none_does(
    settings: Settings,
) -> None:
    graph_id = seed_graph(settings)
    with transaction(get_settings()) as session:
        served, refused = (add_request(session, graph_id, 2, "workers") for _ in range(2))
        start_epoch(session, graph_id, "baseline")  # another epoch is running, not stalled
        session.execute(update(GrowthEpoch).values(heartbeat=time.time()))
    assert grow_epoch.delay(graph_id, 2, False, refused).get() is None
    with transaction(get_settings()) as session:
        view = latest_request(session, graph_id)
        assert view is not None and view.id == refused
        assert (view.state, view.reason) == ("failed", "an epoch of the graph was running")
        session.execute(update(GrowthEpoch).values(status="finished"))
    epoch_id = grow_epoch.delay(graph_id, 2, False, served).get()
    with transaction(get_settings()) as session:
        row = session.get_one(GrowthRequest, served)
        assert (row.state, row.epoch_id) == ("running", epoch_id)
        view = latest_request(session, graph_id)  # the request after the refused one: none
        assert view is not None and view.id == refused


def test_an_epoch_remembers_whether_it_renders_for_a_resend(settings: Settings) -> None:
    graph_id = seed_graph(settings)
    quiet = grow_epoch.delay(graph_id, 2, False).get()
    loud = grow_epoch.delay(graph_id, 2, True).get()
    with transaction(get_settings()) as session:
        assert session.get_one(GrowthEpoch, quiet).renders is False
        assert session.get_one(GrowthEpoch, loud).renders is True
        assert epochs.epoch_work(session, quiet).renders is False


def test_integrating_twice_changes_nothing(settings: Settings) -> None:
    graph_id = seed_graph(settings)
    epoch_id = grow_epoch.delay(graph_id).get()
    with database_sessions(get_settings())() as session:
        revision = session.get_one(Graph, graph_id).revision
        before = snapshot(session, settings, graph_id)
    vertices = [integrate.delay(epoch_id, p).get() for p in range(4)]
    assert vertices == [4, 5, 6, 7]
    with database_sessions(get_settings())() as session:
        assert session.get_one(Graph, graph_id).revision == revision
        assert snapshot(session, settings, graph_id) == before


def test_integration_waits_for_clips_and_for_plan_order(settings: Settings) -> None:
    graph_id = seed_graph(settings)
    with database_sessions(get_settings())() as session:
        plan = epochs.plan_epoch(Scope.of(session, settings), graph_id)
        session.commit()
    assert plan is not None and len(plan.expansions) == 4
    with (
        database_sessions(get_settings())() as session,
        pytest.raises(epochs.ExpansionNotReady) as missing,
    ):
        epochs.integrate_step(Scope.of(session, settings), plan.epoch_id, 0)
    assert missing.value.missing == [0, 1, 2]
    with database_sessions(get_settings())() as session:
        for control in range(3):
            stage = clips.simulate_step(Scope.of(session, settings), plan.epoch_id, 1, control)
            clips.sdf_step(Scope.of(session, settings), stage, plan.epoch_id, 1, control)
        session.commit()
    with (
        database_sessions(get_settings())() as session,
        pytest.raises(epochs.ExpansionNotReady) as early,
    ):
        epochs.integrate_step(Scope.of(session, settings), plan.epoch_id, 1)
    assert early.value.waiting_for == 0


def test_a_running_epoch_blocks_a_second_until_it_stalls(settings: Settings) -> None:
    graph_id = seed_graph(settings)
    with database_sessions(get_settings())() as session:
        first = epochs.plan_epoch(Scope.of(session, settings), graph_id)
        session.commit()
    assert first is not None
    with database_sessions(get_settings())() as session:
        assert epochs.plan_epoch(Scope.of(session, settings), graph_id) is None
    stalled = settings.replace(epoch_resend_after=1e-6)
    with database_sessions(get_settings())() as session:
        again = epochs.plan_epoch(Scope.of(session, stalled), graph_id)
        session.commit()
        assert again is not None and again.resent and again.epoch_id == first.epoch_id
        work = epochs.epoch_work(session, first.epoch_id)
    assert work.pending == [0, 1, 2, 3] and len(work.missing_clips) == 12
    with database_sessions(get_settings())() as session:
        numbers = session.scalars(select(GrowthEpoch.number)).all()
    assert numbers == [1]


def test_growth_goes_on_when_staterank_fails_and_says_so(
    settings: Settings, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    """STATERANK forced to miss convergence: every epoch still grows, on the fallback."""
    graph_id = seed_graph(settings)
    configured = refining.refiner_config

    def one_iteration(
        settings: Settings, dynamics: Dynamics, model: PlayerModelKind = PlayerModelKind.EQ2
    ) -> RefinerConfig:
        return replace(configured(settings, dynamics, model), staterank_max_iter=1)

    monkeypatch.setattr(refining, "refiner_config", one_iteration)
    with caplog.at_level(logging.WARNING, logger="app.services.epochs"):
        result = growing.grow_graph(
            partial(transaction, settings), settings, name=graph_id, expansions=8
        )
    assert (result.epochs, result.expansions) == (2, 8)
    assert len(result.ranking_fallbacks) == 2
    assert all("did not converge in 1 iterations" in f for f in result.ranking_fallbacks)
    assert result.ranking_fallbacks[0].startswith(f"epoch {result.epoch_ids[0]}: ")
    warnings = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]
    assert len(warnings) == 2 and all("baseline ordering" in w for w in warnings)
    # the workers' path plans its epochs the same way
    assert grow_epoch.delay(graph_id).get() is not None
    with database_sessions(get_settings())() as session:
        statuses = session.scalars(select(GrowthEpoch.status)).all()
    assert statuses == ["finished"] * 3


def test_a_loaded_graph_orders_equal_energies_like_the_grown_one(
    tmp_path: Path, settings: Settings
) -> None:
    dynamics, bank = ToyDynamics(), MemoryClipBank()
    graph = initial_tree(dynamics, bank)
    for _ in range(12):
        expand_blend_edge(graph, bank, dynamics, int(graph.blend_edges()[-1]))
    artifacts = ArtifactStore(tmp_path / "a")
    with database_sessions(get_settings())() as session:
        graph_id = create_graph(
            session, name="ties", dynamics="toy", n_controls=3, frames_per_clip=10
        )
        save_graph(session, graph_id, graph, bank, artifacts)
        loaded, _ = load_graph(session, graph_id, artifacts, dynamics.shape)
    assert loaded._sim_edges == graph._sim_edges


def test_occupancy_reads_go_through_redis(tmp_path: Path, redis_server_url: str) -> None:
    cache = RedisShapeCache.from_url(redis_server_url, ttl=60)
    occupancy, descriptor = np.arange(6, dtype=np.uint8), np.ones(3)
    assert cache.get("abc") is None
    cache.put("abc", occupancy, descriptor)
    hit = cache.get("abc")
    assert hit is not None
    np.testing.assert_array_equal(hit[0], occupancy)
    np.testing.assert_array_equal(hit[1], descriptor)
    assert (cache.hits, cache.misses) == (1, 1)


def test_redis_down_is_a_cache_miss() -> None:
    cache = RedisShapeCache.from_url("redis://127.0.0.1:1/0", ttl=60)
    cache.put("abc", np.zeros(2), np.zeros(2))
    assert cache.get("abc") is None


@pytest.fixture
def redis_server_url(redis_server: RedisServer) -> str:
    return redis_server.url


def test_beat_collects_orphaned_artifacts_unless_told_not_to() -> None:
    conf = celery_config(Settings().replace(artifact_gc_interval=600))
    entry = conf["beat_schedule"]["collect-artifacts"]
    assert entry == {"task": "srg.collect_artifacts", "schedule": 600}
    assert "srg.collect_artifacts" in celery_app.tasks
    never = celery_config(Settings().replace(artifact_gc_interval=0))["beat_schedule"]
    assert set(never) == {"grow-graphs"}


def test_the_collect_artifacts_task_removes_old_orphans_only(settings: Settings) -> None:
    graph_id = seed_graph(settings)
    store = ArtifactStore(settings.resolved_artifact_dir)
    kept = {path for path in store.root.rglob("*") if path.is_file()}
    old = time.time() - settings.runtime.artifact_gc_grace - 60
    for path in kept:
        os.utime(path, (old, old))
    orphan = store.root / "00" / "00" / ("0" * 64)
    orphan.parent.mkdir(parents=True, exist_ok=True)
    orphan.write_bytes(b"left by a killed worker")
    os.utime(orphan, (old, old))
    freed = collect_artifacts.delay().get()
    assert (freed["rows"], freed["files"]) == (0, 1) and not orphan.exists()
    assert {path for path in store.root.rglob("*") if path.is_file()} == kept
    with database_sessions(get_settings())() as session:
        load_graph(
            session, graph_id, store, ToyDynamics().shape
        )  # every bundle it uses is still there


def test_an_epoch_renders_the_strips_its_expansions_show(settings: Settings) -> None:
    """The dead-end clip of each expansion gets its strip, new blend edges their blends;
    the new clips, which end on blend edges and show in no edge yet, get none."""
    graph_id = seed_graph(settings)
    with database_sessions(get_settings())() as session:
        clips_before = session.scalar(select(func.count()).select_from(Clip))
    result = growing.grow_graph(
        partial(transaction, settings), settings, name=graph_id, expansions=4, renders=True
    )
    assert result.expansions == 4
    with database_sessions(get_settings())() as session:
        plan = session.scalars(select(GrowthEpoch.plan)).one()
        strips = clip_animations(session, graph_id)
        loaded = open_graph(session, settings, graph_id)
        unrendered_blends = edges_without_animation(session, graph_id, 3, kind=EdgeKind.BLEND)
    graph = loaded.graph
    assert {int(dead_end) for _, dead_end in plan} <= set(strips)
    assert not set(range(int(clips_before or 0), graph.n_clips)) & set(strips)
    new_vertices = {graph.edge_dst[int(edge)] for edge, _ in plan}
    new_blends = {v * 3 + c for v in new_vertices for c in range(3)}
    assert new_blends and not new_blends & set(unrendered_blends)


def _publications(graph_id: int) -> list[tuple[int, int]]:
    """The graph's publications as (number, size in frames), oldest first."""
    with database_sessions(get_settings())() as session:
        return [
            (row.number, row.size_frames)
            for row in session.scalars(
                select(Publication)
                .where(Publication.graph_id == graph_id)
                .order_by(Publication.number)
            )
        ]


def test_beat_publishes_a_growing_graph_when_due_and_grows_it_otherwise(
    settings: Settings, monkeypatch: pytest.MonkeyPatch
) -> None:
    """At once when it has no publication, then after SRG_PUBLISH_EVERY frames grown,
    each time instead of that tick's epoch; renders what the publication misses."""
    monkeypatch.setenv("SRG_PUBLISH_EVERY", "240")  # two epochs of 4 toy expansions
    graph_id = seed_graph(settings)
    idle = seed_graph(settings, "not-growing")
    with transaction(get_settings()) as session:
        rank_relink_publish.set_growing(session, graph_id, True)
    ticks = [schedule_growth.delay().get() for _ in range(5)]
    assert ticks == [
        {"grow": [], "publish": [graph_id]},
        {"grow": [graph_id], "publish": []},
        {"grow": [graph_id], "publish": []},
        {"grow": [], "publish": [graph_id]},
        {"grow": [graph_id], "publish": []},
    ]
    assert _publications(graph_id) == [(1, 120), (2, 360)]
    assert _publications(idle) == []
    with database_sessions(get_settings())() as session:
        latest = session.scalars(select(Publication.id).order_by(Publication.id.desc())).first()
        assert latest is not None
        unanimated = session.scalar(
            select(func.count())
            .select_from(PublicationEdge)
            .where(PublicationEdge.publication_id == latest, PublicationEdge.animation.is_(None))
        )
    assert unanimated == 0  # growth rendered nothing here (SRG_GROWTH_RENDERS=false)


def test_beat_never_publishes_with_publish_every_0_nor_while_an_epoch_runs(
    settings: Settings, monkeypatch: pytest.MonkeyPatch
) -> None:
    graph_id = seed_graph(settings)
    with transaction(get_settings()) as session:
        rank_relink_publish.set_growing(session, graph_id, True)
        start_epoch(session, graph_id, "baseline")  # running: the tick leaves it to grow_epoch
        session.execute(update(GrowthEpoch).values(heartbeat=time.time()))
    assert schedule_growth.delay().get() == {"grow": [graph_id], "publish": []}
    assert publish_if_due.delay(graph_id).get() is None
    with transaction(get_settings()) as session:
        session.execute(update(GrowthEpoch).values(status="finished"))
    monkeypatch.setenv("SRG_PUBLISH_EVERY", "0")
    assert schedule_growth.delay().get()["publish"] == []
    assert _publications(graph_id) == []


@pytest.mark.postgres
def test_a_publication_due_skips_a_graph_another_writer_holds(
    postgres_url: str, tmp_path: Path
) -> None:
    """A tick sent while a publication still renders returns at once instead of waiting
    for the lock, and publishes nothing."""
    settings = Settings().replace(database_url=postgres_url, var_dir=tmp_path, growth_renders=False)
    graph_id = seed_graph(settings)
    factory = session_factory(make_engine(postgres_url))
    with factory() as holder, factory() as session:
        lock_graph(holder, graph_id)
        started = time.monotonic()
        assert rank_relink_publish.publish_if_due(Scope.of(session, settings), graph_id) is None
        assert time.monotonic() - started < 5
        session.rollback()
        holder.rollback()
        assert rank_relink_publish.publish_if_due(Scope.of(session, settings), graph_id) is not None
