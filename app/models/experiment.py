"""Tables of the paper's evaluation: an experiment's plan and each checkpoint's results.

An experiment grows one stored graph per run (a strategy and a seed, and for a strategy
that learns from traces a crowd); a checkpoint row holds one crowd's play of one run's
checkpoint, written in the same transaction as the publication and the bots' traces it
reports on, so a row exists exactly when its checkpoint is complete. That makes an interrupted
experiment resumable from its last completed checkpoint (docs/experiment.md).
"""

from __future__ import annotations

from datetime import datetime
from typing import Any

from sqlalchemy import JSON, Double, ForeignKey, Integer, String, UniqueConstraint
from sqlalchemy.orm import Mapped, mapped_column

from app.models.base import Base, created_at_column


class Experiment(Base):
    __tablename__ = "experiments"

    id: Mapped[int] = mapped_column(primary_key=True)
    name: Mapped[str] = mapped_column(String(200), unique=True)
    #: the ExperimentPlan as a JSON dict: what a resume must run again
    plan: Mapped[dict[str, Any]] = mapped_column(JSON)
    created_at: Mapped[datetime] = created_at_column()


class ExperimentCheckpoint(Base):
    __tablename__ = "experiment_checkpoints"
    __table_args__ = (
        UniqueConstraint(
            "experiment_id",
            "strategy",
            "seed",
            "bot",
            "checkpoint",
            name="uq_experiment_checkpoints_run",
        ),
    )

    id: Mapped[int] = mapped_column(primary_key=True)
    experiment_id: Mapped[int] = mapped_column(ForeignKey("experiments.id", ondelete="CASCADE"))
    strategy: Mapped[str] = mapped_column(String(32))
    seed: Mapped[int] = mapped_column(Integer)
    #: the crowd that played this row (app.core.players.kinds.BotKind)
    bot: Mapped[str] = mapped_column(String(32), server_default="goal-directed")
    #: index into the plan's checkpoints
    checkpoint: Mapped[int] = mapped_column(Integer)
    graph_id: Mapped[int] = mapped_column(ForeignKey("graphs.id", ondelete="CASCADE"))
    publication_id: Mapped[int] = mapped_column(ForeignKey("publications.id", ondelete="CASCADE"))
    #: the row of figures (JSON) of this checkpoint
    figures: Mapped[dict[str, Any]] = mapped_column(JSON)
    #: per-step errors, predicted and observed edge densities, vertex layout (npz artifact)
    arrays: Mapped[str] = mapped_column(ForeignKey("artifacts.hash"))
    seconds: Mapped[float] = mapped_column(Double)
    created_at: Mapped[datetime] = created_at_column()
