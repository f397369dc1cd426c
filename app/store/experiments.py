"""Experiments and their checkpoint rows (the tables of ``app.models.experiment``).

A checkpoint row is added in the transaction that stores its publication and the bots'
traces, so the rows of a run are exactly its completed checkpoints: what a resume skips
(docs/experiment.md). Lookups answer None for a name not stored; the use case says
what that means to the user.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, NamedTuple

from sqlalchemy import func, select
from sqlalchemy.orm import Session

from app.models import Clip, Experiment, ExperimentCheckpoint, Graph


def experiment_id(session: Session, name: str) -> int | None:
    return session.scalar(select(Experiment.id).where(Experiment.name == name))


def experiment_plan(session: Session, name: str) -> dict[str, Any] | None:
    """The stored plan of the experiment ``name`` (a JSON dict), or None."""
    return session.scalar(select(Experiment.plan).where(Experiment.name == name))


def add_experiment(session: Session, name: str, plan: dict[str, Any]) -> None:
    session.add(Experiment(name=name, plan=plan))


def existing_graph_names(session: Session, names: Sequence[str]) -> list[str]:
    """Those of ``names`` that a stored graph already has."""
    return list(session.scalars(select(Graph.name).where(Graph.name.in_(names))))


def frames_of_graphs(session: Session, names: Sequence[str]) -> int:
    """Simulated frames stored over the graphs ``names`` (every clip, dead ends too)."""
    total = session.scalar(
        select(func.coalesce(func.sum(Graph.frames_per_clip), 0))
        .select_from(Clip)
        .join(Graph, Graph.id == Clip.graph_id)
        .where(Graph.name.in_(names))
    )
    return int(total or 0)


def done_checkpoints(
    session: Session, experiment: int, strategy: str, seed: int, bot: str
) -> set[int]:
    """Indices (into the plan's checkpoints) of the run's checkpoints ``bot`` played.

    Every crowd of a checkpoint is stored in one transaction, so any one of them says
    whether the checkpoint is complete.
    """
    return set(
        session.scalars(
            select(ExperimentCheckpoint.checkpoint).where(
                ExperimentCheckpoint.experiment_id == experiment,
                ExperimentCheckpoint.strategy == strategy,
                ExperimentCheckpoint.seed == seed,
                ExperimentCheckpoint.bot == bot,
            )
        )
    )


def add_checkpoint(
    session: Session,
    experiment: int,
    *,
    strategy: str,
    seed: int,
    bot: str,
    checkpoint: int,
    graph_id: int,
    publication_id: int,
    figures: dict[str, Any],
    arrays: str,
    seconds: float,
) -> None:
    session.add(
        ExperimentCheckpoint(
            experiment_id=experiment,
            strategy=strategy,
            seed=seed,
            bot=bot,
            checkpoint=checkpoint,
            graph_id=graph_id,
            publication_id=publication_id,
            figures=figures,
            arrays=arrays,
            seconds=seconds,
        )
    )


class CheckpointRecord(NamedTuple):
    """One run's stored checkpoint: where the crowd played and what it measured."""

    strategy: str
    seed: int
    bot: str
    #: index into the plan's checkpoints
    checkpoint: int
    graph_id: int
    publication_id: int
    figures: dict[str, Any]
    #: npz artifact of the per-step errors, edge densities and vertex layout
    arrays: str
    seconds: float


def checkpoint_rows(
    session: Session, experiment: int, *, strategy: str | None = None
) -> list[CheckpointRecord]:
    """The experiment's checkpoints (of one strategy, if named), each run's in order."""
    row = ExperimentCheckpoint
    query = select(
        row.strategy,
        row.seed,
        row.bot,
        row.checkpoint,
        row.graph_id,
        row.publication_id,
        row.figures,
        row.arrays,
        row.seconds,
    ).where(row.experiment_id == experiment)
    if strategy is not None:
        query = query.where(row.strategy == strategy)
    order = (row.bot, row.strategy, row.seed, row.checkpoint)
    return [CheckpointRecord(*found) for found in session.execute(query.order_by(*order))]
