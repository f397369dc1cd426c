"""Evidence discounted where the choices it was about have changed (docs/player-models.md,
"`mixed-fresh`").

A player chooses a control for where it leads. A session played on an older publication
says how players chose at a vertex when its controls led elsewhere: once growth has
replaced a blend there, or anywhere a few steps on, the same players may choose otherwise
(the goal-directed crowd's 20k loss on one world in three: its players took, on the old
vertices, pairs the earlier players had not taken). Here the steps a publication's
sessions took at a vertex count in full while the graph within ``depth`` steps of it is
as they saw it, and ``discount`` times otherwise. Both are chosen, with the rest of the
model fixed, by how well the earlier publications' sessions predict the latest's. Pure
numpy.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from app.core.crowd_play import PlayCounts
from app.core.publication import Publication
from app.core.session_folds import held_out_score

#: weights of a step taken where the graph has changed since; 1.0 is ``mixed``
DISCOUNTS = (0.0, 0.1, 0.3, 1.0)
#: how many steps on from a vertex a change counts (the logit model's horizons)
DEPTHS = (1, 2, 3, 6)
#: a player model of the step weights it learns from: (V, N) weighted counts in, P(c|v) out
WeightedModel = Callable[[np.ndarray], np.ndarray]


def changed_vertices(then: Publication, now: Publication, depth: int) -> np.ndarray:
    """Bool (V_then,): whether some control at the vertex, or at a vertex fewer than
    ``depth`` steps on along ``then``'s edges, leads elsewhere in ``now`` or has become
    another kind of edge. ``now`` is the same graph later (its first vertices are
    ``then``'s)."""
    if depth < 1:
        raise ValueError(f"depth must be at least 1, got {depth}")
    if now.n_controls != then.n_controls or now.n_vertices < then.n_vertices:
        raise ValueError(
            f"a publication of {then.n_vertices} vertices cannot be compared with a later "
            f"one of {now.n_vertices} ({now.n_controls} controls against {then.n_controls})"
        )
    edges = then.edge_dst.size
    dst = then.edge_dst.reshape(-1, then.n_controls)
    moved = (now.edge_dst[:edges] != then.edge_dst) | (now.edge_kind[:edges] != then.edge_kind)
    changed = moved.reshape(-1, then.n_controls).any(axis=1)
    for _ in range(depth - 1):
        changed = changed | changed[dst].any(axis=1)
    return changed


def weighted_counts(
    played: Sequence[tuple[Publication, PlayCounts]],
    now: Publication,
    n_vertices: int,
    discount: float,
    depth: int,
) -> np.ndarray:
    """The (``n_vertices``, N) control counts of every publication's sessions, a
    vertex's steps weighed ``discount`` where :func:`changed_vertices` since then."""
    if not 0.0 <= discount <= 1.0:
        raise ValueError(f"a discount is in [0, 1], not {discount}")
    total = np.zeros((n_vertices, now.n_controls))
    for then, play in played:
        counts = play.control_counts(n_vertices, now.n_controls).astype(np.float64)
        if discount < 1.0:
            weight = np.ones(n_vertices)
            weight[: then.n_vertices][changed_vertices(then, now, depth)] = discount
            counts *= weight[:, None]
        total += counts
    return total


@dataclass(frozen=True)
class FreshFit:
    """The discount and depth chosen, and every candidate's log-likelihood per step of
    the latest publication's sessions, keyed ``(discount, depth)``."""

    discount: float
    depth: int
    scores: dict[tuple[float, int], float] = field(default_factory=dict)


#: what a model that never saw two publications' sessions keeps: every step in full
NO_DISCOUNT = FreshFit(1.0, DEPTHS[0])


def fit_fresh_evidence(
    played: Sequence[tuple[Publication, PlayCounts]],
    model: WeightedModel,
    n_vertices: int,
    *,
    discounts: Sequence[float] = DISCOUNTS,
    depths: Sequence[int] = DEPTHS,
) -> FreshFit:
    """The (discount, depth) under which ``model``, learnt from the sessions of every
    publication but the latest (changes counted against the latest), best predicts the
    latest's sessions. :data:`NO_DISCOUNT` with fewer than two publications' sessions.
    Ties go to the larger discount, then the smaller depth (the model closer to
    ``mixed``)."""
    played = [(then, play) for then, play in played if play.sessions]
    if len(played) < 2:
        return NO_DISCOUNT
    latest, play = played[-1]
    held = play.control_counts(n_vertices, latest.n_controls)
    scores: dict[tuple[float, int], float] = {}
    for discount in discounts:
        for depth in depths if discount < 1.0 else depths[:1]:
            learnt = weighted_counts(played[:-1], latest, n_vertices, discount, depth)
            scores[(float(discount), depth)] = held_out_score(model, learnt, held)
    discount, depth = max(scores, key=lambda key: (scores[key], key[0], -key[1]))
    return FreshFit(discount, depth, scores)
