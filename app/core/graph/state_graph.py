"""The state graph: vertices, simulated clips, and exactly one edge per vertex and control.

Indices are dense and local to one graph: vertex ``v``, clip ``i`` and edge
``e = v * n_controls + c``. A vertex is only ever added together with its N edges
(see :mod:`app.core.growth.expansion`), so "every vertex has exactly N edges" holds by layout and
is checked by :meth:`StateGraph.check`.

The graph keeps the small per-clip columns the algorithms scan (control, energies,
score, descriptor). Bulky per-clip data (occupancy, frames, end states) lives in a
:class:`~app.core.graph.clipbank.ClipBank`.
"""

from __future__ import annotations

import bisect
from dataclasses import dataclass, field
from enum import IntEnum
from typing import Any

import numpy as np

from app.core.errors import Inconsistent
from app.core.graph.dynamics import ClipFeatures


def edge_index(vertex: Any, control: Any, n_controls: int) -> Any:
    """Edge ``vertex * N + control``: the one layout of every table of edges (a graph's, a
    publication's, a trace's steps, the stored rows), for ints, NumPy arrays and SQL
    column expressions alike."""
    return vertex * n_controls + control


def edge_vertex_control(edge: Any, n_controls: int) -> tuple[Any, Any]:
    """``(vertex, control)`` of an edge index (or an array of them): the inverse of
    :func:`edge_index`."""
    return divmod(edge, n_controls)


class EdgeKind(IntEnum):
    SIM = 0
    BLEND = 1


NO_TARGET = -1


class GraphInvariantError(Inconsistent):
    """The graph broke one of its structural invariants (a bug or a damaged store,
    never bad input)."""


