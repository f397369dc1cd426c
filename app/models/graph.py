"""Tables of a state graph: the graph row, its vertices, clips and edges, growth epochs.

Vertices, clips and edges are keyed by the graph's dense indices (``idx``, and
``(vertex, control)`` for edges), mirroring :class:`app.core.graph.state_graph.StateGraph`, so a
graph loads with three ordered scans and saves with bulk inserts.
"""

from __future__ import annotations

from datetime import datetime
from typing import Any

from sqlalchemy import (
    JSON,
    BigInteger,
    Boolean,
    Double,
    ForeignKey,
    ForeignKeyConstraint,
    Integer,
    LargeBinary,
    SmallInteger,
    String,
    UniqueConstraint,
)
from sqlalchemy.orm import Mapped, mapped_column
from sqlalchemy.sql.expression import true

from app.models.base import HASH_LENGTH, Base, created_at_column


class Artifact(Base):
    """A content-addressed file under the artifact directory (sha256 of its bytes)."""

    __tablename__ = "artifacts"

    hash: Mapped[str] = mapped_column(String(HASH_LENGTH), primary_key=True)
    size: Mapped[int] = mapped_column(BigInteger)
    media_type: Mapped[str] = mapped_column(String(100))
    created_at: Mapped[datetime] = created_at_column()


class Graph(Base):
    __tablename__ = "graphs"

    id: Mapped[int] = mapped_column(primary_key=True)
    name: Mapped[str] = mapped_column(String(200), unique=True)
    dynamics: Mapped[str] = mapped_column(String(64))
    scene: Mapped[dict[str, Any]] = mapped_column(JSON)
    n_controls: Mapped[int] = mapped_column(Integer)
    frames_per_clip: Mapped[int] = mapped_column(Integer)
    seed: Mapped[int] = mapped_column(Integer)
    #: the world seed of the start state (``Dynamics.initial_state``); NULL: the canonical one
    world: Mapped[int | None] = mapped_column(Integer)
    strategy: Mapped[str] = mapped_column(String(32))
    #: the crowd model sr-crowd learns (app.core.players.kinds.PlayerModelKind)
    player_model: Mapped[str] = mapped_column(String(16), default="eq2", server_default="eq2")
    growing: Mapped[bool] = mapped_column(Boolean, default=False)
    #: bumped by every save; a save that finds another revision lost a race or a rollback
    revision: Mapped[int] = mapped_column(Integer, default=0)
    created_at: Mapped[datetime] = created_at_column()


class Vertex(Base):
    __tablename__ = "vertices"

    graph_id: Mapped[int] = mapped_column(
        ForeignKey("graphs.id", ondelete="CASCADE"), primary_key=True
    )
    idx: Mapped[int] = mapped_column(Integer, primary_key=True)
    control: Mapped[int] = mapped_column(SmallInteger)
    #: the clip that produced the vertex; NULL for the start vertex
    clip_idx: Mapped[int | None] = mapped_column(Integer)


class Clip(Base):
    __tablename__ = "clips"

    graph_id: Mapped[int] = mapped_column(
        ForeignKey("graphs.id", ondelete="CASCADE"), primary_key=True
    )
    idx: Mapped[int] = mapped_column(Integer, primary_key=True)
    source: Mapped[int] = mapped_column(Integer)
    control: Mapped[int] = mapped_column(SmallInteger)
    kinetic: Mapped[float] = mapped_column(Double)
    #: float64 bytes, one potential energy per control
    potential: Mapped[bytes] = mapped_column(LargeBinary)
    score: Mapped[float] = mapped_column(Double)
    #: float32 bytes of the flattened descriptor (the exact one is derived from the frames)
    descriptor: Mapped[bytes] = mapped_column(LargeBinary)
    #: arrays artifact: frames and end_state (older bundles also hold occupancy, descriptor)
    bundle: Mapped[str] = mapped_column(ForeignKey("artifacts.hash"))
    animation: Mapped[str | None] = mapped_column(ForeignKey("artifacts.hash"))


class Edge(Base):
    __tablename__ = "edges"
    __table_args__ = (
        ForeignKeyConstraint(
            ["graph_id", "vertex"], ["vertices.graph_id", "vertices.idx"], ondelete="CASCADE"
        ),
    )

    graph_id: Mapped[int] = mapped_column(
        ForeignKey("graphs.id", ondelete="CASCADE"), primary_key=True
    )
    vertex: Mapped[int] = mapped_column(Integer, primary_key=True)
    control: Mapped[int] = mapped_column(SmallInteger, primary_key=True)
    #: 0 SIM, 1 BLEND (app.core.graph.state_graph.EdgeKind)
    kind: Mapped[int] = mapped_column(SmallInteger)
    clip_idx: Mapped[int] = mapped_column(Integer)
    dst: Mapped[int] = mapped_column(Integer)
    #: edge index (vertex * N + control) of a BLEND edge's SIM target
    target: Mapped[int | None] = mapped_column(Integer)
    err: Mapped[float] = mapped_column(Double)
    animation: Mapped[str | None] = mapped_column(ForeignKey("artifacts.hash"))


