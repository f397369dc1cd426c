"""Where players met error, by the age of the blend they met it on.

Growth that follows a crowd moves the graph's frontier along that crowd's route, and
the next crowd plans on the grown graph: it may meet its error on blends growth has
just made, on old blends the last crowd also took, or on old blends nobody took before
(docs/experiment.md, "Where the error lay"). The split needs only what a checkpoint
stores: the published edges, the observed and predicted share of play per edge, and the
earlier checkpoint's observed play. Vertices are only ever appended, so edge
``v * N + c`` of an earlier publication is the same edge in a later one.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from app.core.graph.state_graph import EdgeKind

#: the three parts, in the order reports print them
PARTS = ("new", "old_taken", "old_untaken")


@dataclass(frozen=True)
class ErrorOrigin:
    """Error per step, observed and predicted, on the three kinds of blend.

    ``new``: blends leaving a vertex added since the earlier checkpoint; ``old_taken``:
    blends of older vertices that the earlier checkpoint's players took at least once;
    ``old_untaken``: the other blends of older vertices. Each observed part is that
    part's share of the steps times their mean error, so the three sum to the mean error
    per step; the predicted parts are the same sums under the predicted share of play.
    """

    observed: dict[str, float]
    predicted: dict[str, float]
    #: blends whose error is above ``large``, and the share of the observed error met on them
    large_blends: int
    large_share: float

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


def error_origin(
    edge_kind: np.ndarray,
    edge_err: np.ndarray,
    observed: np.ndarray,
    predicted: np.ndarray,
    earlier_observed: np.ndarray,
    n_controls: int,
    large: float,
) -> ErrorOrigin:
    """Split the error of one checkpoint's play (:class:`ErrorOrigin`); count the blends
    with an error above ``large``, where a few blends can hold most of it.

    ``edge_kind``, ``edge_err``, ``observed`` and ``predicted`` are per edge of the
    checkpoint's publication (shares of play summing to one); ``earlier_observed`` is the
    observed share of play per edge of the earlier checkpoint's publication, whose edges
    are a prefix of these.
    """
    kind = np.asarray(edge_kind)
    n_edges = kind.size
    arrays = [np.asarray(a, dtype=np.float64) for a in (edge_err, observed, predicted)]
    if any(a.shape != (n_edges,) for a in arrays):
        raise ValueError(f"edge arrays must all have {n_edges} entries")
    earlier = np.asarray(earlier_observed, dtype=np.float64)
    if earlier.ndim != 1 or earlier.size > n_edges or earlier.size % n_controls:
        raise ValueError(
            f"the earlier publication's {earlier.size} edges are not a prefix of {n_edges} "
            f"edges of {n_controls} controls"
        )
    err, seen, expected = arrays
    blend = kind == EdgeKind.BLEND
    old = np.arange(n_edges) < earlier.size
    taken = np.zeros(n_edges, dtype=bool)
    taken[: earlier.size] = earlier > 0.0
    masks = {
        "new": blend & ~old,
        "old_taken": blend & taken,
        "old_untaken": blend & old & ~taken,
    }
    met = seen * err
    big = blend & (err > large)
    total = float(met.sum())
    return ErrorOrigin(
        observed={part: float(met[m].sum()) for part, m in masks.items()},
        predicted={part: float((expected * err)[m].sum()) for part, m in masks.items()},
        large_blends=int(big.sum()),
        large_share=float(met[big].sum()) / total if total > 0.0 else 0.0,
    )
