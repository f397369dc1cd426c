"""Tables of play: publications players see, players, and the traces they upload."""

from __future__ import annotations

from datetime import datetime

from sqlalchemy import (
    BigInteger,
    CheckConstraint,
    Double,
    ForeignKey,
    Index,
    Integer,
    SmallInteger,
    String,
    UniqueConstraint,
    text,
)
from sqlalchemy.orm import Mapped, mapped_column

from app.core.players.kinds import PlayerKind
from app.models.base import HASH_LENGTH, Base, created_at_column

#: the kinds a player may be, as the database enforces them (migration 0007)
PLAYER_KIND_CHECK = "kind IN ({})".format(", ".join(f"'{kind.value}'" for kind in PlayerKind))


class Publication(Base):
    __tablename__ = "publications"
    __table_args__ = (UniqueConstraint("graph_id", "number"),)

    id: Mapped[int] = mapped_column(primary_key=True)
    graph_id: Mapped[int] = mapped_column(ForeignKey("graphs.id", ondelete="CASCADE"))
    #: 1, 2, ... per graph, in publication order
    number: Mapped[int] = mapped_column(Integer)
    created_at: Mapped[datetime] = created_at_column()
    n_vertices: Mapped[int] = mapped_column(Integer)
    n_edges: Mapped[int] = mapped_column(Integer)
    size_frames: Mapped[int] = mapped_column(Integer)
    start: Mapped[int] = mapped_column(Integer)
    #: the threshold in force when it was published (app.services.dynamics.threshold_in_force),
    #: so that SQL over the analytics views needs no calibration file; NULL before 0011
    high_error_threshold: Mapped[float | None] = mapped_column(Double)


class PublicationEdge(Base):
    """The frozen copy of one edge: what a player on this publication actually saw."""

    __tablename__ = "publication_edges"

    publication_id: Mapped[int] = mapped_column(
        ForeignKey("publications.id", ondelete="CASCADE"), primary_key=True
    )
    vertex: Mapped[int] = mapped_column(Integer, primary_key=True)
    control: Mapped[int] = mapped_column(SmallInteger, primary_key=True)
    dst: Mapped[int] = mapped_column(Integer)
    kind: Mapped[int] = mapped_column(SmallInteger)
    err: Mapped[float] = mapped_column(Double)
    score: Mapped[float] = mapped_column(Double)
    animation: Mapped[str | None] = mapped_column(ForeignKey("artifacts.hash"))


class EdgeKindName(Base):
    """The name of each :class:`~app.core.graph.state_graph.EdgeKind` number, for SQL that reads
    ``edges.kind`` and ``publication_edges.kind`` (the analytics views join it)."""

    __tablename__ = "edge_kinds"

    kind: Mapped[int] = mapped_column(SmallInteger, primary_key=True, autoincrement=False)
    name: Mapped[str] = mapped_column(String(16), unique=True)


class Player(Base):
    __tablename__ = "players"
    __table_args__ = (CheckConstraint(PLAYER_KIND_CHECK, name="kind"),)

    id: Mapped[int] = mapped_column(primary_key=True)
    name: Mapped[str] = mapped_column(String(100), unique=True)
    #: a :class:`~app.core.players.kinds.PlayerKind`, said at registration; no default, so that
    #: a writer that forgot to say who played fails rather than counts as either
    kind: Mapped[str] = mapped_column(String(8))
    #: sha256 of the bearer token; the token itself is never stored
    token_hash: Mapped[str] = mapped_column(String(HASH_LENGTH), unique=True)
    created_at: Mapped[datetime] = created_at_column()


