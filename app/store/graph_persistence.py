"""Saving and loading a state graph: its vertices, clips and edges.

:func:`save_graph` writes only what changed since the graph object was loaded or last
saved: new vertices, clips and edges as bulk inserts, changed edges as one bulk update.
It remembers what it persisted in a snapshot kept beside the graph object (keyed by the
object's identity, dropped with it), and guards every save with the ``graphs.revision``
counter: a save whose snapshot is not the database's current revision (another writer got
there first, or the transaction of the previous save rolled back) raises
:class:`StaleGraph` instead of writing a wrong diff. Reload and redo the work then.
"""

from __future__ import annotations

import weakref
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from sqlalchemy import Row, select, update
from sqlalchemy.orm import Session

from app.core.errors import Conflict
from app.core.graph.clipbank import ClipBank
from app.core.graph.state_graph import NO_TARGET, EdgeKind, GraphInvariantError, StateGraph
from app.models import Clip, Edge, Graph, Vertex
from app.store._sql import bulk_insert
from app.store.array_codec import ARRAYS_MEDIA_TYPE, encode_arrays
from app.store.artifacts import ArtifactStore
from app.store.clipbank import SHAPE_CACHE_BYTES, ShapeOf, StoredClipBank, clip_bundle
from app.store.graph_catalogue import GraphNotFound, get_graph_row, graph_revision

#: "no clip" in vertex_clip (the start vertex) and in the placeholders of unfilled edges
NO_CLIP = -1


class StaleGraph(Conflict):
    """The in-memory graph is not based on the database's current revision of it.

    Another writer saved the graph first: the work is redone on a reload (the tasks
    retry it), and a user who meets it runs the command again.
    """


@dataclass(frozen=True)
class _Persisted:
    """What one graph object last wrote to (or read from) the database."""

    graph_id: int
    revision: int
    n_vertices: int
    n_clips: int
    edges: np.ndarray  # (E, 5) float64: kind, clip, dst, target, err


_snapshots: dict[int, _Persisted] = {}


def _remember(graph: StateGraph, persisted: _Persisted) -> None:
    key = id(graph)
    if key not in _snapshots:
        weakref.finalize(graph, _snapshots.pop, key, None)
    _snapshots[key] = persisted


def _edge_table(graph: StateGraph) -> np.ndarray:
    return np.column_stack(
        [
            np.asarray(graph.edge_kind, dtype=np.float64),
            np.asarray(graph.edge_clip, dtype=np.float64),
            np.asarray(graph.edge_dst, dtype=np.float64),
            np.asarray(graph.edge_target, dtype=np.float64),
            np.asarray(graph.edge_err, dtype=np.float64),
        ]
    ).reshape(graph.n_edges, 5)


