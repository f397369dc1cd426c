"""Nearly identical clips share one animation strip; a distinct clip, or a limit of 0, not."""

from __future__ import annotations

import numpy as np
import pytest
from sqlalchemy.orm import Session

from app.core.graph.clipbank import MemoryClipBank
from app.core.graph.dynamics import SimClip
from app.core.graph.state_graph import StateGraph
from app.core.graph.toy import ToyDynamics
from app.core.growth.expansion import expand_blend_edge, initial_tree
from app.services.animations import AnimationReuse, render_missing_animations
from app.services.loading import GraphContext, LoadedGraph
from app.store.animations import clip_animations, set_animations
from app.store.artifacts import ArtifactStore
from app.store.graph_catalogue import create_graph, graph_entry
from app.store.graph_persistence import save_graph

#: edge 3 (after clip 0, control 0 again) repeats clip 0; edge 6 is a clip of its own
COPY_EDGE, DISTINCT_EDGE = 3, 6


def near_copy_graph(dynamics: ToyDynamics) -> tuple[StateGraph, MemoryClipBank]:
    """The toy's tree with clip 3, a copy of clip 0, changed by one column in one frame,
    then clips 3 and 6 simulated (their edges expanded)."""
    bank = MemoryClipBank()
    graph = initial_tree(dynamics, bank)
    frames = np.array(bank.frames(0), copy=True)
    frames[5, 0] += 3 * dynamics.tank_height / 48  # three pixel rows of the toy's image
    sim = SimClip(control=0, frames=frames, end_state=bank.end_state(0))
    features = dynamics.features(sim)
    bank.put(3, sim, features)
    graph.clip_descriptor[3] = features.descriptor
    for edge in (COPY_EDGE, DISTINCT_EDGE):
        expand_blend_edge(graph, bank, dynamics, edge)
    return graph, bank


def loaded(session: Session, artifacts: ArtifactStore) -> LoadedGraph:
    dynamics = ToyDynamics()
    graph, bank = near_copy_graph(dynamics)
    graph_id = create_graph(session, name="near", dynamics="toy", n_controls=3, frames_per_clip=10)
    save_graph(session, graph_id, graph, bank, artifacts)
    context = GraphContext(graph_entry(session, graph_id), dynamics, dynamics.high_error_threshold)
    return LoadedGraph(context, graph, bank, artifacts)


@pytest.mark.parametrize("max_error", [0.05, 0.0])
def test_a_near_copy_shows_the_first_clips_strip_unless_disabled(
    session: Session, artifacts: ArtifactStore, max_error: float, monkeypatch: pytest.MonkeyPatch
) -> None:
    graph = loaded(session, artifacts)
    rendered: list[int] = []
    render = ToyDynamics.render

    def counted(self: ToyDynamics, frames: np.ndarray) -> np.ndarray:
        rendered.append(len(frames))
        return render(self, frames)

    monkeypatch.setattr(ToyDynamics, "render", counted)
    render_missing_animations(session, graph, max_error)
    strips = clip_animations(session, graph.entry.id)
    copy, distinct = (graph.graph.edge_clip[e] for e in (COPY_EDGE, DISTINCT_EDGE))
    assert sorted(strips) == [0, 1, 2, copy, distinct]
    assert (strips[copy] == strips[0]) == (max_error > 0)
    assert strips[distinct] not in {strips[c] for c in strips if c != distinct}
    blends = int(np.sum(np.asarray(graph.graph.edge_kind) == 1))
    assert len(rendered) == blends + (4 if max_error > 0 else 5)


def test_a_step_without_the_graph_finds_the_stored_strip(
    session: Session, artifacts: ArtifactStore
) -> None:
    graph = loaded(session, artifacts)
    strip = artifacts.put_bytes(b"clip 0", media_type="image/webp", session=session)
    set_animations(session, graph.entry.id, clips={0: strip})
    copy = graph.graph.edge_clip[COPY_EDGE]
    features = graph.bank.features(copy)
    for max_error, expected in ((0.05, strip), (0.0, None)):
        reuse = AnimationReuse.of_stored(
            session, artifacts, graph.dynamics, graph.entry.id, features.control, max_error
        )
        digest, found = reuse.strip(session, artifacts, features, lambda: graph.bank.frames(copy))
        assert (digest == strip) == (expected is not None)
        assert (found is not None) == (expected is not None)
        if found is not None:
            assert found.clip == 0 and found.error <= max_error
    other = (features.control + 1) % graph.graph.n_controls
    reuse = AnimationReuse.of_stored(
        session, artifacts, graph.dynamics, graph.entry.id, other, 0.05
    )
    assert reuse.animations == {}  # another control's clips are not even read
    assert reuse.substitute(features) is None


def test_a_clip_never_shows_a_later_clips_strip(session: Session, artifacts: ArtifactStore) -> None:
    graph = loaded(session, artifacts)
    copy = graph.graph.edge_clip[COPY_EDGE]
    later = artifacts.put_bytes(b"clip 3", media_type="image/webp", session=session)
    set_animations(session, graph.entry.id, clips={copy: later})
    render_missing_animations(session, graph, 0.05)
    strips = clip_animations(session, graph.entry.id)
    assert strips[copy] == later and strips[0] != later
