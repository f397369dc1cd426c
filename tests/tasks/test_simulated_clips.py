"""Each simulation once: a liquid clip already simulated from the same state and control
is reused, in process and through the workers' steps, with the same bytes."""

from __future__ import annotations

from functools import partial
from pathlib import Path

import numpy as np
import pytest
from sqlalchemy import func, select
from sqlalchemy.orm import Session

from app.config import Settings, get_settings
from app.core.graph.toy import ToyDynamics
from app.db.sessions import transaction
from app.kernels.pcisph import PcisphSolver
from app.liquid.adapter import LiquidDynamics
from app.models import Clip, Graph, SimulatedClip
from app.services import clips, epochs, growing
from app.services.clips import ClipJob, simulation_key
from app.services.creation import init_graph
from app.services.loading import graph_dynamics
from app.services.scope import Scope
from app.store.graph_catalogue import graph_entry
from app.store.simulated_clips import reuse_counts

#: expansions grown per graph: two expansions of three controls, six clips
EXPANSIONS = 2


def _new_graph(settings: Settings, name: str) -> None:
    with transaction(settings) as session:
        init_graph(session, settings, name=name, dynamics="liquid", preset="tiny")


def _grow(settings: Settings, name: str) -> int:
    """Grow ``name`` by :data:`EXPANSIONS`; return the PCISPH substeps it ran."""
    before = _substeps(settings, name)
    growing.grow_graph(partial(transaction, settings), settings, name=name, expansions=EXPANSIONS)
    return _substeps(settings, name) - before


def _substeps(settings: Settings, name: str) -> int:
    """Substeps run so far by this process's simulator of the graph's dynamics."""
    with transaction(get_settings()) as session:
        dynamics = graph_dynamics(graph_entry(session, name), settings)
    assert isinstance(dynamics, LiquidDynamics)
    assert isinstance(dynamics.solver, PcisphSolver)
    return dynamics.solver.stats.substeps


def _bundles(name: str) -> list[str]:
    with transaction(get_settings()) as session:
        graph = select(Graph.id).where(Graph.name == name).scalar_subquery()
        return list(
            session.scalars(select(Clip.bundle).where(Clip.graph_id == graph).order_by(Clip.idx))
        )


def _remembered() -> list[str]:
    with transaction(get_settings()) as session:
        return list(session.scalars(select(SimulatedClip.clip)))


def test_a_graph_grown_again_reuses_every_clip_and_with_reuse_off_simulates_the_same_bytes(
    settings: Settings, monkeypatch: pytest.MonkeyPatch
) -> None:
    _new_graph(settings, "first")
    assert _grow(settings, "first") > 0
    assert len(_remembered()) == EXPANSIONS * 3

    _new_graph(settings, "again")
    assert _grow(settings, "again") == 0
    assert _bundles("again") == _bundles("first")
    with transaction(get_settings()) as session:
        assert reuse_counts(session) == (2 * EXPANSIONS * 3, EXPANSIONS * 3)

    monkeypatch.setenv("SRG_REUSE_SIMULATIONS", "false")
    reuse_off = get_settings()
    assert not reuse_off.growth.reuse_simulations
    _new_graph(reuse_off, "simulated")
    assert _grow(reuse_off, "simulated") > 0
    assert _bundles("simulated") == _bundles("first")


def test_a_remembered_clip_that_was_collected_is_simulated_again(settings: Settings) -> None:
    _new_graph(settings, "first")
    _grow(settings, "first")
    store = Path(settings.resolved_artifact_dir)
    for digest in _remembered():
        (store / digest[:2] / digest[2:4] / digest).unlink()

    _new_graph(settings, "again")
    assert _grow(settings, "again") > 0
    assert _bundles("again") == _bundles("first")
    assert all((store / d[:2] / d[2:4] / d).exists() for d in _remembered())


def test_the_workers_steps_reuse_a_remembered_clip_and_record_it(settings: Settings) -> None:
    _new_graph(settings, "first")
    _grow(settings, "first")
    _new_graph(settings, "again")
    before = _substeps(settings, "again")
    with transaction(get_settings()) as session:
        graph_id = session.scalars(select(Graph.id).where(Graph.name == "again")).one()
        plan = epochs.plan_epoch(Scope.of(session, settings), graph_id)
    assert plan is not None
    with transaction(get_settings()) as session:
        stage = clips.simulate_step(Scope.of(session, settings), plan.epoch_id, 0, 1)
        assert stage in _remembered_in(session)
        assert clips.sdf_step(Scope.of(session, settings), stage, plan.epoch_id, 0, 1) == stage
    assert _substeps(settings, "again") == before


def _remembered_in(session: Session) -> set[str]:
    return set(session.scalars(select(SimulatedClip.clip)))


def test_the_key_tells_apart_what_changes_a_clip_and_leaves_out_the_toy() -> None:
    low = LiquidDynamics("tiny")
    state = np.zeros((4, 6), dtype=np.float32)
    key = simulation_key(ClipJob(low, state, 0))
    assert key is not None and len(key) == 64
    assert simulation_key(ClipJob(low, state.copy(), 0)) == key
    assert simulation_key(ClipJob(low, state, 1)) != key
    nudged = state.copy()
    nudged[3, 4] = np.nextafter(np.float32(0), np.float32(1))
    assert simulation_key(ClipJob(low, nudged, 0)) != key
    assert simulation_key(ClipJob(LiquidDynamics("tiny", "high"), state, 0)) != key
    assert simulation_key(ClipJob(ToyDynamics(), state, 0)) is None


def test_nothing_is_remembered_of_the_toy(settings: Settings) -> None:
    with transaction(settings) as session:
        init_graph(session, settings, name="toy")
    growing.grow_graph(partial(transaction, settings), settings, name="toy", expansions=EXPANSIONS)
    with transaction(get_settings()) as session:
        assert session.scalar(select(func.count()).select_from(SimulatedClip)) == 0