def save_graph(
    session: Session, graph_id: int, graph: StateGraph, bank: ClipBank, artifacts: ArtifactStore
) -> None:
    """Write what changed in ``graph`` since it was loaded or saved, bundles included.

    Changed edges lose their animation (it showed the old transition); render again and
    call :func:`set_animations`. A clip's end state is written only while its edge is a
    blend, and a clip whose blend edge became a simulation is rewritten without it
    (``app.store.clipbank``). Raises :class:`StaleGraph` (see the module docstring).
    """
    graph.check()
    before = _snapshots.get(id(graph))
    if before is None or before.graph_id != graph_id:
        before = _Persisted(graph_id, 0, 0, 0, np.empty((0, 5)))
    bumped = session.execute(
        update(Graph)
        .where(Graph.id == graph_id, Graph.revision == before.revision)
        .values(revision=before.revision + 1)
    )
    if bumped.rowcount != 1:  # type: ignore[attr-defined]
        get_graph_row(session, graph_id)
        raise StaleGraph(f"graph {graph_id} changed since revision {before.revision}; reload it")

    edges = _edge_table(graph)
    simulated = _simulated_clips(edges, graph.n_clips)
    new_clips = range(before.n_clips, graph.n_clips)
    digests = artifacts.put_many(
        (encode_arrays(clip_bundle(bank, c, keep_state=c not in simulated)) for c in new_clips),
        media_type=ARRAYS_MEDIA_TYPE,
        session=session,
    )
    bulk_insert(session, Vertex, _vertex_rows(graph_id, graph, before.n_vertices))
    bulk_insert(session, Clip, _clip_rows(graph_id, graph, new_clips, digests))
    old = len(before.edges)
    bulk_insert(session, Edge, _edge_rows(graph_id, graph, range(old, graph.n_edges)))
    changed = np.flatnonzero(np.any(edges[:old] != before.edges, axis=1))
    if len(changed):
        rows = _edge_rows(graph_id, graph, changed.tolist())
        session.execute(update(Edge), [{**row, "animation": None} for row in rows])
    expanded = _expanded_clips(before.edges, edges[:old], changed)
    rewritten = _drop_end_states(session, graph_id, bank, artifacts, expanded)
    if isinstance(bank, StoredClipBank):
        saved = dict(zip(new_clips, digests, strict=True))
        saved.update(zip(expanded, rewritten, strict=True))
        bank.mark_saved(saved)
    _remember(
        graph,
        _Persisted(graph_id, before.revision + 1, graph.n_vertices, graph.n_clips, edges),
    )


def require_saved(session: Session, graph_id: int, graph: StateGraph) -> None:
    """Raise :class:`StaleGraph` unless ``graph`` equals the database's current revision."""
    persisted = _snapshots.get(id(graph))
    current = get_graph_row(session, graph_id).revision
    if (
        persisted is None
        or persisted.graph_id != graph_id
        or persisted.revision != current
        or persisted.n_clips != graph.n_clips
        or not np.array_equal(persisted.edges, _edge_table(graph))
    ):
        raise StaleGraph(f"graph {graph_id} has unsaved or stale changes; save or reload it")


def load_graph(
    session: Session,
    graph_id: int,
    artifacts: ArtifactStore,
    shape_of: ShapeOf,
    shape_cache_bytes: int = SHAPE_CACHE_BYTES,
) -> tuple[StateGraph, StoredClipBank]:
    """The graph as last saved, with a bank that reads clip bundles lazily.

    ``shape_of`` derives a clip's occupancy and descriptor from its frames (the graph's
    dynamics' ``shape``).

    The graph comes from one revision, whatever commits meanwhile. Its row, vertices,
    clips and edges are separate statements, and under PostgreSQL's READ COMMITTED each
    sees what was committed when it began: a save committed between them would give a
    torn graph. Every save bumps ``graphs.revision`` in its transaction, so the read is
    kept when the revision after it is the one before it; otherwise it is read again
    with the graph's row share-locked (:func:`_share_lock`), which waits for a save in
    flight to commit and holds off the next until the caller's transaction ends. SQLite
    reads one snapshot per transaction, so there the first read always stands.

    Descriptors come back as float64 of the stored float32 values; everything else is
    exact. The energy index is rebuilt through ``set_sim`` in ascending energy order,
    where each insertion is an append. A stored graph that breaks an invariant is
    :class:`~app.core.graph.state_graph.GraphInvariantError`, naming the graph.
    """
    row = get_graph_row(session, graph_id)
    revision = _current_revision(session, graph_id)
    stored = _stored_rows(session, graph_id)
    if _current_revision(session, graph_id) != revision:
        _share_lock(session, graph_id)
        revision = _current_revision(session, graph_id)
        stored = _stored_rows(session, graph_id)
    graph = StateGraph(n_controls=row.n_controls, frames_per_clip=row.frames_per_clip)
    try:
        bundles = _fill_graph(graph, stored)
        graph.check()
    except GraphInvariantError as exc:
        raise GraphInvariantError(f"graph {graph_id} at revision {revision}: {exc}") from None
    _remember(
        graph,
        _Persisted(graph_id, revision, graph.n_vertices, graph.n_clips, _edge_table(graph)),
    )
    return graph, StoredClipBank(
        graph, artifacts, dict(enumerate(bundles)), shape_of, shape_cache_bytes
    )


