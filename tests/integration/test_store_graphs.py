"""Saving and loading state graphs: exact round trips, incremental saves, staleness."""

from __future__ import annotations

import time

import numpy as np
import pytest
from sqlalchemy import func, select, update
from sqlalchemy.orm import Session

from app.bench.store import synthetic_graph, synthetic_shape
from app.core.graph.clipbank import ClipBank, MemoryClipBank
from app.core.graph.graph_entry import GraphScene
from app.core.graph.state_graph import EdgeKind, StateGraph
from app.core.graph.toy import ToyDynamics
from app.core.growth.expansion import best_target, expand_blend_edge, relink_all
from app.models import Clip, Edge, Graph
from app.store.animations import set_animations
from app.store.artifacts import ArtifactStore
from app.store.clipbank import MIN_SHAPE_ENTRIES, EndStateDropped, StoredClipBank
from app.store.graph_catalogue import GraphNotFound, create_graph, get_graph_row
from app.store.graph_persistence import StaleGraph, load_graph, save_graph

Toy = tuple[ToyDynamics, StateGraph, MemoryClipBank]


def new_graph(session: Session, graph: StateGraph, name: str = "tank") -> int:
    return create_graph(
        session,
        name=name,
        dynamics="toy",
        n_controls=graph.n_controls,
        frames_per_clip=graph.frames_per_clip,
        scene=GraphScene(preset="small"),
    )


def saved_and_loaded(
    session: Session, artifacts: ArtifactStore, toy: Toy
) -> tuple[int, StateGraph, StoredClipBank]:
    """The toy graph saved as a new graph, and loaded back with its stored bank."""
    dynamics, graph, bank = toy
    graph_id = new_graph(session, graph)
    save_graph(session, graph_id, graph, bank, artifacts)
    loaded, stored = load_graph(session, graph_id, artifacts, dynamics.shape)
    return graph_id, loaded, stored


def assert_same_graph(loaded: StateGraph, graph: StateGraph) -> None:
    assert loaded.n_controls == graph.n_controls
    assert loaded.frames_per_clip == graph.frames_per_clip
    for name in (
        "vertex_control", "vertex_clip", "clip_source", "clip_control", "clip_kinetic",
        "clip_score", "edge_kind", "edge_clip", "edge_dst", "edge_target", "edge_err",
    ):  # fmt: skip
        assert list(getattr(loaded, name)) == list(getattr(graph, name)), name
    np.testing.assert_array_equal(np.array(loaded.clip_potential), np.array(graph.clip_potential))
    rounded = np.array(graph.clip_descriptor).astype(np.float32).astype(np.float64)
    np.testing.assert_array_equal(np.array(loaded.clip_descriptor), rounded)
    for control in range(graph.n_controls):  # the energy index answers as before
        for energy in (0.0, 0.5, 10.0):
            assert set(loaded.nearest_sim_edges_by_energy(energy, control, 5)) == set(
                graph.nearest_sim_edges_by_energy(energy, control, 5)
            )


def assert_same_clips(bank: ClipBank, reference: ClipBank, graph: StateGraph) -> None:
    """Equal features and frames; equal end states where the clip's edge is still a blend,
    none kept where it is a simulation (no step reads it again)."""
    kinds = zip(graph.edge_clip, graph.edge_kind, strict=True)
    simulated = {c for c, kind in kinds if kind == EdgeKind.SIM}
    assert simulated and len(simulated) < graph.n_clips
    for clip in range(graph.n_clips):
        a, b = bank.features(clip), reference.features(clip)
        assert (a.control, a.kinetic, a.score) == (b.control, b.kinetic, b.score)
        np.testing.assert_array_equal(a.potential, b.potential)
        np.testing.assert_array_equal(a.occupancy, b.occupancy)
        np.testing.assert_array_equal(a.descriptor, b.descriptor)
        np.testing.assert_array_equal(bank.frames(clip), reference.frames(clip))
        if clip in simulated:
            with pytest.raises(EndStateDropped, match=f"clip {clip} ends a simulated edge"):
                bank.end_state(clip)
        else:
            np.testing.assert_array_equal(bank.end_state(clip), reference.end_state(clip))


def test_round_trip_is_exact(session: Session, artifacts: ArtifactStore, toy_graph: Toy) -> None:
    _, graph, bank = toy_graph
    graph_id = new_graph(session, graph)
    save_graph(session, graph_id, graph, bank, artifacts)
    loaded, stored = load_graph(session, graph_id, artifacts, ToyDynamics().shape)
    assert_same_graph(loaded, graph)
    assert_same_clips(stored, bank, graph)


def test_loaded_graph_grows_like_the_original(
    session: Session, artifacts: ArtifactStore, toy_graph: Toy
) -> None:
    dynamics, graph, bank = toy_graph
    graph_id, loaded, stored = saved_and_loaded(session, artifacts, toy_graph)
    for clip, control in [(graph.n_clips - 1, 2), (0, 0)]:
        assert best_target(loaded, stored, dynamics, clip, control) == best_target(
            graph, bank, dynamics, clip, control
        )


