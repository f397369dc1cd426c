"""The growth tasks: thin wrappers of :mod:`app.services.epochs` and its steps, ids in
and ids out.

Each task opens one session (its base task's unit of work, :class:`SrgTask`), runs one
step, commits. Arrays never travel through Redis:
a step writes them to the artifact store and returns the digest. The epoch's canvas is
flat (:func:`epoch_canvas`)::

    chord([simulate | sdf | render   for every (expansion, control)],
          integrate(0) | integrate(1) | ... | integrate(n-1) | blend)

The integrating steps form a chain so that they run in the plan's order, the order the
eager path integrates in (blend targets depend on it). Nothing relies on the chord to
be safe: ``integrate`` re-checks completeness itself and is idempotent, and work lost
on the way (a killed worker, a restarted Redis) is found by the workers' watchdog
(:mod:`app.tasks.watchdog`) and re-sent through :func:`epoch_canvas` too.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import asdict

from celery import chain, chord, group
from celery.canvas import Signature
from celery.utils.log import get_task_logger
from sqlalchemy.exc import OperationalError

from app.config import Settings, get_settings
from app.core.growth.expansion import GrowthBudget
from app.db.sessions import transaction
from app.services import clips, epochs, rank_relink_publish
from app.services.catalogue import find_graph, size_frames
from app.services.growth_tracking import (
    end_request,
    failure_reason,
    running_epoch_state,
    start_request,
)
from app.tasks.celery_app import SrgTask, celery_app

log = get_task_logger(__name__)

#: seconds an integrating step waits before checking again for clips or an earlier step
NOT_READY_DELAY = 2.0


@celery_app.task(name="srg.simulate", bind=True)
def simulate(self: SrgTask, epoch_id: int, position: int, control: int) -> str:
    """Simulate one clip of a planned expansion; the stage artifact's digest.

    Toy: the whole clip. Liquid: PCISPH only (particle positions and end state).
    """
    with self.scope() as scope:
        return clips.simulate_step(scope, epoch_id, position, control)


@celery_app.task(name="srg.sdf", bind=True)
def sdf(self: SrgTask, stage: str, epoch_id: int, position: int, control: int) -> str:
    """Liquid: SDF frames and features of the simulated particles. Toy: pass-through.

    Records the clip on ``expansion_clips``; returns the clip artifact's digest.
    """
    with self.scope() as scope:
        return clips.sdf_step(scope, stage, epoch_id, position, control)


@celery_app.task(name="srg.render", bind=True)
def render(self: SrgTask, clip: str, epoch_id: int, position: int, control: int) -> str:
    """Render the clip's animation strip (stored, attached at integration)."""
    with self.scope() as scope:
        return clips.render_step(scope, clip, epoch_id, position, control)


@celery_app.task(name="srg.integrate", bind=True)
def integrate(
    self: SrgTask, epoch_id: int, position: int, renders: bool | None = None
) -> int | None:
    """Swap one planned expansion into the graph (once); the new vertex's index."""
    settings = self.settings
    renders = settings.render.growth_renders if renders is None else renders
    try:
        with self.scope() as scope:
            outcome = epochs.integrate_step(scope, epoch_id, position)
    except epochs.ExpansionNotReady as exc:
        if exc.missing:
            missing = [(position, c) for c in exc.missing]
            clip_pipelines(epoch_id, missing, renders=renders).apply_async()
        raise self.retry(
            exc=exc, countdown=NOT_READY_DELAY, max_retries=settings.runtime.task_max_retries
        ) from exc
    except (epochs.StaleGraph, OperationalError) as exc:  # a racing writer, a dropped connection
        raise self.retry(
            exc=exc, countdown=0.5, max_retries=settings.runtime.task_max_retries
        ) from exc
    log.info(
        "epoch %d: expansion %d %s (vertex %s)%s",
        epoch_id,
        position + 1,
        outcome.status,
        outcome.vertex,
        ", epoch finished" if outcome.epoch_finished else "",
    )
    return outcome.vertex


