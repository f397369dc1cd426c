"""Clips together on a worker: with ``SRG_SIMULATE_BATCH`` a worker's ``srg.simulate`` runs
the epoch's other missing clips in its own launch sequence and records them, with the
bytes each clip has alone (docs/runtime.md, "Clips together on a worker")."""

from __future__ import annotations

import logging
from collections.abc import Callable
from pathlib import Path

import pytest
from sqlalchemy import select
from tasks_cluster import Cluster
from tasks_helpers import client, eager_reference, run_epoch, seed_graph, snapshot

from app.config import Settings, get_settings
from app.db.sessions import transaction
from app.liquid.adapter import LiquidDynamics
from app.models import Graph
from app.services import clips, epochs
from app.services.creation import init_graph
from app.services.loading import graph_dynamics
from app.services.scope import Scope
from app.store.epochs import expansion_clip, stored_clips
from app.store.graph_catalogue import graph_entry

#: expansions an epoch plans here: six clips of three controls
EXPANSIONS = 2
LIQUID = {"dynamics": "liquid", "preset": "tiny"}


def _planned_epoch(settings: Settings, name: str) -> int:
    with transaction(settings) as session:
        init_graph(session, settings, name=name, dynamics="liquid", preset="tiny")
    with transaction(settings) as session:
        graph_id = session.scalars(select(Graph.id).where(Graph.name == name)).one()
        plan = epochs.plan_epoch(Scope.of(session, settings), graph_id, count=EXPANSIONS)
    assert plan is not None and len(plan.expansions) == EXPANSIONS
    return plan.epoch_id


def _steps(settings: Settings, epoch_id: int) -> dict[tuple[int, int], str]:
    """Every clip's ``simulate`` and ``sdf`` steps, in the order of the epoch's canvas."""
    digests = {}
    for position in range(EXPANSIONS):
        for control in range(3):
            with transaction(settings) as session:
                stage = clips.simulate_step(
                    Scope.of(session, settings), epoch_id, position, control
                )
                digests[position, control] = clips.sdf_step(
                    Scope.of(session, settings), stage, epoch_id, position, control
                )
    return digests


def test_a_step_simulates_the_epochs_next_clips_with_its_own_to_the_same_bytes(
    settings: Settings, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    monkeypatch.setenv("SRG_REUSE_SIMULATIONS", "false")  # each graph simulates its clips
    alone = get_settings()
    alone_epoch = _planned_epoch(alone, "alone")
    with transaction(alone) as session:
        clips.simulate_step(Scope.of(session, alone), alone_epoch, 0, 0)
        assert stored_clips(session, alone_epoch) == set()  # the default: each clip alone

    monkeypatch.setenv("SRG_SIMULATE_BATCH", "5")
    together = get_settings()
    together_epoch = _planned_epoch(together, "together")
    with transaction(together) as session:
        dynamics = graph_dynamics(graph_entry(session, "together"), together)
    assert isinstance(dynamics, LiquidDynamics) and dynamics.batch == 5
    with (
        caplog.at_level(logging.INFO, logger="app.services.clips"),
        transaction(together) as session,
    ):
        stage = clips.simulate_step(Scope.of(session, together), together_epoch, 0, 1)
    assert "clip 0/1 simulated together with 4 more of the epoch" in caplog.text
    with transaction(together) as session:
        # its expansion's other clips first, then the next expansion's, in control order
        assert stored_clips(session, together_epoch) == {(0, 0), (0, 2), (1, 0), (1, 1)}
        # a companion's own step finds it done; the step's own clip is a stage to finish
        companion = expansion_clip(session, together_epoch, 0, 0)
        assert clips.simulate_step(Scope.of(session, together), together_epoch, 0, 0) == companion
        clips.sdf_step(Scope.of(session, together), stage, together_epoch, 0, 1)
        assert stored_clips(session, together_epoch) == {(0, 0), (0, 1), (0, 2), (1, 0), (1, 1)}

    assert _steps(together, together_epoch) == _steps(alone, alone_epoch)


def test_a_worker_with_a_batch_grows_the_graph_grown_in_process(
    cluster_env: Callable[..., Cluster], tmp_path: Path
) -> None:
    cluster = cluster_env(batch_size=EXPANSIONS, simulate_batch=3, reuse_simulations=False)
    graph_id = seed_graph(cluster.settings, **LIQUID)
    cluster.start_worker("w1", concurrency=1)
    run_epoch(cluster, client(cluster), graph_id, timeout=300)
    log = (cluster.logs / "w1.log").read_text(errors="replace")
    assert "simulated together with 2 more of the epoch" in log, log[-3000:]
    with cluster.session() as session:
        on_worker = snapshot(session, cluster.settings, graph_id)
    assert on_worker == eager_reference(tmp_path, 1, batch=EXPANSIONS, **LIQUID)
