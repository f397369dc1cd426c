"""One edge layout, ``vertex * N + control``, for ints and arrays alike."""

from __future__ import annotations

import numpy as np

from app.core.graph.state_graph import edge_index, edge_vertex_control


def test_edge_index_and_its_inverse_agree_on_ints_and_arrays() -> None:
    vertices, controls = np.meshgrid(np.arange(7), np.arange(3), indexing="ij")
    edges = edge_index(vertices.ravel(), controls.ravel(), 3)
    assert edges.tolist() == list(range(21))  # dense, vertex-major
    back = edge_vertex_control(edges, 3)
    assert back[0].tolist() == vertices.ravel().tolist()
    assert back[1].tolist() == controls.ravel().tolist()
    assert edge_index(4, 2, 3) == 14 and edge_vertex_control(14, 3) == (4, 2)