@dataclass
class StateGraph:
    n_controls: int
    frames_per_clip: int
    start: int = 0
    # vertices
    vertex_control: list[int] = field(default_factory=list)
    vertex_clip: list[int] = field(default_factory=list)
    # clips
    clip_source: list[int] = field(default_factory=list)
    clip_control: list[int] = field(default_factory=list)
    clip_kinetic: list[float] = field(default_factory=list)
    clip_potential: list[np.ndarray] = field(default_factory=list)
    clip_score: list[float] = field(default_factory=list)
    clip_descriptor: list[np.ndarray] = field(default_factory=list)
    # edges, indexed by v * n_controls + c
    edge_kind: list[int] = field(default_factory=list)
    edge_clip: list[int] = field(default_factory=list)
    edge_dst: list[int] = field(default_factory=list)
    edge_target: list[int] = field(default_factory=list)
    edge_err: list[float] = field(default_factory=list)
    # derived: per control, SIM edges sorted by the energy of their clip's end state
    _sim_energy: list[list[float]] = field(default_factory=list, repr=False)
    _sim_edges: list[list[int]] = field(default_factory=list, repr=False)

    def __post_init__(self) -> None:
        if not self._sim_energy:
            self._sim_energy = [[] for _ in range(self.n_controls)]
            self._sim_edges = [[] for _ in range(self.n_controls)]

    # ---- sizes -------------------------------------------------------------
    @property
    def n_vertices(self) -> int:
        return len(self.vertex_control)

    @property
    def n_clips(self) -> int:
        return len(self.clip_control)

    @property
    def n_edges(self) -> int:
        return len(self.edge_kind)

    @property
    def size_frames(self) -> int:
        """Graph size as the paper counts it: every simulated frame, dead ends included."""
        return self.n_clips * self.frames_per_clip

    def edge_id(self, vertex: int, control: int) -> int:
        return int(edge_index(vertex, control, self.n_controls))

    def edge_source(self, edge: int) -> int:
        return int(edge_vertex_control(edge, self.n_controls)[0])

    def edge_control(self, edge: int) -> int:
        return int(edge_vertex_control(edge, self.n_controls)[1])

    def blend_edges(self) -> np.ndarray:
        return np.flatnonzero(np.asarray(self.edge_kind) == EdgeKind.BLEND)

    def clip_energy(self, clip: int, control: int) -> float:
        return float(self.clip_kinetic[clip] + self.clip_potential[clip][control])

    def vertex_descriptors(self) -> np.ndarray:
        """Descriptor of each vertex: that of the clip that produced it.

        The start vertex has no incoming clip; it takes the descriptor of its own
        level (control 0) clip, the closest thing to "the tank as it starts".
        """
        out = np.empty((self.n_vertices, len(self.clip_descriptor[0])), dtype=np.float64)
        for v, clip in enumerate(self.vertex_clip):
            source = clip if clip >= 0 else self.edge_clip[self.edge_id(v, 0)]
            out[v] = self.clip_descriptor[source]
        return out

    def edge_arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(source, control, destination) of every edge, as int64 arrays."""
        source, control = edge_vertex_control(np.arange(self.n_edges), self.n_controls)
        return source, control, np.asarray(self.edge_dst, dtype=np.int64)

    # ---- mutation (called by app.core.growth.expansion only) ----------------------------
    def add_clip(self, source: int, features: ClipFeatures) -> int:
        self.clip_source.append(source)
        self.clip_control.append(features.control)
        self.clip_kinetic.append(float(features.kinetic))
        self.clip_potential.append(np.asarray(features.potential, dtype=np.float64))
        self.clip_score.append(float(features.score))
        self.clip_descriptor.append(np.asarray(features.descriptor, dtype=np.float64).ravel())
        return self.n_clips - 1

    def add_vertex(self, control: int, clip: int) -> int:
        """Add a vertex with N placeholder edges; the caller fills every one of them."""
        self.vertex_control.append(control)
        self.vertex_clip.append(clip)
        for _ in range(self.n_controls):
            self.edge_kind.append(EdgeKind.BLEND)
            self.edge_clip.append(-1)
            self.edge_dst.append(-1)
            self.edge_target.append(NO_TARGET)
            self.edge_err.append(np.inf)
        return self.n_vertices - 1

    def set_sim(self, edge: int, clip: int, dst: int) -> None:
        if self.edge_kind[edge] == EdgeKind.SIM and self.edge_clip[edge] >= 0:
            raise GraphInvariantError(f"edge {edge} is already a SIM edge")
        self.edge_kind[edge] = EdgeKind.SIM
        self.edge_clip[edge] = clip
        self.edge_dst[edge] = dst
        self.edge_target[edge] = NO_TARGET
        self.edge_err[edge] = 0.0
        control = self.edge_control(edge)
        energy = self.clip_energy(clip, control)
        # Order by (energy, edge): equal energies (clips of a system at rest) then sit in
        # the same order however the graph was built, grown in memory or loaded, so the
        # best-target search gives the same answer on every worker.
        energies, edges = self._sim_energy[control], self._sim_edges[control]
        at = bisect.bisect_left(energies, energy)
        while at < len(energies) and energies[at] == energy and edges[at] < edge:
            at += 1
        self._sim_energy[control].insert(at, energy)
        self._sim_edges[control].insert(at, edge)

    def set_blend(self, edge: int, clip: int, target: int, err: float) -> None:
        if self.edge_kind[target] != EdgeKind.SIM:
            raise GraphInvariantError(f"blend target {target} is not a SIM edge")
        if self.edge_clip[target] == clip:
            raise GraphInvariantError(f"edge {edge} would blend clip {clip} into itself")
        self.edge_kind[edge] = EdgeKind.BLEND
        self.edge_clip[edge] = clip
        self.edge_dst[edge] = self.edge_dst[target]
        self.edge_target[edge] = target
        self.edge_err[edge] = float(err)

    # ---- queries ---------------------------------------------------------------
    def nearest_sim_edges_by_energy(self, energy: float, control: int, k: int) -> list[int]:
        """The ``k`` SIM edges of ``control`` whose end energy is closest to ``energy``.

        A two-pointer walk out from the insertion point of a sorted list: O(log n + k),
        so the energy pre-filter (paper 6.1) does not grow with the graph.
        """
        energies = self._sim_energy[control]
        edges = self._sim_edges[control]
        hi = bisect.bisect_left(energies, energy)
        lo = hi - 1
        out: list[int] = []
        while len(out) < k and (lo >= 0 or hi < len(energies)):
            take_hi = lo < 0 or (
                hi < len(energies) and energies[hi] - energy <= energy - energies[lo]
            )
            if take_hi:
                out.append(edges[hi])
                hi += 1
            else:
                out.append(edges[lo])
                lo -= 1
        return out

    def check(self) -> None:
        """Raise :class:`GraphInvariantError` unless the graph is complete and playable."""
        n = self.n_controls
        if self.n_edges != self.n_vertices * n:
            raise GraphInvariantError("edge count is not N per vertex")
        for e in range(self.n_edges):
            kind, clip, dst = self.edge_kind[e], self.edge_clip[e], self.edge_dst[e]
            if clip < 0 or not 0 <= dst < self.n_vertices:
                raise GraphInvariantError(f"edge {e} is unfilled")
            source, control = edge_vertex_control(e, n)
            if self.clip_control[clip] != control or self.clip_source[clip] != source:
                raise GraphInvariantError(f"edge {e} owns a clip of another edge")
            if kind == EdgeKind.SIM:
                if self.vertex_clip[dst] != clip:
                    raise GraphInvariantError(f"SIM edge {e} does not end at its clip's vertex")
            else:
                target = self.edge_target[e]
                if self.edge_kind[target] != EdgeKind.SIM or self.edge_control(target) != control:
                    raise GraphInvariantError(f"BLEND edge {e} has a bad target {target}")
                if self.edge_clip[target] == clip or self.edge_dst[target] != dst:
                    raise GraphInvariantError(f"BLEND edge {e} is inconsistent with {target}")
        sims = sum(len(s) for s in self._sim_edges)
        if sims != sum(1 for k in self.edge_kind if k == EdgeKind.SIM):
            raise GraphInvariantError("energy index out of step with SIM edges")