@celery_app.task(name="srg.blend", bind=True)
def blend(self: SrgTask, epoch_id: int) -> int:
    """Render eq. 8's blend of the epoch's new BLEND edges; how many were rendered."""
    with self.scope() as scope:
        return epochs.blend_step(scope, epoch_id)


@celery_app.task(name="srg.rank", bind=True)
def rank(self: SrgTask, graph_id: int) -> str | None:
    """STATERANK of the graph now (warm-started), stored: the ``pi`` artifact's digest."""
    with self.scope() as scope:
        return rank_relink_publish.rank_graph(scope, graph_id)


@celery_app.task(name="srg.relink", bind=True)
def relink(self: SrgTask, graph_id: int) -> int:
    """Relink every BLEND edge to its best target now (between epochs); how many moved."""
    try:
        with self.scope() as scope:
            return rank_relink_publish.relink_graph(scope, graph_id)
    except rank_relink_publish.EpochRunning as exc:
        raise self.retry(exc=exc, countdown=self.settings.runtime.beat_interval) from exc


@celery_app.task(name="srg.publish", bind=True)
def publish(self: SrgTask, graph_id: int) -> int:
    """Pre-publish relinking, missing animations, a frozen publication; its id."""
    try:
        with self.scope() as scope:
            return rank_relink_publish.publish_between_epochs(scope, graph_id)
    except rank_relink_publish.EpochRunning as exc:
        raise self.retry(exc=exc, countdown=self.settings.runtime.beat_interval) from exc


@celery_app.task(name="srg.grow_epoch", bind=True)
def grow_epoch(
    self: SrgTask,
    graph_id: int,
    count: int | None = None,
    renders: bool | None = None,
    request: int | None = None,
) -> int | None:
    """Plan the graph's next epoch (or re-send a long-stalled one) and dispatch its canvas.

    ``count`` blend edges are expanded (default ``SRG_BATCH_SIZE``); ``renders`` says
    whether to render animations (default ``SRG_GROWTH_RENDERS``); ``request`` is the
    admin route's growth request, told which epoch serves it or why none does. Returns
    the epoch id, or None when an epoch of the graph is already running.
    """
    try:
        epoch_id = _plan_and_send(self, graph_id, count, renders)
    except Exception as exc:
        if request is not None:
            with self.scope() as scope:
                end_request(scope.session, request, failure=failure_reason(exc))
        raise
    if request is not None:
        with self.scope() as scope:
            if epoch_id is None:
                end_request(scope.session, request, failure="an epoch of the graph was running")
            else:
                start_request(scope.session, request, epoch_id)
    return epoch_id


def _plan_and_send(
    task: SrgTask, graph_id: int, count: int | None, renders: bool | None
) -> int | None:
    renders = task.settings.render.growth_renders if renders is None else renders
    try:
        with task.scope() as scope:
            plan = epochs.plan_epoch(scope, graph_id, count=count, renders=renders)
    except epochs.EpochTaken:  # another tick opened the same epoch number first
        return None
    if plan is None:
        log.info("graph %d: an epoch is running; this tick does nothing", graph_id)
        return None
    log.info(
        "graph %d epoch %d: %d expansions %s, %d blends relinked lazily",
        graph_id,
        plan.epoch_id,
        len(plan.expansions),
        "re-sent" if plan.resent else "planned",
        plan.relinks,
    )
    if plan.expansions:
        with task.scope() as scope:
            work = epochs.epoch_work(scope.session, plan.epoch_id)
        epoch_canvas(work).apply_async()
    return plan.epoch_id


@celery_app.task(name="srg.publish_if_due", bind=True)
def publish_if_due(self: SrgTask, graph_id: int) -> int | None:
    """Beat's publication of a growing graph due one; its id, or None (not due after all,
    or another writer holds the graph: the next tick asks again)."""
    with self.scope() as scope:
        return rank_relink_publish.publish_if_due(scope, graph_id)


