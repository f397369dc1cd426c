"""The growth epoch as a sequence of small steps, shared by the eager and the Celery paths.

One epoch (docs/runtime.md) is:

1. :func:`plan_epoch` - under the graph's lock: rank (STATERANK warm-started from the
   previous epoch's pi, stored as an artifact and named on the epoch row), pop the top
   BLEND edges relinking lazily, save the relinks, and write the plan (the ordered list
   of ``(edge, dead-end clip)``) on a new ``growth_epochs`` row;
2. per planned expansion and control: the steps of :mod:`app.services.clips` (simulate,
   surface, render), which read and write artifacts only;
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
from contextlib import AbstractContextManager, nullcontext
from dataclasses import dataclass
from functools import partial

import numpy as np
from sqlalchemy.orm import Session

from app.config import Settings
from app.core.graph.graph_entry import GraphEntry
from app.core.graph.state_graph import EdgeKind, edge_index
from app.core.growth.expansion import integrate_expansion
from app.core.growth.kinds import Strategy
from app.db.sessions import Transactions
from app.services.animations import blend_strip
from app.services.clips import (
    ClipJob,
    clip_from_arrays,
    clip_job,
    finish_clip,
    record_finished,
    remembered_clip,
    render_step,
    simulate_jobs,
)
from app.services.loading import LoadedGraph, artifact_store, keep_graph, loaded_graph
from app.services.refining import rank_stored, refiner_for
from app.services.scope import Scope, step_scope
from app.store.animations import edges_without_animation, set_animations
from app.store.epochs import (
    Epoch,
    EpochStatus,
    expansion_clips,
    finish_epoch,
    get_epoch,
    record_clip,
    record_heartbeat,
    record_plan,
    running_epoch,
    running_epoch_ids,
    start_epoch,
    stored_clips,
)
from app.store.epochs import EpochTaken as EpochTaken  # a racing tick: nothing to do
from app.store.graph_catalogue import graph_entry, stored_edge_kind
from app.store.graph_persistence import StaleGraph as StaleGraph  # a racing writer: retry
from app.store.graph_persistence import save_graph
from app.store.locks import lock_epoch_graph, lock_graph

log = logging.getLogger(__name__)


class ExpansionNotReady(RuntimeError):
    """An expansion cannot be integrated yet: clips missing, or an earlier one pending.

    A signal between the steps, never the user's: the integrating task retries on it.
    """

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
    #: as the epoch was planned: what is sent again renders the same way
    renders: bool = True


@dataclass(frozen=True)
class Integration:
    epoch_id: int
    position: int
    #: "integrated" now, or "done" (an earlier delivery did it: nothing changed)
    status: str
    vertex: int | None
    epoch_finished: bool


# ---- 1. plan ----------------------------------------------------------------------------
def plan_epoch(
    scope: Scope,
    graph_id: int,
    *,
    count: int | None = None,
    strategy: Strategy | None = None,
    renders: bool = True,
) -> EpochPlan | None:
    """Open the graph's next epoch (rendering its clips if ``renders``), or re-send a
    stalled one; None if one is running.

    A running epoch that has made no progress for ``settings.runtime.epoch_resend_after``
    seconds is returned again (``resent=True``) for its missing work to be dispatched
    once more, whatever holds it: the backstop behind :func:`resend_epoch`, for a task
    that hangs. Two concurrent calls are serialised by the graph's lock, and the unique
    (graph, number) of epochs is the backstop, so epochs of one graph never overlap.
    """
    session, settings = scope.session, scope.settings
    entry = lock_graph(session, graph_id)
    running = running_epoch(session, graph_id)
    if running is not None:
        if time.time() - (running.heartbeat or 0.0) < settings.runtime.epoch_resend_after:
            return None
        return _resent(session, running)
    loaded = loaded_graph(session, settings, entry)
    refiner = refiner_for(session, settings, loaded, strategy)
    ranked = rank_stored(session, loaded, refiner)
    outcome = refiner.plan_epoch(count, ranked)
    if outcome.relinked:
        save_graph(session, graph_id, loaded.graph, loaded.bank, loaded.artifacts)
    epoch_id = start_epoch(session, graph_id, refiner.strategy.value, renders=renders)
    expansions = [(e, loaded.graph.edge_clip[e]) for e in outcome.expanded]
    warm_start = None
    if ranked.rank is not None:
        warm_start = loaded.artifacts.put_arrays({"pi": ranked.rank.pi}, session=session)
    epoch = record_plan(
        session,
        epoch_id,
        plan=expansions,
        relinks=len(outcome.relinked),
        warm_start=warm_start,
    )
    if ranked.fallback is not None:
        log.warning("graph %d epoch %d: %s", graph_id, epoch.number, ranked.fallback)
    if not expansions:
        size = loaded.graph.size_frames
        finish_epoch(session, epoch_id, expansions=0, relinks=epoch.relinks, size_frames=size)
    keep_graph(session, loaded)
    return EpochPlan(
        epoch_id, graph_id, expansions, len(outcome.relinked), ranking_fallback=ranked.fallback
    )


def resend_epoch(session: Session, epoch_id: int) -> EpochPlan | None:
    """The running epoch ``epoch_id`` again, its work found lost; None once it has ended.

    Under the graph's lock, as :func:`plan_epoch`: an epoch that ended meanwhile is left
    alone, and the caller, who only found lost work, never opens the graph's next one.
    """
    epoch, _row = lock_epoch_graph(session, epoch_id)
    if epoch.status != EpochStatus.RUNNING:
        return None
    return _resent(session, epoch)


def _resent(session: Session, epoch: Epoch) -> EpochPlan:
    record_heartbeat(session, epoch.id)  # the re-send is progress: the backstop waits again
    return EpochPlan(epoch.id, epoch.graph_id, list(epoch.plan), epoch.relinks, resent=True)


def running_work(session: Session) -> list[EpochWork]:
    """What is left of every graph's running epoch."""
    return [epoch_work(session, epoch_id) for epoch_id in running_epoch_ids(session)]


