"""The growth epoch as a sequence of small steps, shared by the eager and the Celery paths.

One epoch (docs/design.md, "Runtime") is:

1. :func:`plan_epoch` - under the graph's row lock: rank (STATERANK warm-started from
   the previous epoch's pi, stored as an artifact and named on the epoch row), pop the
   top BLEND edges relinking lazily, save the relinks, and write the plan (the ordered
   list of ``(edge, dead-end clip)``) on a new ``growth_epochs`` row;
2. per planned expansion and control: :func:`simulate_step`, :func:`sdf_step`,
   :func:`render_step` - each reads and writes artifacts only, and the last two record
   the clip on an ``expansion_clips`` row;
3. per planned expansion, in plan order: :func:`integrate_step` - the single writer of
   the expansion, idempotent (see its docstring);
4. :func:`blend_step` - render the new BLEND edges' animations.

``grow_graph`` (eager, :func:`run_epoch`) and the Celery tasks (on workers) call
exactly these functions, one transaction per step, and integration order is the plan's
in both, so one seed grows one graph either way.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from contextlib import nullcontext
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from sqlalchemy import select, update
from sqlalchemy.orm import Session

from app.config import Settings
from app.core.dynamics import ClipFeatures, Dynamics, SimClip
from app.core.graph import EdgeKind
from app.core.growth import integrate_expansion, relink_all, select_for_expansion
from app.core.refinement import Refiner
from app.core.strategies import EdgeWeights, Strategy, edge_weights
from app.db import Scope, begin_immediate
from app.models import Clip, Edge, ExpansionClip, Graph, GrowthEpoch
from app.render.animation import STRIP_MEDIA_TYPE, encode_strip
from app.services.dynamics import make_dynamics
from app.services.graph_cache import graph_cache
from app.services.graphs import LoadedGraph, artifact_store, refiner_for
from app.store._sql import insert_ignoring_duplicates
from app.store.epochs import EpochStatus, finish_epoch, start_epoch
from app.store.graphs import GraphNotFound, load_graph, save_graph, set_animations
from app.store.occupancy_cache import RedisShapeCache

CACHE_SCOPE = "growth"
log = logging.getLogger(__name__)


class ExpansionNotReady(RuntimeError):
    """An expansion cannot be integrated yet: clips missing, or an earlier one pending."""

    def __init__(self, message: str, *, missing: list[int], waiting_for: int | None) -> None:
        super().__init__(message)
        self.missing = missing
        self.waiting_for = waiting_for


@dataclass(frozen=True)
class EpochPlan:
    epoch_id: int
    graph_id: int
    #: (edge, dead-end clip) in integration order
    expansions: list[tuple[int, int]]
    relinks: int
    #: True when this re-sends a stalled epoch's missing work instead of a new plan
    resent: bool = False
    #: why the ranking fell back from STATERANK and to what (None: it did not)
    ranking_fallback: str | None = None


@dataclass(frozen=True)
class EpochWork:
    """What of an epoch is still to do: clips to simulate, expansions to integrate."""

    epoch_id: int
    missing_clips: list[tuple[int, int]]  # (position, control)
    pending: list[int]  # positions, in order


# ---- locking and loading ------------------------------------------------------------
def lock_graph(session: Session, graph_id: int) -> Graph:
    """The graph row, locked until the transaction ends.

    PostgreSQL: ``SELECT ... FOR UPDATE``. SQLite has no row locks: the transaction is
    begun IMMEDIATE (the database's write lock), which must happen before any statement
    of the transaction, so call this first.
    """
    begin_immediate(session)
    stmt = select(Graph).where(Graph.id == graph_id).execution_options(populate_existing=True)
    if session.get_bind().dialect.name != "sqlite":
        stmt = stmt.with_for_update()
    row = session.scalars(stmt).one_or_none()
    if row is None:
        raise GraphNotFound(f"no graph {graph_id!r}")
    return row


@lru_cache(maxsize=4)
def cached_dynamics(name: str, preset: str | None, fluid: str | None = None) -> Dynamics:
    """One dynamics per worker process: the liquid builds OpenCL programs once."""
    return make_dynamics(name, preset, fluid)


def graph_dynamics(row: Graph) -> Dynamics:
    """The dynamics a stored graph was grown with (its scene names preset and fluid)."""
    return cached_dynamics(row.dynamics, row.scene.get("preset"), row.scene.get("fluid"))


@lru_cache(maxsize=4)
def _shape_cache(url: str, ttl: int) -> RedisShapeCache:
    return RedisShapeCache.from_url(url, ttl)


def loaded_graph(session: Session, settings: Settings, row: Graph) -> LoadedGraph:
    """The graph at its current revision: the process's cached copy, or a fresh load.

    The caller owns the returned object until :func:`keep_graph`; on any failure it is
    simply not given back, and the next caller reloads.
    """
    cached = graph_cache.take(session, row.id, CACHE_SCOPE)
    if isinstance(cached, LoadedGraph):
        cached.row = row
        return cached
    artifacts = artifact_store(settings)
    graph, bank = load_graph(session, row.id, artifacts, settings.clip_cache_mb * 2**20)
    if settings.resolved_redis_url:
        cache = _shape_cache(settings.resolved_redis_url, settings.occupancy_cache_ttl)
        bank.use_shape_cache(cache)
    return LoadedGraph(row, graph, bank, graph_dynamics(row), artifacts)


def keep_graph(session: Session, loaded: LoadedGraph) -> None:
    graph_cache.put(session, loaded.row.id, CACHE_SCOPE, loaded)


def _canonical_descriptors(loaded: LoadedGraph, first_clip: int) -> None:
    """Round new clips' descriptors as the database stores them (float32).

    A reloaded graph has the stored values; the cached one must equal it, or the crowd
    model would differ between a worker that reloaded and one that did not.
    """
    graph = loaded.graph
    for clip in range(first_clip, graph.n_clips):
        stored = np.asarray(graph.clip_descriptor[clip], dtype=np.float32)
        graph.clip_descriptor[clip] = stored.astype(np.float64)


# ---- 1. plan ----------------------------------------------------------------------------
def running_epoch(session: Session, graph_id: int) -> GrowthEpoch | None:
    return session.scalars(
        select(GrowthEpoch)
        .where(GrowthEpoch.graph_id == graph_id, GrowthEpoch.status == EpochStatus.RUNNING)
        .order_by(GrowthEpoch.number)
    ).first()


def _warm_start(session: Session, loaded: LoadedGraph) -> np.ndarray | None:
    digest = session.scalar(
        select(GrowthEpoch.warm_start)
        .where(GrowthEpoch.graph_id == loaded.row.id, GrowthEpoch.warm_start.is_not(None))
        .order_by(GrowthEpoch.number.desc())
        .limit(1)
    )
    if digest is None:
        return None
    pi = loaded.artifacts.get_arrays(digest, ("pi",))["pi"]
    return pi if pi.size <= loaded.graph.n_vertices else None


def _rank(session: Session, loaded: LoadedGraph, refiner: Refiner) -> EdgeWeights:
    """Edge weights under the refiner's strategy, STATERANK warm-started from the last pi."""
    return edge_weights(
        refiner.strategy,
        loaded.graph,
        refiner.player_model(),
        restart=refiner.restart,
        warm_start=_warm_start(session, loaded),
        max_iter=refiner.config.staterank_max_iter,
    )


def plan_epoch(
    session: Session,
    settings: Settings,
    graph_id: int,
    *,
    count: int | None = None,
    strategy: Strategy | None = None,
    work_lost: bool = False,
) -> EpochPlan | None:
    """Open the graph's next epoch, or re-send a stalled one; None if one is running.

    A running epoch is returned again (``resent=True``) for its missing work to be
    dispatched once more when it has made no progress for ``settings.epoch_check_after``
    seconds and the caller found its work lost (``work_lost``: no worker or queue holds
    any of it), or for ``settings.epoch_resend_after`` seconds whatever the caller
    found. Two concurrent calls are serialised by the graph's row lock, and the unique
    (graph, number) of epochs is the backstop, so epochs of one graph never overlap.
    """
    row = lock_graph(session, graph_id)
    running = running_epoch(session, graph_id)
    if running is not None:
        quiet = time.time() - (running.heartbeat or 0.0)
        if quiet < (settings.epoch_check_after if work_lost else settings.epoch_resend_after):
            return None
        running.heartbeat = time.time()
        session.flush()
        plan = [(int(e), int(c)) for e, c in running.plan or []]
        return EpochPlan(running.id, graph_id, plan, running.relinks, resent=True)
    loaded = loaded_graph(session, settings, row)
    refiner = refiner_for(session, settings, loaded, strategy)
    ranked = _rank(session, loaded, refiner)
    outcome = select_for_expansion(
        loaded.graph, ranked.weights, count or refiner.config.batch_size, refiner.relink
    )
    if outcome.relinked:
        save_graph(session, graph_id, loaded.graph, loaded.bank, loaded.artifacts)
    epoch_id = start_epoch(session, graph_id, refiner.strategy.value)
    epoch = session.get_one(GrowthEpoch, epoch_id)
    expansions = [(e, loaded.graph.edge_clip[e]) for e in outcome.expanded]
    epoch.plan = [list(pair) for pair in expansions]
    epoch.relinks = len(outcome.relinked)
    epoch.heartbeat = time.time()
    if ranked.rank is not None:
        epoch.warm_start = loaded.artifacts.put_arrays({"pi": ranked.rank.pi}, session=session)
    if ranked.fallback is not None:
        log.warning("graph %d epoch %d: %s", graph_id, epoch.number, ranked.fallback)
    session.flush()
    if not expansions:
        size = loaded.graph.size_frames
        finish_epoch(session, epoch_id, expansions=0, relinks=epoch.relinks, size_frames=size)
    keep_graph(session, loaded)
    return EpochPlan(
        epoch_id, graph_id, expansions, len(outcome.relinked), ranking_fallback=ranked.fallback
    )


def epoch_work(session: Session, epoch_id: int) -> EpochWork:
    """The clips not yet stored and the expansions not yet integrated, of one epoch."""
    epoch = session.get_one(GrowthEpoch, epoch_id)
    row = session.get_one(Graph, epoch.graph_id)
    plan = epoch.plan or []
    stored = set(
        session.execute(
            select(ExpansionClip.position, ExpansionClip.control).where(
                ExpansionClip.epoch_id == epoch_id
            )
        ).all()
    )
    pending = [p for p in range(len(plan)) if not _integrated(session, row, plan[p])]
    missing = [(p, c) for p in pending for c in range(row.n_controls) if (p, c) not in stored]
    return EpochWork(epoch_id, missing, pending)


def _integrated(session: Session, row: Graph, planned: list[int]) -> bool:
    """Whether planned (edge, dead-end clip) has been swapped in: the edge is now SIM."""
    edge, _ = planned
    kind = session.scalar(
        select(Edge.kind).where(
            Edge.graph_id == row.id,
            Edge.vertex == edge // row.n_controls,
            Edge.control == edge % row.n_controls,
        )
    )
    return kind == EdgeKind.SIM


# ---- 2. per clip: simulate, sdf, render ---------------------------------------------------
def _planned(session: Session, epoch_id: int, position: int) -> tuple[GrowthEpoch, Graph, int]:
    epoch = session.get_one(GrowthEpoch, epoch_id)
    row = session.get_one(Graph, epoch.graph_id)
    plan = epoch.plan or []
    if not 0 <= position < len(plan):
        raise LookupError(f"epoch {epoch_id} plans no expansion {position}")
    return epoch, row, int(plan[position][1])


def _stored_clip(session: Session, epoch_id: int, position: int, control: int) -> str | None:
    found = session.get(ExpansionClip, (epoch_id, position, control))
    return None if found is None else found.clip


def _heartbeat(session: Session, epoch_id: int) -> None:
    session.execute(
        update(GrowthEpoch).where(GrowthEpoch.id == epoch_id).values(heartbeat=time.time())
    )


@dataclass(frozen=True)
class ClipJob:
    """What simulating one planned clip needs, read from the database beforehand."""

    dynamics: Dynamics
    state: np.ndarray
    control: int


def clip_job(
    session: Session, settings: Settings, epoch_id: int, position: int, control: int
) -> ClipJob | str:
    """The start state and dynamics of a planned clip, or its digest once recorded."""
    if (stored := _stored_clip(session, epoch_id, position, control)) is not None:
        return stored  # a redelivery after the clip was recorded
    _, row, dead_end = _planned(session, epoch_id, position)
    bundle = session.scalar(
        select(Clip.bundle).where(Clip.graph_id == row.id, Clip.idx == dead_end)
    )
    if bundle is None:
        raise LookupError(f"graph {row.id} has no clip {dead_end}")
    state = artifact_store(settings).get_arrays(bundle, ("end_state",))["end_state"]
    return ClipJob(graph_dynamics(row), state, control)


def simulate_job(job: ClipJob) -> dict[str, np.ndarray]:
    """The simulated stage of a clip, no database needed.

    Toy: the whole clip (frames and features). Liquid: PCISPH only, the particle
    positions of the k frames and the end state (the SDF is :func:`finish_clip`'s).
    """
    dynamics = job.dynamics
    if dynamics.name == "liquid":
        positions, end_state = dynamics.simulator.simulate_clip(job.state, job.control)  # type: ignore[attr-defined]
        return {
            "positions": positions,
            "end_state": end_state,
            "control": np.asarray(job.control, dtype=np.int64),
        }
    sim = dynamics.simulate(job.state, job.control)
    return clip_arrays(sim, dynamics.features(sim))


def finish_clip(dynamics: Dynamics, stage: dict[str, np.ndarray]) -> dict[str, np.ndarray] | None:
    """Liquid: the clip (Zhu-Bridson SDF frames and features) of a simulated stage.

    None when the stage already is the clip (the toy has no SDF stage).
    """
    if "positions" not in stage:
        return None
    frames = dynamics.surface_frames(stage["positions"])  # type: ignore[attr-defined]
    sim = SimClip(control=int(stage["control"]), frames=frames, end_state=stage["end_state"])
    return clip_arrays(sim, dynamics.features(sim))


def record_clip(session: Session, epoch_id: int, position: int, control: int, clip: str) -> None:
    """Note a planned clip's artifact on ``expansion_clips`` (once) and beat the heart."""
    insert_ignoring_duplicates(
        session,
        ExpansionClip,
        [{"epoch_id": epoch_id, "position": position, "control": control, "clip": clip}],
    )
    _heartbeat(session, epoch_id)


def simulate_step(
    session: Session, settings: Settings, epoch_id: int, position: int, control: int
) -> str:
    """Simulate one clip of a planned expansion; return its stage artifact's digest."""
    job = clip_job(session, settings, epoch_id, position, control)
    if isinstance(job, str):
        return job
    if settings.test_simulate_delay > 0:  # test-only: a window to kill the worker in
        time.sleep(settings.test_simulate_delay)
    return artifact_store(settings).put_arrays(simulate_job(job), session=session)


def sdf_step(
    session: Session,
    settings: Settings,
    stage: str,
    epoch_id: int,
    position: int,
    control: int,
) -> str:
    """Turn a simulated stage into a clip and record it; return the clip artifact."""
    stored = _stored_clip(session, epoch_id, position, control)
    if stored is not None:
        return stored
    _, row, _ = _planned(session, epoch_id, position)
    artifacts = artifact_store(settings)
    clip = finish_clip(graph_dynamics(row), artifacts.get_arrays(stage))
    digest = stage if clip is None else artifacts.put_arrays(clip, session=session)
    record_clip(session, epoch_id, position, control, digest)
    return digest


def render_step(
    session: Session, settings: Settings, clip: str, epoch_id: int, position: int, control: int
) -> str:
    """Render a recorded clip's animation strip (once); return the clip artifact."""
    found = session.get_one(ExpansionClip, (epoch_id, position, control))
    if found.animation is None:
        _, row, _ = _planned(session, epoch_id, position)
        artifacts = artifact_store(settings)
        dynamics = graph_dynamics(row)
        frames = artifacts.get_arrays(found.clip, ("frames",))["frames"]
        found.animation = artifacts.put_bytes(
            encode_strip(dynamics.render(frames)), media_type=STRIP_MEDIA_TYPE, session=session
        )
        session.flush()
    return clip


def clip_arrays(sim: SimClip, features: ClipFeatures) -> dict[str, np.ndarray]:
    """Everything :func:`integrate_step` needs of a clip, exactly (no float rounding)."""
    return {
        "control": np.asarray(sim.control, dtype=np.int64),
        "frames": np.asarray(sim.frames),
        "end_state": np.asarray(sim.end_state),
        "kinetic": np.asarray(features.kinetic, dtype=np.float64),
        "potential": np.asarray(features.potential, dtype=np.float64),
        "occupancy": np.asarray(features.occupancy),
        "descriptor": np.asarray(features.descriptor),
        "score": np.asarray(features.score, dtype=np.float64),
    }


def _clip_from_arrays(arrays: dict[str, np.ndarray]) -> tuple[SimClip, ClipFeatures]:
    control = int(arrays["control"])
    sim = SimClip(control=control, frames=arrays["frames"], end_state=arrays["end_state"])
    features = ClipFeatures(
        control=control,
        kinetic=float(arrays["kinetic"]),
        potential=arrays["potential"],
        occupancy=arrays["occupancy"],
        descriptor=arrays["descriptor"],
        score=float(arrays["score"]),
    )
    return sim, features


# ---- 3. integrate -------------------------------------------------------------------------
@dataclass(frozen=True)
class Integration:
    epoch_id: int
    position: int
    #: "integrated" now, or "done" (an earlier delivery did it: nothing changed)
    status: str
    vertex: int | None
    epoch_finished: bool


def integrate_step(
    session: Session, settings: Settings, epoch_id: int, position: int
) -> Integration:
    """Swap planned expansion ``position`` of the epoch into the graph, exactly once.

    Under the graph's row lock, in one transaction: the expansion is identified by
    (graph, edge, dead-end clip); if that edge is no longer that BLEND edge it was done
    before (a redelivery or a duplicate) and nothing changes. Otherwise the step checks
    completeness itself - every earlier expansion of the plan integrated, all N clips
    recorded - and raises :class:`ExpansionNotReady` if not. The last expansion of the
    plan also finishes the epoch.
    """
    begin_immediate(session)  # before the first statement: see lock_graph
    epoch = session.get(GrowthEpoch, epoch_id)
    if epoch is None:
        raise LookupError(f"no growth epoch {epoch_id}")
    row = lock_graph(session, epoch.graph_id)
    session.refresh(epoch)
    plan = [(int(e), int(c)) for e, c in epoch.plan or []]
    edge, dead_end = plan[position]
    loaded = loaded_graph(session, settings, row)
    graph = loaded.graph
    if not (graph.edge_kind[edge] == EdgeKind.BLEND and graph.edge_clip[edge] == dead_end):
        finished = _finish_if_complete(session, loaded, epoch, plan)
        keep_graph(session, loaded)
        vertex = graph.edge_dst[edge] if graph.edge_clip[edge] == dead_end else None
        return Integration(epoch_id, position, "done", vertex, finished)
    for earlier in range(position):
        e, d = plan[earlier]
        if graph.edge_kind[e] == EdgeKind.BLEND and graph.edge_clip[e] == d:
            keep_graph(session, loaded)
            raise ExpansionNotReady(
                f"epoch {epoch_id}: expansion {earlier} comes first",
                missing=[],
                waiting_for=earlier,
            )
    recorded = {
        r.control: r
        for r in session.scalars(
            select(ExpansionClip).where(
                ExpansionClip.epoch_id == epoch_id, ExpansionClip.position == position
            )
        )
    }
    missing = [c for c in range(graph.n_controls) if c not in recorded]
    if missing:
        keep_graph(session, loaded)
        raise ExpansionNotReady(
            f"epoch {epoch_id}: expansion {position} lacks clips {missing}",
            missing=missing,
            waiting_for=None,
        )
    clips = [
        _clip_from_arrays(loaded.artifacts.get_arrays(recorded[c].clip))
        for c in range(graph.n_controls)
    ]
    first_clip = graph.n_clips
    expansion = integrate_expansion(
        graph, loaded.bank, loaded.dynamics, edge, clips, prefilter_k=settings.prefilter_k
    )
    save_graph(session, row.id, graph, loaded.bank, loaded.artifacts)
    _canonical_descriptors(loaded, first_clip)
    animations: dict[int, str] = {}
    for control, clip in enumerate(expansion.clips):
        if (animation := recorded[control].animation) is not None:
            animations[clip] = animation
    set_animations(session, row.id, clips=animations)
    epoch.heartbeat = time.time()
    finished = _finish_if_complete(session, loaded, epoch, plan)
    keep_graph(session, loaded)
    return Integration(epoch_id, position, "integrated", expansion.vertex, finished)


def _finish_if_complete(
    session: Session, loaded: LoadedGraph, epoch: GrowthEpoch, plan: list[tuple[int, int]]
) -> bool:
    graph = loaded.graph
    if epoch.status != EpochStatus.RUNNING:
        return False
    if any(graph.edge_kind[e] == EdgeKind.BLEND and graph.edge_clip[e] == d for e, d in plan):
        return False
    finish_epoch(
        session,
        epoch.id,
        expansions=len(plan),
        relinks=epoch.relinks,
        size_frames=graph.size_frames,
    )
    return True


# ---- 4. blend animations ---------------------------------------------------------------------
def blend_step(session: Session, settings: Settings, epoch_id: int) -> int:
    """Render eq. 8's blend for the epoch's new BLEND edges still without an animation."""
    epoch = session.get_one(GrowthEpoch, epoch_id)
    row = session.get_one(Graph, epoch.graph_id)
    n = row.n_controls
    loaded = loaded_graph(session, settings, row)
    graph = loaded.graph
    vertices = [
        graph.edge_dst[e]
        for e, d in epoch.plan or []
        if graph.edge_kind[e] == EdgeKind.SIM and graph.edge_clip[e] == d
    ]
    wanted = {v * n + c for v in vertices for c in range(n)}
    unrendered = {
        vertex * n + control
        for vertex, control in session.execute(
            select(Edge.vertex, Edge.control).where(
                Edge.graph_id == row.id,
                Edge.vertex.in_(vertices),
                Edge.animation.is_(None),
                Edge.kind == int(EdgeKind.BLEND),
            )
        )
    }
    edges: dict[int, str] = {}
    for edge in sorted(wanted & unrendered):
        target_clip = graph.edge_clip[graph.edge_target[edge]]
        frames = loaded.dynamics.blend(
            loaded.bank.frames(graph.edge_clip[edge]), loaded.bank.frames(target_clip)
        )
        edges[edge] = loaded.artifacts.put_bytes(
            encode_strip(loaded.dynamics.render(frames)),
            media_type=STRIP_MEDIA_TYPE,
            session=session,
        )
    set_animations(session, row.id, edges=edges)
    keep_graph(session, loaded)
    return len(edges)


# ---- the whole epoch in-process ---------------------------------------------------------------
def in_session(session: Session) -> Scope:
    """A scope that runs every step in ``session``, in one transaction the caller owns."""
    return lambda: nullcontext(session)


def run_epoch(
    scope: Scope,
    settings: Settings,
    epoch_id: int,
    *,
    renders: bool,
    on_expansion: Callable[[Integration], None] | None = None,
) -> list[Integration]:
    """What is left of a planned epoch, step by step in plan order, one ``scope`` a step.

    With :func:`app.db.transaction` as the scope every step commits on its own, as on
    the workers: an interruption keeps what was done, and running the epoch again (it
    reads what is left from the database) finishes it with the same result.
    """
    with scope() as session:
        work = epoch_work(session, epoch_id)
        row = session.get_one(Graph, session.get_one(GrowthEpoch, epoch_id).graph_id)
        controls = range(row.n_controls)
    missing = set(work.missing_clips)
    done = []
    for position in work.pending:
        for control in controls:
            if (position, control) in missing:
                clip = _simulate_in_process(scope, settings, epoch_id, position, control)
                if renders:
                    with scope() as session:
                        render_step(session, settings, clip, epoch_id, position, control)
        with scope() as session:
            integration = integrate_step(session, settings, epoch_id, position)
        done.append(integration)
        if on_expansion is not None:
            on_expansion(integration)
    if renders:
        with scope() as session:
            blend_step(session, settings, epoch_id)
    return done


def _simulate_in_process(
    scope: Scope, settings: Settings, epoch_id: int, position: int, control: int
) -> str:
    """One clip: read, then compute outside any transaction, then record (SQLite's
    single writer is held only for the short record, so processes grow side by side)."""
    with scope() as session:
        job = clip_job(session, settings, epoch_id, position, control)
    if isinstance(job, str):
        return job
    stage = simulate_job(job)
    clip = finish_clip(job.dynamics, stage) or stage
    with scope() as session:
        digest = artifact_store(settings).put_arrays(clip, session=session)
        record_clip(session, epoch_id, position, control, digest)
    return digest


# ---- between epochs -----------------------------------------------------------------------
class EpochRunning(RuntimeError):
    """An epoch of the graph is running: wait for it before changing the graph."""


def _between_epochs(session: Session, graph_id: int) -> Graph:
    row = lock_graph(session, graph_id)
    if running_epoch(session, graph_id) is not None:
        raise EpochRunning(f"graph {graph_id} has an epoch running")
    return row


def rank_graph(session: Session, settings: Settings, graph_id: int) -> str | None:
    """STATERANK of the graph as it is, warm-started like an epoch's; the pi artifact.

    None for strategies that do not rank. The stored pi is what :func:`plan_epoch`
    computes too; this task exists to look at the ranking without growing.
    """
    row = session.get(Graph, graph_id)
    if row is None:
        raise GraphNotFound(f"no graph {graph_id!r}")
    loaded = loaded_graph(session, settings, row)
    ranked = _rank(session, loaded, refiner_for(session, settings, loaded))
    keep_graph(session, loaded)
    if ranked.rank is None:
        return None
    return loaded.artifacts.put_arrays({"pi": ranked.rank.pi}, session=session)


def relink_graph(session: Session, settings: Settings, graph_id: int) -> int:
    """Pre-publish relinking of every BLEND edge, between epochs; how many moved."""
    row = _between_epochs(session, graph_id)
    loaded = loaded_graph(session, settings, row)
    moved = relink_all(loaded.graph, loaded.bank, loaded.dynamics, prefilter_k=settings.prefilter_k)
    if moved:
        save_graph(session, graph_id, loaded.graph, loaded.bank, loaded.artifacts)
    keep_graph(session, loaded)
    return len(moved)


def publish_between_epochs(session: Session, settings: Settings, graph_id: int) -> int:
    """``publish_graph`` under the graph's lock, never in the middle of an epoch."""
    from app.services.graphs import publish_graph

    _between_epochs(session, graph_id)
    return publish_graph(session, settings, name=graph_id).publication_id


def set_growing(session: Session, name: str | int, growing: bool) -> dict[str, object]:
    """Mark a graph for (or take it off) beat's periodic growth."""
    from app.store.graphs import get_graph_row

    row = get_graph_row(session, name)
    row.growing = growing
    session.flush()
    return {"id": row.id, "name": row.name, "growing": row.growing}