class GrowthEpoch(Base):
    __tablename__ = "growth_epochs"
    __table_args__ = (UniqueConstraint("graph_id", "number"),)

    id: Mapped[int] = mapped_column(primary_key=True)
    graph_id: Mapped[int] = mapped_column(ForeignKey("graphs.id", ondelete="CASCADE"))
    number: Mapped[int] = mapped_column(Integer)
    strategy: Mapped[str] = mapped_column(String(32))
    status: Mapped[str] = mapped_column(String(16))
    started_at: Mapped[datetime] = created_at_column()
    finished_at: Mapped[datetime | None] = mapped_column()
    expansions: Mapped[int] = mapped_column(Integer, default=0)
    relinks: Mapped[int] = mapped_column(Integer, default=0)
    size_frames: Mapped[int] = mapped_column(Integer, default=0)
    #: the planned expansions in integration order: [[edge, dead-end clip], ...]
    plan: Mapped[list[list[int]] | None] = mapped_column(JSON)
    #: .npz artifact of the STATERANK pi ranked at planning: the next epoch's warm start
    warm_start: Mapped[str | None] = mapped_column(ForeignKey("artifacts.hash"))
    #: unix time of the last progress (clip stored, expansion integrated, re-send)
    heartbeat: Mapped[float | None] = mapped_column(Double)
    #: whether its clips are rendered: a re-send of lost work renders as the epoch did
    renders: Mapped[bool] = mapped_column(Boolean, default=True, server_default=true())


class GrowthRequest(Base):
    """One growth the admin route accepted (202): what became of it, for its poll.

    A growth runs after its request has been answered, in this server or on the
    workers, so its end is written here, never only in a log (docs/play.md, "Admin").
    """

    __tablename__ = "growth_requests"

    id: Mapped[int] = mapped_column(primary_key=True)
    graph_id: Mapped[int] = mapped_column(ForeignKey("graphs.id", ondelete="CASCADE"), index=True)
    expansions: Mapped[int] = mapped_column(Integer)
    #: "server" or "workers"
    runs_on: Mapped[str] = mapped_column(String(16))
    #: queued, running, finished or failed
    state: Mapped[str] = mapped_column(String(16))
    #: why it failed, in one line
    reason: Mapped[str | None] = mapped_column(String(500))
    #: expansions done, once finished (a server job; the workers' epoch has its own count)
    done: Mapped[int] = mapped_column(Integer, default=0)
    #: the epoch the workers planned for it
    epoch_id: Mapped[int | None] = mapped_column(
        ForeignKey("growth_epochs.id", ondelete="SET NULL")
    )
    created_at: Mapped[datetime] = created_at_column()
    finished_at: Mapped[datetime | None] = mapped_column()


class ExpansionClip(Base):
    """One simulated clip of a planned expansion: written by a worker, read on integration.

    Keyed by (epoch, position in the plan, control), so a redelivered task that stores the
    same clip again changes nothing.
    """

    __tablename__ = "expansion_clips"

    epoch_id: Mapped[int] = mapped_column(
        ForeignKey("growth_epochs.id", ondelete="CASCADE"), primary_key=True
    )
    position: Mapped[int] = mapped_column(Integer, primary_key=True)
    control: Mapped[int] = mapped_column(SmallInteger, primary_key=True)
    #: .npz artifact: frames, end_state and every ClipFeatures field
    clip: Mapped[str] = mapped_column(ForeignKey("artifacts.hash"))
    #: the new clip's strip, as rendered before strips waited for their edge's expansion
    #: (docs/runtime.md, "Strips"); no longer written, still read by the artifact GC
    animation: Mapped[str | None] = mapped_column(ForeignKey("artifacts.hash"))


class SimulatedClip(Base):
    """A clip already simulated, by what determines it: one simulation per (dynamics,
    start state, control) in the database (docs/runtime.md, "Each simulation once").

    A cache, not a reference: ``clip`` has no foreign key, so ``srg gc`` may collect a
    clip no graph holds any longer, and the next lookup of its key simulates again.
    """

    __tablename__ = "simulated_clips"

    #: sha256 of the dynamics' identity, the control and the start state's bytes
    key: Mapped[str] = mapped_column(String(HASH_LENGTH), primary_key=True)
    #: the finished clip's arrays artifact (frames, end state, features)
    clip: Mapped[str] = mapped_column(String(HASH_LENGTH))
    created_at: Mapped[datetime] = created_at_column()
