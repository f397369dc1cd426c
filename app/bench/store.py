"""Benchmark of the graph store: save and load a complete graph of ``n_edges`` edges.

Growth saves incrementally, but an import, a first save or a worker's cold start moves
the whole graph; that must take seconds at the paper's scale (a 200K-frame graph has
about 20K clips; 100K edges is five times that). The timed save includes writing every
clip's bundle to the artifact store; the timed load reads no bundle (they load lazily).
Nothing is left behind: the transaction is rolled back and the artifacts are in a
temporary directory.
"""

from __future__ import annotations

import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from sqlalchemy.orm import Session

from app.core.graph.clipbank import MemoryClipBank
from app.core.graph.dynamics import ClipFeatures, SimClip
from app.core.graph.state_graph import StateGraph, edge_vertex_control
from app.db.engines import make_engine
from app.models import Base
from app.store.artifacts import ArtifactStore
from app.store.graph_catalogue import create_graph
from app.store.graph_persistence import load_graph, save_graph


@dataclass(frozen=True)
class StoreBench:
    n_edges: int
    save_seconds: float
    load_seconds: float


def synthetic_shape(frames: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A synthetic clip's occupancy and descriptor: like a dynamics' ``shape``, a function
    of its frames (a (k, 8) occupancy, a 6 x 6 descriptor)."""
    frames = np.asarray(frames, dtype=np.float64)
    return np.sqrt(frames), np.resize(frames.mean(axis=0), 36).reshape(6, 6)


def synthetic_graph(
    n_edges: int,
    n_controls: int = 3,
    frames_per_clip: int = 10,
    seed: int = 0,
    distinct_bundles: int | None = None,
) -> tuple[StateGraph, MemoryClipBank]:
    """A complete, valid graph shaped like a grown one, with random small clips.

    Vertex ``w >= 1`` is the end of the SIM edge ``w - 1`` (so every source exists
    before its edge); every later edge is a BLEND into a random SIM edge of its control.
    With ``distinct_bundles``, clips share that many frame and occupancy arrays, so the
    content-addressed store writes that many files (tests that check the database).
    """
    rng = np.random.default_rng(seed)
    n_vertices = max(n_edges // n_controls, n_controls + 1)
    n_sim = n_vertices - 1
    graph = StateGraph(n_controls=n_controls, frames_per_clip=frames_per_clip)
    bank = MemoryClipBank()
    n_all = n_vertices * n_controls
    kinetic, score = rng.random(n_all), rng.random(n_all)
    potential = rng.random((n_all, n_controls))
    n_arrays = n_all if distinct_bundles is None else distinct_bundles
    frames = rng.random((n_arrays, frames_per_clip, 8)).astype(np.float32)
    shapes = [synthetic_shape(f) for f in frames]
    for edge in range(n_all):
        shared = edge % n_arrays
        source, control = edge_vertex_control(edge, n_controls)
        occupancy, descriptor = shapes[shared]
        features = ClipFeatures(
            control,
            float(kinetic[edge]),
            potential[edge],
            occupancy,
            descriptor,
            float(score[edge]),
        )
        clip = graph.add_clip(source, features)
        bank.put(clip, SimClip(control, frames[shared], frames[shared, -1]), features)
    graph.add_vertex(control=0, clip=-1)
    for edge in range(n_sim):
        graph.add_vertex(control=edge % n_controls, clip=edge)
    for edge in range(n_sim):
        graph.set_sim(edge, edge, edge + 1)
    for edge in range(n_sim, graph.n_edges):
        source, control = edge_vertex_control(edge, n_controls)
        target = control + n_controls * int(rng.integers((n_sim - 1 - control) // n_controls + 1))
        graph.set_blend(edge, edge, target, float(rng.random()))
    return graph, bank


def bench_store(
    n_edges: int = 100_000,
    database_url: str | None = None,
    distinct_bundles: int | None = None,
) -> StoreBench:
    """Seconds to save and to load a synthetic graph of ``n_edges`` edges.

    ``database_url`` must name a migrated database; by default a temporary SQLite file
    is used. The work is rolled back either way. ``distinct_bundles`` (see
    :func:`synthetic_graph`) separates the cost of creating one file per clip.
    """
    graph, bank = synthetic_graph(n_edges, distinct_bundles=distinct_bundles)
    with tempfile.TemporaryDirectory() as scratch:
        url = database_url or f"sqlite:///{Path(scratch) / 'bench.sqlite3'}"
        engine = make_engine(url)
        if database_url is None:
            Base.metadata.create_all(engine)
        artifacts = ArtifactStore(Path(scratch) / "artifacts")
        try:
            with Session(engine) as session, session.begin():
                graph_id = create_graph(
                    session,
                    name="bench-store",
                    dynamics="synthetic",
                    n_controls=graph.n_controls,
                    frames_per_clip=graph.frames_per_clip,
                )
                started = time.perf_counter()
                save_graph(session, graph_id, graph, bank, artifacts)
                session.flush()
                saved = time.perf_counter()
                load_graph(session, graph_id, artifacts, synthetic_shape)
                loaded = time.perf_counter()
                session.rollback()
        finally:
            engine.dispose()
    return StoreBench(graph.n_edges, saved - started, loaded - saved)