def epoch_work(session: Session, epoch_id: int) -> EpochWork:
    """The clips not yet stored and the expansions not yet integrated, of one epoch."""
    epoch = get_epoch(session, epoch_id)
    entry = graph_entry(session, epoch.graph_id)
    plan = epoch.plan
    stored = stored_clips(session, epoch_id)
    pending = [p for p in range(len(plan)) if not _integrated(session, entry, plan[p])]
    missing = [(p, c) for p in pending for c in range(entry.n_controls) if (p, c) not in stored]
    return EpochWork(epoch_id, missing, pending, epoch.renders)


def _integrated(session: Session, graph: GraphEntry, planned: tuple[int, int]) -> bool:
    """Whether planned (edge, dead-end clip) has been swapped in: the edge is now SIM."""
    edge, _ = planned
    return stored_edge_kind(session, graph, edge) == EdgeKind.SIM


# ---- 3. integrate -------------------------------------------------------------------------
def integrate_step(scope: Scope, epoch_id: int, position: int) -> Integration:
    """Swap planned expansion ``position`` of the epoch into the graph, exactly once.

    Under the graph's lock, in one transaction: the expansion is identified by (graph,
    edge, dead-end clip); if that edge is no longer that BLEND edge it was done before
    (a redelivery or a duplicate) and nothing changes. Otherwise the step checks
    completeness itself - every earlier expansion of the plan integrated, all N clips
    recorded - and raises :class:`ExpansionNotReady` if not. The last expansion of the
    plan also finishes the epoch.
    """
    session, settings = scope.session, scope.settings
    epoch, entry = lock_epoch_graph(session, epoch_id)
    plan = epoch.plan
    edge, dead_end = plan[position]
    loaded = loaded_graph(session, settings, entry)
    graph = loaded.graph
    if not (graph.edge_kind[edge] == EdgeKind.BLEND and graph.edge_clip[edge] == dead_end):
        finished = _finish_if_complete(session, loaded, epoch)
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
    recorded = expansion_clips(session, epoch_id, position)
    missing = [c for c in range(graph.n_controls) if c not in recorded]
    if missing:
        keep_graph(session, loaded)
        raise ExpansionNotReady(
            f"epoch {epoch_id}: expansion {position} lacks clips {missing}",
            missing=missing,
            waiting_for=None,
        )
    clips = [
        clip_from_arrays(loaded.artifacts.get_arrays(recorded[c])) for c in range(graph.n_controls)
    ]
    first_clip = graph.n_clips
    expansion = integrate_expansion(
        graph, loaded.bank, loaded.dynamics, edge, clips, prefilter_k=settings.growth.prefilter_k
    )
    save_graph(session, entry.id, graph, loaded.bank, loaded.artifacts)
    _canonical_descriptors(loaded, first_clip)
    record_heartbeat(session, epoch_id)
    finished = _finish_if_complete(session, loaded, epoch)
    keep_graph(session, loaded)
    return Integration(epoch_id, position, "integrated", expansion.vertex, finished)


def _canonical_descriptors(loaded: LoadedGraph, first_clip: int) -> None:
    """Round new clips' descriptors as the database stores them (float32).

    A reloaded graph has the stored values; the cached one must equal it, or the crowd
    model would differ between a worker that reloaded and one that did not.
    """
    graph = loaded.graph
    for clip in range(first_clip, graph.n_clips):
        stored = np.asarray(graph.clip_descriptor[clip], dtype=np.float32)
        graph.clip_descriptor[clip] = stored.astype(np.float64)


