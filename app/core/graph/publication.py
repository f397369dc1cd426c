"""A frozen, playable copy of a graph: what players and bots see.

Growth goes on behind a publication; a trace names the publication it was played on,
so observed errors are always read against the edges the player actually saw.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from app.core.graph.state_graph import StateGraph, edge_index


@dataclass(frozen=True)
class Publication:
    n_controls: int
    start: int
    edge_dst: np.ndarray
    edge_kind: np.ndarray
    edge_err: np.ndarray
    edge_score: np.ndarray

    @property
    def n_vertices(self) -> int:
        return len(self.edge_dst) // self.n_controls

    def destination(self, vertex: int, control: int) -> int:
        return int(self.edge_dst[edge_index(vertex, control, self.n_controls)])

    def mean_score_per_step(self, traces: list[np.ndarray]) -> float:
        """The score of the clips the traces' steps took, averaged over every step."""
        steps = np.concatenate(traces)
        return float(self.edge_score[edge_index(steps[:, 0], steps[:, 1], self.n_controls)].mean())

    def step_errors(self, steps: np.ndarray) -> np.ndarray:
        """The error of the edge each of a trace's (vertex, control) steps took."""
        steps = np.asarray(steps).reshape(-1, 2)
        return self.edge_err[edge_index(steps[:, 0], steps[:, 1], self.n_controls)]

    def follows_edges(self, steps: np.ndarray) -> bool:
        """Whether a trace (rows of vertex, control) starts anywhere valid and follows edges."""
        if steps.ndim != 2 or steps.shape[1] != 2 or len(steps) == 0:
            return False
        return self.stray_step(steps) is None

    def stray_step(self, steps: np.ndarray) -> tuple[int, str] | None:
        """The index of a trace's first step that is not a valid edge, and why; None if all are.

        ``steps`` is an (n, 2) integer array of (vertex, control) rows, n >= 1. Step i is
        wrong when its vertex or control is out of range, or when it does not start where
        step i - 1's edge leads.
        """
        v, c = steps[:, 0], steps[:, 1]
        out_of_range = (v < 0) | (v >= self.n_vertices) | (c < 0) | (c >= self.n_controls)
        leads_to = np.full(len(steps), -1, dtype=np.int64)
        valid = ~out_of_range[:-1]
        leads_to[1:][valid] = self.edge_dst[
            edge_index(v[:-1][valid], c[:-1][valid], self.n_controls)
        ]
        off_path = np.zeros(len(steps), dtype=bool)
        off_path[1:] = valid & (leads_to[1:] != v[1:])
        wrong = out_of_range | off_path
        if not wrong.any():
            return None
        i = int(np.argmax(wrong))
        vertex, control = int(v[i]), int(c[i])
        if not 0 <= vertex < self.n_vertices:
            return i, f"vertex {vertex} is not in 0..{self.n_vertices - 1}"
        if not 0 <= control < self.n_controls:
            return i, f"control {control} is not in 0..{self.n_controls - 1}"
        previous = (int(v[i - 1]), int(c[i - 1]))
        return i, f"step {i - 1}'s edge {previous} leads to vertex {leads_to[i]}, not {vertex}"


def freeze(graph: StateGraph) -> Publication:
    return Publication(
        n_controls=graph.n_controls,
        start=graph.start,
        edge_dst=np.asarray(graph.edge_dst, dtype=np.int64),
        edge_kind=np.asarray(graph.edge_kind, dtype=np.int8),
        edge_err=np.asarray(graph.edge_err, dtype=np.float64),
        edge_score=np.asarray([graph.clip_score[c] for c in graph.edge_clip], dtype=np.float64),
    )
