"""Growing a stored graph in-process by a budget, epoch by epoch (``srg grow``).

Each epoch is the very unit the Celery ``grow_epoch`` task runs (:mod:`app.services.epochs`),
so a graph grows the same whether the CLI, the API's embedded server or the workers
grow it.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from app.config import Settings
from app.core.errors import Conflict
from app.core.graph.graph_entry import GraphEntry
from app.core.growth.expansion import GrowthBudget
from app.core.growth.kinds import Strategy, parse_strategy
from app.db.sessions import Transactions
from app.services.epochs import plan_epoch, run_epoch
from app.services.progress import Advance
from app.services.scope import Scope
from app.store.epochs import get_epoch, running_epoch
from app.store.graph_catalogue import graph_entry, size_frames
from app.store.growth_claims import GrowingElsewhere as GrowingElsewhere
from app.store.growth_claims import growth_claim


@dataclass
class GrowResult:
    graph: str
    strategy: str
    epochs: int = 0
    expansions: int = 0
    relinks: int = 0
    size_frames: int = 0
    epoch_ids: list[int] = field(default_factory=list)
    #: "epoch <id>: <why>" for each epoch ranked by a fallback (STATERANK did not converge)
    ranking_fallbacks: list[str] = field(default_factory=list)


class GrowthBusy(Conflict):
    """An epoch of the graph is running on the workers; in-process growth would race it.

    Another in-process grower is :class:`~app.store.growth_claims.GrowingElsewhere`.
    """


def grow_graph(
    transactions: Transactions,
    settings: Settings,
    *,
    name: str | int,
    strategy: str | None = None,
    frames: int | None = None,
    expansions: int | None = None,
    to_frames: int | None = None,
    renders: bool | None = None,
    batch_size: int | None = None,
    progress: Advance | None = None,
) -> GrowResult:
    """Grow in-process by a budget (frames, expansions, or up to a size), epoch by epoch.

    Without a budget: one batch (``settings.growth.batch_size`` expansions). Each epoch is
    planned (rank, pick the top BLEND edges, relink lazily), each clip simulated, the
    expansions integrated in plan order, and animations rendered when ``renders``
    (default ``settings.render.growth_renders``). Every step runs in one of ``transactions()``:
    :func:`app.db.sessions.transaction` makes each step durable (an interrupted grow keeps its
    finished steps, and the next grow first finishes the interrupted epoch);
    :func:`app.services.epochs.in_session` runs all in one caller-owned transaction.

    One process at a time grows a graph in-process: another that holds its growth claim
    (:mod:`app.store.growth_claims`) is :class:`GrowingElsewhere` at once.
    """
    if frames is None and expansions is None and to_frames is None:
        expansions = settings.growth.batch_size
    GrowthBudget.check(frames=frames, expansions=expansions, to_frames=to_frames)
    renders = settings.render.growth_renders if renders is None else renders
    batch = batch_size or settings.growth.batch_size
    with transactions() as session:
        entry = graph_entry(session, name)
        engine = session.get_bind().engine
    with growth_claim(engine, entry.id, entry.name):
        return _grow_claimed(
            transactions,
            settings,
            entry,
            parse_strategy(strategy or entry.strategy),
            frames=frames,
            expansions=expansions,
            to_frames=to_frames,
            renders=renders,
            batch=batch,
            progress=progress,
        )


def _grow_claimed(
    transactions: Transactions,
    settings: Settings,
    entry: GraphEntry,
    chosen: Strategy,
    *,
    frames: int | None,
    expansions: int | None,
    to_frames: int | None,
    renders: bool,
    batch: int,
    progress: Advance | None,
) -> GrowResult:
    """:func:`grow_graph` once this process holds the graph's growth claim.

    Holding it, an in-process grower knows that no other one is running an epoch of the
    graph: with no workers (eager), an epoch found running was left by a grower that
    died, and is finished first.
    """
    graph_id, per_expansion = entry.id, entry.frames_per_expansion
    with transactions() as session:
        size = size_frames(session, graph_id)
        interrupted = running_epoch(session, graph_id) if settings.eager else None
        interrupted_id = None if interrupted is None else interrupted.id
    result = GrowResult(graph=str(entry.name), strategy=chosen.value)

    def advance(_: object) -> None:
        if progress is not None:
            progress(1 if expansions is not None else per_expansion)

    if interrupted_id is not None:
        result.expansions += len(
            run_epoch(transactions, settings, interrupted_id, renders=renders, on_expansion=advance)
        )
        size = _epoch_size(transactions, interrupted_id)
    budget = GrowthBudget.of(size, frames=frames, expansions=expansions, to_frames=to_frames)
    while (left := budget.left(size, result.expansions, per_expansion)) > 0:
        with transactions() as session:
            plan = plan_epoch(
                Scope.of(session, settings),
                graph_id,
                count=min(left, batch),
                strategy=chosen,
                renders=renders,
            )
        if plan is None:
            raise GrowthBusy(f"graph {result.graph!r} has an epoch running on the workers")
        done = run_epoch(
            transactions, settings, plan.epoch_id, renders=renders, on_expansion=advance
        )
        size = _epoch_size(transactions, plan.epoch_id)
        result.epochs += 1
        result.expansions += len(done)
        result.relinks += plan.relinks
        result.epoch_ids.append(plan.epoch_id)
        if plan.ranking_fallback is not None:
            result.ranking_fallbacks.append(f"epoch {plan.epoch_id}: {plan.ranking_fallback}")
        if not plan.expansions:
            break
    result.size_frames = size
    return result


def _epoch_size(transactions: Transactions, epoch_id: int) -> int:
    with transactions() as session:
        return get_epoch(session, epoch_id).size_frames