def _current_revision(session: Session, graph_id: int) -> int:
    """The revision committed now (or written by this transaction), read past the row
    object the session may hold from earlier."""
    revision = graph_revision(session, graph_id)
    if revision is None:
        raise GraphNotFound(f"no graph {graph_id!r}")
    return revision


def _share_lock(session: Session, graph_id: int) -> None:
    """Lock the graph's row against saves until the transaction ends (PostgreSQL's
    ``FOR SHARE``; SQLite, whose transactions read one snapshot, needs none)."""
    if session.get_bind().dialect.name != "sqlite":
        session.execute(select(Graph.id).where(Graph.id == graph_id).with_for_update(read=True))


@dataclass(frozen=True)
class _StoredRows:
    """A graph's rows as read, before anything is built of them."""

    vertices: Sequence[Row[int, int | None]]  # control, clip
    clips: Sequence[Row[int, int, float, bytes, float, bytes, str]]  # source, features, bundle
    edges: Sequence[Row[int, int, int, int | None, float]]  # kind, clip, dst, target, err


def _stored_rows(session: Session, graph_id: int) -> _StoredRows:
    return _StoredRows(
        vertices=session.execute(
            select(Vertex.control, Vertex.clip_idx)
            .where(Vertex.graph_id == graph_id)
            .order_by(Vertex.idx)
        ).all(),
        clips=session.execute(
            select(Clip.source, *CLIP_FEATURE_COLUMNS)
            .where(Clip.graph_id == graph_id)
            .order_by(Clip.idx)
        ).all(),
        edges=session.execute(
            select(Edge.kind, Edge.clip_idx, Edge.dst, Edge.target, Edge.err)
            .where(Edge.graph_id == graph_id)
            .order_by(Edge.vertex, Edge.control)
        ).all(),
    )


def _fill_graph(graph: StateGraph, stored: _StoredRows) -> list[str]:
    """Build the empty ``graph`` from its rows; the clips' bundle digests, by clip."""
    graph.vertex_control = [control for control, _ in stored.vertices]
    graph.vertex_clip = [NO_CLIP if clip is None else clip for _, clip in stored.vertices]
    rows = stored.clips
    graph.clip_source = [r.source for r in rows]
    graph.clip_control = [r.control for r in rows]
    graph.clip_kinetic = [r.kinetic for r in rows]
    graph.clip_potential = [stored_potential(r.potential) for r in rows]
    graph.clip_score = [r.score for r in rows]
    graph.clip_descriptor = [stored_descriptor(r.descriptor) for r in rows]
    for energy_order in _fill_edges(graph, stored.edges):
        for edge, clip, dst in energy_order:
            graph.set_sim(edge, clip, dst)
    return [r.bundle for r in rows]


#: the columns a stored clip is compared by (its features) and found by (its bundle)
CLIP_FEATURE_COLUMNS = (
    Clip.control,
    Clip.kinetic,
    Clip.potential,
    Clip.score,
    Clip.descriptor,
    Clip.bundle,
)


def stored_potential(raw: bytes) -> np.ndarray:
    """A clip row's potential energies (float64 bytes, one per control)."""
    return np.frombuffer(raw, dtype=np.float64).copy()


def stored_descriptor(raw: bytes) -> np.ndarray:
    """A clip row's descriptor (float32 bytes; the exact one lives in the bundle)."""
    return np.frombuffer(raw, dtype=np.float32).astype(np.float64)