def _finish_if_complete(session: Session, loaded: LoadedGraph, epoch: Epoch) -> bool:
    graph = loaded.graph
    if epoch.status != EpochStatus.RUNNING:
        return False
    if any(graph.edge_kind[e] == EdgeKind.BLEND and graph.edge_clip[e] == d for e, d in epoch.plan):
        return False
    finish_epoch(
        session,
        epoch.id,
        expansions=len(epoch.plan),
        relinks=epoch.relinks,
        size_frames=graph.size_frames,
    )
    return True


# ---- 4. blend animations ---------------------------------------------------------------------
def blend_step(scope: Scope, epoch_id: int) -> int:
    """Render eq. 8's blend for the epoch's new BLEND edges still without an animation."""
    session, settings = scope.session, scope.settings
    epoch = get_epoch(session, epoch_id)
    entry = graph_entry(session, epoch.graph_id)
    n = entry.n_controls
    loaded = loaded_graph(session, settings, entry)
    graph = loaded.graph
    vertices = [
        graph.edge_dst[e]
        for e, d in epoch.plan
        if graph.edge_kind[e] == EdgeKind.SIM and graph.edge_clip[e] == d
    ]
    wanted = {edge_index(v, c, n) for v in vertices for c in range(n)}
    unrendered = set(
        edges_without_animation(session, entry.id, n, vertices=vertices, kind=EdgeKind.BLEND)
    )
    edges = {edge: blend_strip(session, loaded, edge) for edge in sorted(wanted & unrendered)}
    set_animations(session, entry.id, edges=edges)
    keep_graph(session, loaded)
    return len(edges)


# ---- the whole epoch in-process ---------------------------------------------------------------
def in_session(session: Session) -> Transactions:
    """A scope that runs every step in ``session``, in one transaction the caller owns."""
    return lambda: nullcontext(session)


def run_epoch(
    transactions: Transactions,
    settings: Settings,
    epoch_id: int,
    *,
    renders: bool,
    on_expansion: Callable[[Integration], None] | None = None,
) -> list[Integration]:
    """What is left of a planned epoch, step by step in plan order, one of
    ``transactions`` a step, every step in one scope with the settings and one artifact
    store.

    With :func:`app.db.sessions.transaction` every step commits on its own, as on the
    workers: an interruption keeps what was done, and running the epoch again (it reads
    what is left from the database) finishes it with the same result.
    """
    artifacts = artifact_store(settings)
    step = partial(step_scope, settings, artifacts, transactions)
    with step() as scope:
        work = epoch_work(scope.session, epoch_id)
        epoch = get_epoch(scope.session, epoch_id)
        controls = range(graph_entry(scope.session, epoch.graph_id).n_controls)
    missing = set(work.missing_clips)
    done = []
    for position in work.pending:
        todo = [control for control in controls if (position, control) in missing]
        for control, clip in _simulate_in_process(step, epoch_id, position, todo):
            if renders:
                with step() as scope:
                    render_step(scope, clip, epoch_id, position, control)
        with step() as scope:
            integration = integrate_step(scope, epoch_id, position)
        done.append(integration)
        if on_expansion is not None:
            on_expansion(integration)
    if renders:
        with step() as scope:
            blend_step(scope, epoch_id)
    return done


def _simulate_in_process(
    step: Callable[[], AbstractContextManager[Scope]],
    epoch_id: int,
    position: int,
    controls: list[int],
) -> list[tuple[int, str]]:
    """The clips of ``controls`` of one expansion, (control, digest) in that order: read,
    then compute together outside any transaction (one batch, docs/sph.md "Clips in
    batches"), then record each (SQLite's single writer is held only for the short
    records, so processes grow side by side)."""
    digests: dict[int, str] = {}
    jobs: dict[int, ClipJob] = {}
    with step() as scope:
        for control in controls:
            job = clip_job(scope, epoch_id, position, control)
            if isinstance(job, str):
                digests[control] = job
            elif (remembered := remembered_clip(scope, job)) is not None:
                record_clip(scope.session, epoch_id, position, control, remembered)
                digests[control] = remembered
            else:
                jobs[control] = job
    stages = simulate_jobs(list(jobs.values()))
    for (control, job), stage in zip(jobs.items(), stages, strict=True):
        clip = finish_clip(job.dynamics, stage) or stage
        with step() as scope:
            digests[control] = record_finished(scope, epoch_id, position, control, job, clip)
    return [(control, digests[control]) for control in controls]