def test_incremental_saves_write_only_changes(
    session: Session, artifacts: ArtifactStore, toy_graph: Toy
) -> None:
    dynamics, graph, bank = toy_graph
    graph_id = new_graph(session, graph)
    save_graph(session, graph_id, graph, bank, artifacts)
    loaded, stored = load_graph(session, graph_id, artifacts, ToyDynamics().shape)
    first_blend = int(loaded.blend_edges()[0])
    set_animations(session, graph_id, edges={first_blend: _animation(session, artifacts)})

    # grow the loaded copy (its new clips live in the stored bank until saved) and relink
    expand_blend_edge(loaded, stored, dynamics, first_blend)
    expand_blend_edge(loaded, stored, dynamics, int(loaded.blend_edges()[-1]))
    relink_all(loaded, stored, dynamics)
    save_graph(session, graph_id, loaded, stored, artifacts)
    # and a third save after more mutation of the same object
    expand_blend_edge(loaded, stored, dynamics, int(loaded.blend_edges()[0]))
    save_graph(session, graph_id, loaded, stored, artifacts)

    again, bank_again = load_graph(session, graph_id, artifacts, ToyDynamics().shape)
    assert_same_graph(again, loaded)
    assert_same_clips(bank_again, stored, loaded)
    animation = session.scalar(
        select(Edge.animation).where(
            Edge.graph_id == graph_id,
            Edge.vertex == first_blend // graph.n_controls,
            Edge.control == first_blend % graph.n_controls,
        )
    )
    assert animation is None  # the expanded edge's blend animation no longer applies
    assert get_graph_row(session, graph_id).revision == 3


def test_a_save_after_a_rollback_is_refused(
    session: Session, artifacts: ArtifactStore, toy_graph: Toy
) -> None:
    dynamics, graph, bank = toy_graph
    graph_id = new_graph(session, graph)
    save_graph(session, graph_id, graph, bank, artifacts)
    # someone else saved (or this save's transaction rolled back): revisions disagree
    session.execute(update(Graph).where(Graph.id == graph_id).values(revision=7))
    expand_blend_edge(graph, bank, dynamics, int(graph.blend_edges()[0]))
    edges_before = session.scalar(select(func.count()).select_from(Edge))
    with pytest.raises(StaleGraph):
        save_graph(session, graph_id, graph, bank, artifacts)
    assert session.scalar(select(func.count()).select_from(Edge)) == edges_before


def test_a_fresh_graph_object_cannot_overwrite_a_saved_graph(
    session: Session, artifacts: ArtifactStore, toy_graph: Toy
) -> None:
    _, graph, bank = toy_graph
    graph_id = new_graph(session, graph)
    save_graph(session, graph_id, graph, bank, artifacts)
    copy = StateGraph(**{k: v for k, v in vars(graph).items()})
    with pytest.raises(StaleGraph):
        save_graph(session, graph_id, copy, bank, artifacts)


def test_graph_lookup_by_name_or_id(session: Session, toy_graph: Toy) -> None:
    graph_id = new_graph(session, toy_graph[1], name="lookup")
    assert get_graph_row(session, "lookup").id == graph_id
    assert get_graph_row(session, graph_id).name == "lookup"
    assert get_graph_row(session, str(graph_id)).name == "lookup"
    with pytest.raises(GraphNotFound):
        get_graph_row(session, "no-such-graph")
    with pytest.raises(GraphNotFound):
        get_graph_row(session, graph_id + 1000)


@pytest.mark.slow
def test_100k_edge_round_trip_is_exact(session: Session, artifacts: ArtifactStore) -> None:
    graph, bank = synthetic_graph(100_000, distinct_bundles=64)
    graph_id = new_graph(session, graph, name="big")
    started = time.perf_counter()
    save_graph(session, graph_id, graph, bank, artifacts)
    session.flush()
    saved = time.perf_counter()
    loaded, _ = load_graph(session, graph_id, artifacts, synthetic_shape)
    loaded_at = time.perf_counter()
    print(f"100k edges: save {saved - started:.2f} s, load {loaded_at - saved:.2f} s")
    assert loaded.n_edges == graph.n_edges == 99_999
    assert_same_graph(loaded, graph)


def _animation(session: Session, artifacts: ArtifactStore) -> str:
    return artifacts.put_bytes(b"\x00mp4", media_type="video/mp4", session=session)


def test_the_shape_cache_holds_what_its_byte_budget_allows(
    session: Session, artifacts: ArtifactStore, toy_graph: Toy
) -> None:
    _, graph, bank = toy_graph
    graph_id = new_graph(session, graph)
    save_graph(session, graph_id, graph, bank, artifacts)
    shape = bank.features(0)
    per_clip = shape.occupancy.nbytes + np.asarray(shape.descriptor).nbytes
    for budget, entries in ((1_000 * per_clip, 1_000), (1, MIN_SHAPE_ENTRIES)):
        _, stored = load_graph(
            session, graph_id, artifacts, ToyDynamics().shape, shape_cache_bytes=budget
        )
        assert_same_clips(stored, bank, graph)
        cache = stored._shape_members
        assert cache is not None and cache.cache_info().maxsize == entries  # type: ignore[attr-defined]


def test_an_expanded_clip_is_rewritten_without_its_end_state(
    session: Session, artifacts: ArtifactStore, toy_graph: Toy
) -> None:
    dynamics, graph, bank = toy_graph
    graph_id, loaded, stored = saved_and_loaded(session, artifacts, toy_graph)
    edge = int(loaded.blend_edges()[0])
    clip = loaded.edge_clip[edge]

    def bundle() -> dict[str, np.ndarray]:
        digest = session.scalar(
            select(Clip.bundle).where(Clip.graph_id == graph_id, Clip.idx == clip)
        )
        return artifacts.get_arrays(str(digest))

    before = bundle()
    assert set(before) == {"frames", "end_state"}  # a blend's clip: expanded from its state
    expand_blend_edge(loaded, stored, dynamics, edge)
    save_graph(session, graph_id, loaded, stored, artifacts)
    after = bundle()
    assert set(after) == {"frames"}
    np.testing.assert_array_equal(after["frames"], before["frames"])
    with pytest.raises(EndStateDropped):
        stored.end_state(clip)
    new_clips = range(graph.n_clips, loaded.n_clips)  # the expansion's clips end on blends
    assert all(stored.end_state(c).size for c in new_clips)
