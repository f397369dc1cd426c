"""Traces built by hand for tests that need a session no bot would play."""

from __future__ import annotations

import numpy as np

from app.core.graph.publication import Publication


def looping_trace(publication: Publication, control: int, steps: int) -> np.ndarray:
    """A session that holds one control for ``steps`` steps: it ends up circling a loop."""
    trace = np.empty((steps, 2), dtype=np.int64)
    vertex = publication.start
    for step in range(steps):
        trace[step] = vertex, control
        vertex = publication.destination(vertex, control)
    return trace