class Trace(Base):
    __tablename__ = "traces"
    __table_args__ = (
        UniqueConstraint("player_id", "idempotency_key"),
        # the uncounted traces of a publication (ordinal NULL), and a counted batch
        Index("ix_traces_publication_id_ordinal", "publication_id", "ordinal"),
    )

    id: Mapped[int] = mapped_column(primary_key=True)
    publication_id: Mapped[int] = mapped_column(
        ForeignKey("publications.id", ondelete="CASCADE"), index=True
    )
    player_id: Mapped[int] = mapped_column(ForeignKey("players.id", ondelete="CASCADE"))
    idempotency_key: Mapped[str] = mapped_column(String(128))
    created_at: Mapped[datetime] = created_at_column()
    n_steps: Mapped[int] = mapped_column(Integer)
    #: summed over the steps, on the publication's frozen edge errors, when it was stored
    error: Mapped[float] = mapped_column(Double, server_default=text("0"))
    #: its steps above the publication's stored threshold; NULL where it stored none
    high_error_steps: Mapped[int | None] = mapped_column(Integer)
    #: its place (0, 1, ...) among its graph's sessions, given when the sums first count
    #: it (app.store.play_counts); NULL until then
    ordinal: Mapped[int | None] = mapped_column(Integer)


class TraceStep(Base):
    __tablename__ = "trace_steps"

    trace_id: Mapped[int] = mapped_column(
        ForeignKey("traces.id", ondelete="CASCADE"), primary_key=True
    )
    step: Mapped[int] = mapped_column(Integer, primary_key=True)
    vertex: Mapped[int] = mapped_column(Integer)
    control: Mapped[int] = mapped_column(SmallInteger)


class GraphSessions(Base):
    """How many of the graph's sessions the sums count: the next one's ordinal.

    Its row is the lock under which a reader of the sums numbers the traces uploaded since
    the last count, in id order, and adds them (docs/player-models.md); uploads never
    take it.
    """

    __tablename__ = "graph_sessions"

    graph_id: Mapped[int] = mapped_column(
        ForeignKey("graphs.id", ondelete="CASCADE"), primary_key=True
    )
    sessions: Mapped[int] = mapped_column(Integer)


class PlayCount(Base):
    """Steps taken with ``control`` at ``vertex`` on a publication by the sessions whose
    ordinal in the graph is ``bucket`` modulo :data:`~app.core.players.crowd_play.FOLD_BUCKETS`:
    what the crowd models read, kept as traces are accepted (app.store.play_counts), per
    kind of player so that analytics can answer for people or bots."""

    __tablename__ = "play_counts"

    publication_id: Mapped[int] = mapped_column(
        ForeignKey("publications.id", ondelete="CASCADE"), primary_key=True
    )
    player_kind: Mapped[str] = mapped_column(String(8), primary_key=True)
    bucket: Mapped[int] = mapped_column(SmallInteger, primary_key=True)
    vertex: Mapped[int] = mapped_column(Integer, primary_key=True)
    control: Mapped[int] = mapped_column(SmallInteger, primary_key=True)
    steps: Mapped[int] = mapped_column(BigInteger)


class PlayLength(Base):
    """Sessions of ``n_steps`` steps accepted on a publication (the restart rate's median)."""

    __tablename__ = "play_lengths"

    publication_id: Mapped[int] = mapped_column(
        ForeignKey("publications.id", ondelete="CASCADE"), primary_key=True
    )
    player_kind: Mapped[str] = mapped_column(String(8), primary_key=True)
    n_steps: Mapped[int] = mapped_column(Integer, primary_key=True)
    sessions: Mapped[int] = mapped_column(BigInteger)


class PlayVisit(Base):
    """Sessions accepted on a publication that stepped at ``vertex`` at least once (the
    analytics' sessions per vertex, kept as traces are accepted)."""

    __tablename__ = "play_visits"

    publication_id: Mapped[int] = mapped_column(
        ForeignKey("publications.id", ondelete="CASCADE"), primary_key=True
    )
    player_kind: Mapped[str] = mapped_column(String(8), primary_key=True)
    vertex: Mapped[int] = mapped_column(Integer, primary_key=True)
    sessions: Mapped[int] = mapped_column(BigInteger)
