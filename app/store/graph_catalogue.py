"""The catalogue of stored graphs: their rows, and what is read of a graph without loading it.

A graph row is found by name or id (:func:`get_graph_row`; :func:`graph_entry` hands it
out as a value for the layers above), made empty
(:func:`create_graph`) and marked for beat's growth; its size, revision, edge kinds and a
clip's bundle are single queries. Loading and saving the graph itself, its vertices,
clips and edges, is :mod:`app.store.graph_persistence`.
"""

from __future__ import annotations

import re

from sqlalchemy import String, func, select
from sqlalchemy.exc import IntegrityError
from sqlalchemy.orm import Session

from app.core.errors import Conflict, NotFound
from app.core.graph.graph_entry import GraphEntry, GraphScene
from app.core.graph.state_graph import edge_vertex_control
from app.db.limits import MAX_ROW_ID
from app.models import Clip, Edge, Graph


class GraphNotFound(NotFound):
    """No graph with that name or id."""


class GraphExists(Conflict):
    """A graph of that name is already stored."""


def create_graph(
    session: Session,
    *,
    name: str,
    dynamics: str,
    n_controls: int,
    frames_per_clip: int,
    scene: GraphScene | None = None,
    seed: int = 0,
    strategy: str = "sr-crowd",
    player_model: str = "eq2",
    world: int | None = None,
) -> int:
    """Add an empty graph row and return its id; :func:`save_graph` fills it.

    :class:`GraphExists` when the name is taken, also by a writer that committed it
    after the caller checked (the unique name is the last word).
    """
    row = Graph(
        name=name,
        dynamics=dynamics,
        scene=(scene or GraphScene()).to_json(),
        n_controls=n_controls,
        frames_per_clip=frames_per_clip,
        seed=seed,
        world=world,
        strategy=strategy,
        player_model=player_model,
        growing=False,
        revision=0,
    )
    session.add(row)
    try:
        session.flush()
    except IntegrityError:
        raise GraphExists(f"a graph named {name!r} already exists") from None
    return row.id


MAX_ID_DIGITS = len(str(MAX_ROW_ID))
_ASCII_DIGITS = re.compile(r"[0-9]+")


def get_graph_row(session: Session, name_or_id: str | int) -> Graph:
    """The graph row by id (an int, or a string of the digits 0-9) or else by name.

    An id outside the database's integer range names no graph (:class:`GraphNotFound`),
    never an overflow; ``str.isdigit`` is not used because it accepts '²' and '٣'.
    """
    row: Graph | None
    if isinstance(name_or_id, int) or _ASCII_DIGITS.fullmatch(name_or_id):
        # more digits than the largest id names no graph, and would not even parse
        too_long = isinstance(name_or_id, str) and len(name_or_id.lstrip("0")) > MAX_ID_DIGITS
        graph_id = 0 if too_long else int(name_or_id)
        row = session.get(Graph, graph_id) if 1 <= graph_id <= MAX_ROW_ID else None
    elif "\x00" in name_or_id:  # PostgreSQL refuses NUL in text; no name holds one
        row = None
    else:
        row = session.scalars(select(Graph).where(Graph.name == name_or_id)).one_or_none()
    if row is None:
        named = str(name_or_id)
        shown = repr(named) if len(named) <= 80 else f"{named[:40]!r}... ({len(named)} characters)"
        raise GraphNotFound(f"no graph {shown}")
    return row


def entry_of(row: Graph) -> GraphEntry:
    """The row as a value (its scene typed)."""
    return GraphEntry(
        id=row.id,
        name=row.name,
        dynamics=row.dynamics,
        n_controls=row.n_controls,
        frames_per_clip=row.frames_per_clip,
        scene=GraphScene.from_json(row.scene),
        strategy=row.strategy,
        player_model=row.player_model,
        growing=row.growing,
        world=row.world,
    )


def graph_entry(session: Session, name_or_id: str | int) -> GraphEntry:
    """:func:`get_graph_row` as a value."""
    return entry_of(get_graph_row(session, name_or_id))


def graph_name_length() -> int:
    """The length of the graphs' name column: the longest name every backend stores."""
    column = Graph.__table__.c.name.type
    assert isinstance(column, String) and column.length is not None
    return column.length


def size_frames(session: Session, graph_id: int) -> int:
    """The graph's size in simulated frames: every stored clip, dead ends included."""
    clips = session.scalar(select(func.count()).where(Clip.graph_id == graph_id)) or 0
    return int(clips) * get_graph_row(session, graph_id).frames_per_clip


def graph_exists(session: Session, name: str) -> bool:
    return session.scalar(select(Graph.id).where(Graph.name == name)) is not None


def graph_ids(session: Session) -> list[int]:
    """Every stored graph's id, oldest first."""
    return list(session.scalars(select(Graph.id).order_by(Graph.id)))


def growing_graph_ids(session: Session) -> list[int]:
    """The graphs beat grows (``growing = true``)."""
    return list(session.scalars(select(Graph.id).where(Graph.growing.is_(True))))


def mark_growing(session: Session, name_or_id: str | int, growing: bool) -> GraphEntry:
    row = get_graph_row(session, name_or_id)
    row.growing = growing
    session.flush()
    return entry_of(row)


def graph_revision(session: Session, graph_id: int) -> int | None:
    """The graph's saved revision (None: no such graph), without loading its row."""
    return session.scalar(select(Graph.revision).where(Graph.id == graph_id))


def edge_kind_counts(session: Session, graph_id: int) -> dict[int, int]:
    """How many stored edges of each kind (``EdgeKind`` values) the graph has."""
    return {
        kind: count
        for kind, count in session.execute(
            select(Edge.kind, func.count()).where(Edge.graph_id == graph_id).group_by(Edge.kind)
        )
    }


def stored_edge_kind(session: Session, graph: GraphEntry, edge: int) -> int | None:
    """The stored kind of one edge (by index), read without loading the graph."""
    vertex, control = edge_vertex_control(edge, graph.n_controls)
    return session.scalar(
        select(Edge.kind).where(
            Edge.graph_id == graph.id, Edge.vertex == vertex, Edge.control == control
        )
    )


def clip_bundle_digest(session: Session, graph_id: int, clip: int) -> str | None:
    """The artifact holding one stored clip (frames, end state, features)."""
    return session.scalar(select(Clip.bundle).where(Clip.graph_id == graph_id, Clip.idx == clip))