def _fill_edges(
    graph: StateGraph, rows: Sequence[Row[int, int, int, int | None, float]]
) -> list[list[tuple[int, int, int]]]:
    """Fill the edge columns; return each control's SIM edges (edge, clip, dst) by energy.

    SIM edges are left as unfilled placeholders for the caller to ``set_sim``, which
    also files them in the energy index.
    """
    n = graph.n_controls
    sims: list[list[tuple[float, int, int, int]]] = [[] for _ in range(n)]
    for edge, (kind, clip, dst, target, err) in enumerate(rows):
        if kind == EdgeKind.SIM:
            control = graph.edge_control(edge)
            sims[control].append((graph.clip_energy(clip, control), edge, clip, dst))
            kind, clip, dst, target, err = EdgeKind.BLEND, NO_CLIP, NO_CLIP, None, np.inf
        graph.edge_kind.append(EdgeKind(kind))
        graph.edge_clip.append(clip)
        graph.edge_dst.append(dst)
        graph.edge_target.append(NO_TARGET if target is None else target)
        graph.edge_err.append(err)
    return [[(edge, clip, dst) for _, edge, clip, dst in sorted(s)] for s in sims]


def _drop_end_states(
    session: Session, graph_id: int, bank: ClipBank, artifacts: ArtifactStore, clips: list[int]
) -> list[str]:
    """Rewrite these clips' bundles with their frames only; the new bundles' digests."""
    digests = artifacts.put_many(
        (encode_arrays(clip_bundle(bank, clip, keep_state=False)) for clip in clips),
        media_type=ARRAYS_MEDIA_TYPE,
        session=session,
    )
    if clips:
        rows = [
            {"graph_id": graph_id, "idx": clip, "bundle": digest}
            for clip, digest in zip(clips, digests, strict=True)
        ]
        session.execute(update(Clip), rows)
    return digests


def _simulated_clips(edges: np.ndarray, n_clips: int) -> set[int]:
    """The clips whose edge is a simulation (their end state is no longer needed)."""
    sim = (edges[:, 0] == EdgeKind.SIM) & (edges[:, 1] >= 0) & (edges[:, 1] < n_clips)
    return set(edges[sim, 1].astype(np.int64).tolist())


def _expanded_clips(before: np.ndarray, after: np.ndarray, changed: np.ndarray) -> list[int]:
    """Clips saved before whose blend edge has since become a simulation of the same clip."""
    return sorted(
        int(after[e, 1])
        for e in changed
        if before[e, 0] == EdgeKind.BLEND
        and after[e, 0] == EdgeKind.SIM
        and before[e, 1] == after[e, 1]
    )


def _vertex_rows(graph_id: int, graph: StateGraph, first: int) -> list[dict[str, Any]]:
    return [
        {
            "graph_id": graph_id,
            "idx": v,
            "control": graph.vertex_control[v],
            "clip_idx": None if graph.vertex_clip[v] < 0 else graph.vertex_clip[v],
        }
        for v in range(first, graph.n_vertices)
    ]


def _clip_rows(
    graph_id: int, graph: StateGraph, clips: range, digests: list[str]
) -> list[dict[str, Any]]:
    return [
        {
            "graph_id": graph_id,
            "idx": i,
            "source": graph.clip_source[i],
            "control": graph.clip_control[i],
            "kinetic": graph.clip_kinetic[i],
            "potential": np.asarray(graph.clip_potential[i], dtype=np.float64).tobytes(),
            "score": graph.clip_score[i],
            "descriptor": np.asarray(graph.clip_descriptor[i], dtype=np.float32).tobytes(),
            "bundle": digest,
        }
        for i, digest in zip(clips, digests, strict=True)
    ]


def _edge_rows(graph_id: int, graph: StateGraph, edges: Iterable[int]) -> list[dict[str, Any]]:
    return [
        {
            "graph_id": graph_id,
            "vertex": graph.edge_source(e),
            "control": graph.edge_control(e),
            "kind": int(graph.edge_kind[e]),
            "clip_idx": graph.edge_clip[e],
            "dst": graph.edge_dst[e],
            "target": None if graph.edge_target[e] == NO_TARGET else graph.edge_target[e],
            "err": float(graph.edge_err[e]),
        }
        for e in edges
    ]
