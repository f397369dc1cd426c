"""Building and growing a state graph (paper 3, 6.1; docs/design.md, "Graph algorithms").

An expansion is split in two so that a distributed runtime can fan out the expensive
part: :func:`expansion_start_state` names the state to simulate from (workers simulate
the N clips), and :func:`integrate_expansion` swaps the results in at once. Until then
the BLEND edge being expanded stays playable, so the graph is always complete.
"""

from __future__ import annotations

import heapq
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from app.core.errors import InvalidInput
from app.core.graph.clipbank import ClipBank
from app.core.graph.dynamics import ClipFeatures, Dynamics, SimClip
from app.core.graph.state_graph import EdgeKind, StateGraph


@dataclass(frozen=True)
class GrowthBudget:
    """How much to grow: a number of expansions, or a size in simulated frames to reach.

    Frames to add are a size to reach from where growth starts (:meth:`of`); since an
    expansion adds ``n_controls`` clips at once, growth by frames stops at the first
    expansion that reaches the size.
    """

    expansions: int | None = None
    to_frames: int | None = None

    @staticmethod
    def check(
        *, frames: int | None = None, expansions: int | None = None, to_frames: int | None = None
    ) -> None:
        """Refuse anything but one positive budget (before any growth starts)."""
        if sum(b is not None for b in (frames, expansions, to_frames)) != 1:
            raise InvalidInput("give exactly one budget: frames, expansions or a size to reach")
        if any(b is not None and b <= 0 for b in (frames, expansions, to_frames)):
            raise InvalidInput("the growth budget must be positive")

    @classmethod
    def of(
        cls,
        size_frames: int,
        *,
        frames: int | None = None,
        expansions: int | None = None,
        to_frames: int | None = None,
    ) -> GrowthBudget:
        """The budget of growth starting at ``size_frames`` (see :meth:`check`)."""
        cls.check(frames=frames, expansions=expansions, to_frames=to_frames)
        if frames is not None:
            return cls(to_frames=size_frames + frames)
        return cls(expansions=expansions, to_frames=to_frames)

    def left(self, size_frames: int, expanded: int, per_expansion: int) -> int:
        """Expansions still to make once ``expanded`` grew the graph to ``size_frames``."""
        if self.to_frames is not None:
            return -(-(self.to_frames - size_frames) // per_expansion)
        assert self.expansions is not None
        return self.expansions - expanded


class NoBlendTarget(LookupError):
    """No SIM edge of the control exists to blend into (the tree is too shallow)."""


@dataclass(frozen=True)
class BlendTarget:
    edge: int
    err: float


def best_target(
    graph: StateGraph,
    bank: ClipBank,
    dynamics: Dynamics,
    clip: int,
    control: int,
    *,
    prefilter_k: int = 100,
) -> BlendTarget:
    """The SIM edge of ``control`` that clip ``clip`` blends into with the least ``dist``.

    Only the ``prefilter_k`` SIM edges closest in end energy are fully compared (the
    paper's energy pre-filter); a clip is never blended into itself.
    """
    source = bank.features(clip)
    candidates = graph.nearest_sim_edges_by_energy(source.energy(control), control, prefilter_k + 1)
    best = BlendTarget(edge=-1, err=np.inf)
    for edge in candidates:
        target_clip = graph.edge_clip[edge]
        if target_clip == clip:
            continue
        err = dynamics.dist(source, bank.features(target_clip), control)
        if err < best.err:
            best = BlendTarget(edge=edge, err=err)
    if best.edge < 0:
        raise NoBlendTarget(f"no SIM edge of control {control} to blend clip {clip} into")
    return best


def simulate_clips(
    dynamics: Dynamics, state: np.ndarray, controls: Sequence[int]
) -> list[tuple[SimClip, ClipFeatures]]:
    """The clips of ``controls`` from ``state``, simulated together, with their features."""
    sims = dynamics.simulate_many([state] * len(controls), controls)
    return [(sim, dynamics.features(sim)) for sim in sims]


def initial_tree_clips(n_controls: int, depth: int) -> int:
    """Clips :func:`initial_tree` simulates: N + N^2 + ... + N^depth."""
    return sum(n_controls**level for level in range(1, depth + 1))


def initial_tree(
    dynamics: Dynamics,
    bank: ClipBank,
    *,
    depth: int = 2,
    prefilter_k: int = 100,
    progress: Callable[[int], None] | None = None,
    world: int | None = None,
) -> StateGraph:
    """A complete N-ary simulation tree of ``depth`` levels whose leaves are blended back.

    Depth 2 gives N interior SIM edges and N^2 BLEND edges (paper Fig. 3, left/centre).
    The tree starts from ``dynamics.initial_state(world)``: a world seed's start state,
    the canonical one when None.
    ``progress(1)`` follows each of its :func:`initial_tree_clips`: at the paper's
    resolution they take minutes.
    """
    if depth < 2:
        raise ValueError("the initial tree needs depth >= 2 so that leaves have SIM targets")
    n = dynamics.n_controls
    graph = StateGraph(n_controls=n, frames_per_clip=dynamics.frames_per_clip)
    frontier = [(graph.add_vertex(control=0, clip=-1), dynamics.initial_state(world))]
    leaves: list[tuple[int, int]] = []
    for level in range(depth):
        next_frontier = []
        for vertex, state in frontier:
            for control, (sim, features) in enumerate(simulate_clips(dynamics, state, range(n))):
                clip = graph.add_clip(vertex, features)
                bank.put(clip, sim, features)
                if progress is not None:
                    progress(1)
                edge = graph.edge_id(vertex, control)
                if level < depth - 1:
                    child = graph.add_vertex(control, clip)
                    graph.set_sim(edge, clip, child)
                    next_frontier.append((child, sim.end_state))
                else:
                    leaves.append((edge, clip))
        frontier = next_frontier
    for edge, clip in leaves:
        target = best_target(
            graph, bank, dynamics, clip, graph.edge_control(edge), prefilter_k=prefilter_k
        )
        graph.set_blend(edge, clip, target.edge, target.err)
    return graph


def expansion_start_state(graph: StateGraph, bank: ClipBank, edge: int) -> np.ndarray:
    """The state the N new clips of an expansion of BLEND ``edge`` start from."""
    if graph.edge_kind[edge] != EdgeKind.BLEND:
        raise ValueError(f"edge {edge} is not a BLEND edge")
    return bank.end_state(graph.edge_clip[edge])


@dataclass(frozen=True)
class Expansion:
    edge: int
    vertex: int
    clips: tuple[int, ...]
    blends: tuple[int, ...]


def integrate_expansion(
    graph: StateGraph,
    bank: ClipBank,
    dynamics: Dynamics,
    edge: int,
    clips: Sequence[tuple[SimClip, ClipFeatures]],
    *,
    prefilter_k: int = 100,
) -> Expansion:
    """Turn BLEND ``edge`` into a SIM edge to a new vertex whose N clips are blended.

    ``clips[c]`` must be the clip simulated under control ``c`` from
    :func:`expansion_start_state`. All changes happen here, together.
    """
    if len(clips) != graph.n_controls or any(s.control != c for c, (s, _) in enumerate(clips)):
        raise ValueError("an expansion needs exactly one clip per control, in control order")
    dead_end = graph.edge_clip[edge]
    if graph.edge_kind[edge] != EdgeKind.BLEND:
        raise ValueError(f"edge {edge} is not a BLEND edge")
    vertex = graph.add_vertex(graph.edge_control(edge), dead_end)
    graph.set_sim(edge, dead_end, vertex)
    new_clips = []
    for sim, features in clips:
        clip = graph.add_clip(vertex, features)
        bank.put(clip, sim, features)
        new_clips.append(clip)
    blends = []
    for control, clip in enumerate(new_clips):
        target = best_target(graph, bank, dynamics, clip, control, prefilter_k=prefilter_k)
        blend_edge = graph.edge_id(vertex, control)
        graph.set_blend(blend_edge, clip, target.edge, target.err)
        blends.append(blend_edge)
    return Expansion(edge=edge, vertex=vertex, clips=tuple(new_clips), blends=tuple(blends))


def expand_blend_edge(
    graph: StateGraph, bank: ClipBank, dynamics: Dynamics, edge: int, *, prefilter_k: int = 100
) -> Expansion:
    """Simulate and integrate one expansion in-process (the eager path)."""
    state = expansion_start_state(graph, bank, edge)
    clips = simulate_clips(dynamics, state, range(graph.n_controls))
    return integrate_expansion(graph, bank, dynamics, edge, clips, prefilter_k=prefilter_k)


def relink_blend_edge(
    graph: StateGraph, bank: ClipBank, dynamics: Dynamics, edge: int, *, prefilter_k: int = 100
) -> bool:
    """Search ``edge``'s best target again; relink and return True if it is strictly better."""
    clip = graph.edge_clip[edge]
    target = best_target(
        graph, bank, dynamics, clip, graph.edge_control(edge), prefilter_k=prefilter_k
    )
    if target.err < graph.edge_err[edge] and target.edge != graph.edge_target[edge]:
        graph.set_blend(edge, clip, target.edge, target.err)
        return True
    return False


def relink_all(
    graph: StateGraph, bank: ClipBank, dynamics: Dynamics, *, prefilter_k: int = 100
) -> list[int]:
    """Pre-publish relinking: give every BLEND edge the best target the graph now has."""
    return [
        int(edge)
        for edge in graph.blend_edges()
        if relink_blend_edge(graph, bank, dynamics, int(edge), prefilter_k=prefilter_k)
    ]


@dataclass
class EpochOutcome:
    expanded: list[int] = field(default_factory=list)
    relinked: list[int] = field(default_factory=list)


def select_for_expansion(
    graph: StateGraph,
    weights: np.ndarray,
    count: int,
    relink: Callable[[int], bool],
) -> EpochOutcome:
    """Pop BLEND edges by priority ``weights[e] * err[e]``, relinking each lazily first:
    growth minimises the expected error per step (the paper's).

    A relinked edge goes back into the queue with its new priority instead of being
    simulated (paper 6.1); the outcome lists the edges to expand, best first.
    """
    w, err = np.asarray(weights), graph.edge_err
    # an entry is stale once its edge was relinked after it was queued
    relinks: dict[int, int] = {}
    queue = [(-float(w[e] * err[e]), int(e), 0) for e in graph.blend_edges()]
    heapq.heapify(queue)
    outcome = EpochOutcome()
    while len(outcome.expanded) < count and queue:
        _, edge, stamp = heapq.heappop(queue)
        if stamp != relinks.get(edge, 0):
            continue
        if relink(edge):
            outcome.relinked.append(edge)
            relinks[edge] = stamp + 1
            heapq.heappush(queue, (-float(w[edge] * err[edge]), edge, stamp + 1))
        else:
            outcome.expanded.append(edge)
    return outcome