@celery_app.task(name="srg.schedule_growth", bind=True)
def schedule_growth(self: SrgTask) -> dict[str, list[int]]:
    """Beat's tick: for each graph with ``growing = true`` its publication when one is due
    (``SRG_PUBLISH_EVERY``), else a ``grow_epoch``; the ids of each."""
    with self.scope() as scope:
        tick = rank_relink_publish.beat_tick(scope)
    for graph_id in tick.publish:
        publish_if_due.delay(graph_id)
    for graph_id in tick.grow:
        grow_epoch.delay(graph_id)
    return asdict(tick)


def clip_pipelines(epoch_id: int, clips: list[tuple[int, int]], *, renders: bool) -> Signature:
    """``simulate | sdf | render`` for each (position, control), as one group."""
    return group(clip_pipeline(epoch_id, p, c, renders=renders) for p, c in clips)


def clip_pipeline(epoch_id: int, position: int, control: int, *, renders: bool) -> Signature:
    steps = [simulate.si(epoch_id, position, control), sdf.s(epoch_id, position, control)]
    if renders:
        steps.append(render.s(epoch_id, position, control))
    return chain(*steps)


def epoch_canvas(work: epochs.EpochWork) -> Signature:
    """The flat canvas of what is left of an epoch (see the module docstring), rendering
    as the epoch was planned to."""
    renders = work.renders
    integrations = [integrate.si(work.epoch_id, p, renders) for p in work.pending]
    tail = [blend.si(work.epoch_id)] if renders else []
    body = chain(*integrations, *tail)
    header = [clip_pipeline(work.epoch_id, p, c, renders=renders) for p, c in work.missing_clips]
    return chord(header, body) if header else body


# ---- the client side: grow a graph to a size on the workers -------------------------------
#: seconds between two looks at an epoch's state
EPOCH_POLL = 0.5


def grow_on_workers(
    name: str, to_frames: int, batch: int, progress: Callable[[int], None] | None = None
) -> None:
    """Grow the stored graph ``name`` to ``to_frames`` frames through ``grow_epoch``.

    The same workflow beat drives, one epoch at a time and without renders: this only
    sends epochs and waits for them. Work of an epoch that is lost on the way (a killed
    worker, a restarted Redis) is re-sent by the workers themselves
    (:mod:`app.tasks.watchdog`); an epoch quiet for ``SRG_EPOCH_RESEND_AFTER`` is handed
    to ``grow_epoch`` again.
    """
    settings = get_settings()
    with transaction(settings) as session:
        graph = find_graph(session, name)
    graph_id, per_expansion = graph.id, graph.frames_per_expansion
    size = _size_frames(settings, graph_id)
    budget = GrowthBudget.of(size, to_frames=to_frames)
    while (left := budget.left(size, 0, per_expansion)) > 0:
        epoch_id = grow_epoch.delay(graph_id, min(left, batch), False).get(
            timeout=settings.runtime.task_time_limit
        )
        _wait_for_epochs(settings, graph_id)
        grown = _size_frames(settings, graph_id)
        if progress is not None:
            progress(grown - size)
        if epoch_id is not None and grown == size:
            return  # nothing left to expand
        size = grown


def _size_frames(settings: Settings, graph_id: int) -> int:
    with transaction(settings) as session:
        return size_frames(session, graph_id)


def _wait_for_epochs(settings: Settings, graph_id: int) -> None:
    """Until no epoch of the graph runs; one quiet for ``SRG_EPOCH_RESEND_AFTER`` seconds
    is handed to ``grow_epoch`` again, the backstop that beat would otherwise reach."""
    last_change = time.monotonic()
    seen: tuple[int, float | None] | None = None
    while True:
        with transaction(settings) as session:
            state = running_epoch_state(session, graph_id)
        if state is None:
            return
        if state != seen:
            seen, last_change = state, time.monotonic()
        elif time.monotonic() - last_change > settings.runtime.epoch_resend_after:
            grow_epoch.delay(graph_id, None, False)
            last_change = time.monotonic()
        time.sleep(EPOCH_POLL)
