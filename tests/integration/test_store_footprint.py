"""A graph's footprint counts each artifact once, by the kind of edge that shows it."""

from __future__ import annotations

import numpy as np
from sqlalchemy import func, select
from sqlalchemy.orm import Session

from app.core.graph.clipbank import MemoryClipBank
from app.core.graph.state_graph import EdgeKind, StateGraph
from app.core.graph.toy import ToyDynamics
from app.models import Artifact, Clip
from app.store.animations import set_animations
from app.store.artifacts import ArtifactStore
from app.store.footprint import graph_footprint
from app.store.graph_catalogue import create_graph
from app.store.graph_persistence import save_graph

Toy = tuple[ToyDynamics, StateGraph, MemoryClipBank]


def test_shared_strips_count_once_and_as_the_clips(
    session: Session, artifacts: ArtifactStore, toy_graph: Toy
) -> None:
    _, graph, bank = toy_graph
    graph_id = create_graph(session, name="bytes", dynamics="toy", n_controls=3, frames_per_clip=10)
    save_graph(session, graph_id, graph, bank, artifacts)
    own, shared, blend, unshown = (
        artifacts.put_bytes(data, media_type="video/x-ivf", session=session)
        for data in (b"a" * 100, b"b" * 30, b"c" * 7, b"d" * 11)
    )
    sim_edge = int(np.flatnonzero(np.asarray(graph.edge_kind) == EdgeKind.SIM)[0])
    first_blend, second_blend = graph.blend_edges()[:2]
    assert graph.edge_kind[graph.edge_clip.index(0)] == EdgeKind.SIM
    blend_clip = graph.edge_clip[int(second_blend)]
    set_animations(session, graph_id, clips={0: own, blend_clip: unshown}, edges={sim_edge: shared})
    set_animations(session, graph_id, edges={int(first_blend): shared, int(second_blend): blend})
    session.flush()

    footprint = graph_footprint(session, graph_id)
    bundles = session.scalar(
        select(func.sum(Artifact.size)).where(
            Artifact.hash.in_(select(Clip.bundle).where(Clip.graph_id == graph_id).distinct())
        )
    )
    assert footprint.bundle_bytes == bundles > 0
    assert (footprint.sim_strip_bytes, footprint.blend_strip_bytes) == (141, 7)
    assert footprint.unshown_strip_bytes == 11  # a clip's own strip while its edge blends
    assert footprint.clips == graph.n_clips and footprint.vertices == graph.n_vertices
    assert footprint.sim_edges + footprint.blend_edges == graph.n_edges
    assert footprint.blend_edges == len(graph.blend_edges())
    descriptors = sum(
        np.asarray(graph.clip_descriptor[c], np.float32).nbytes
        + np.asarray(graph.clip_potential[c], np.float64).nbytes
        for c in range(graph.n_clips)
    )
    assert footprint.array_column_bytes == descriptors
