"""Steps counted less where the graph has changed since they were played: which vertices
changed, how their steps are weighed, and how the weight is chosen on the latest
publication's players."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from refiner_helpers import toy_refiners

from app.core.crowd_play import PlayCounts
from app.core.fresh_evidence import (
    NO_DISCOUNT,
    changed_vertices,
    fit_fresh_evidence,
    weighted_counts,
)
from app.core.player_models import PlayerModelKind
from app.core.publication import Publication, freeze
from app.core.session_folds import held_out_score


def _chain(dst: list[list[int]], kind: list[list[int]] | None = None) -> Publication:
    """A publication of two controls whose vertex v's edges lead to ``dst[v]``."""
    edges = np.asarray(dst, dtype=np.int64).reshape(-1)
    kinds = np.zeros_like(edges) if kind is None else np.asarray(kind).reshape(-1)
    zeros = np.zeros(edges.size)
    return Publication(2, 0, edges, kinds.astype(np.int8), zeros, zeros)


#: 0 -> 1 -> 2 -> 3, each vertex's second control back to 0
THEN = _chain([[1, 0], [2, 0], [3, 0], [3, 0]])


def test_a_change_marks_its_vertex_and_those_fewer_than_depth_steps_before_it() -> None:
    # vertex 2's first control now leads to a new vertex 4
    now = _chain([[1, 0], [2, 0], [4, 0], [3, 0], [4, 4]])
    assert changed_vertices(THEN, now, 1).tolist() == [False, False, True, False]
    assert changed_vertices(THEN, now, 2).tolist() == [False, True, True, False]
    # vertex 3 reaches 2 only through 0 -> 1 -> 2: three steps from it
    assert changed_vertices(THEN, now, 3).tolist() == [True, True, True, False]
    assert changed_vertices(THEN, now, 4).tolist() == [True, True, True, True]
    # the same destination as another kind of edge (a blend made a clip) is a change too
    kind = [[0, 0], [0, 0], [0, 0], [0, 1]]
    assert changed_vertices(THEN, _chain([[1, 0], [2, 0], [3, 0], [3, 0]], kind), 1).tolist() == [
        False,
        False,
        False,
        True,
    ]
    assert not changed_vertices(THEN, THEN, 6).any()


@pytest.mark.parametrize(
    ("now", "depth", "message"),
    [
        (THEN, 0, "depth"),
        (_chain([[1, 0], [2, 0]]), 1, "cannot be compared"),
        (replace(THEN, n_controls=4), 1, "cannot be compared"),
    ],
)
def test_what_cannot_be_compared_is_refused(now: Publication, depth: int, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        changed_vertices(THEN, now, depth)


def test_steps_where_the_graph_changed_count_the_discount_by_hand() -> None:
    now = _chain([[1, 0], [2, 0], [4, 0], [3, 0], [4, 4]])
    play = PlayCounts.of_traces([np.array([[0, 0], [1, 0], [2, 0], [3, 1]])])
    later = PlayCounts.of_traces([np.array([[0, 0], [1, 0], [2, 1]])], first=1)
    played = [(THEN, play), (now, later)]
    counts = weighted_counts(played, now, 5, 0.25, 2)
    # the first session's steps at vertices 1 and 2 (changed within 2 steps) weigh 0.25,
    # the later session's all count: it was played on the graph as it is now
    expected = np.array([[2.0, 0.0], [1.25, 0.0], [0.25, 1.0], [0.0, 1.0], [0.0, 0.0]])
    np.testing.assert_allclose(counts, expected)
    np.testing.assert_array_equal(
        weighted_counts(played, now, 5, 1.0, 2),
        PlayCounts.merged([play, later]).control_counts(5, 2),
    )
    with pytest.raises(ValueError, match="discount"):
        weighted_counts(played, now, 5, 1.5, 2)


def _uniform_blend(counts: np.ndarray) -> np.ndarray:
    """A model of the counts: one pseudo-step of each control per vertex."""
    return (counts + 1.0) / (counts.sum(axis=1, keepdims=True) + counts.shape[1])


def test_the_discount_is_the_one_that_best_predicts_the_latest_publication_by_hand() -> None:
    now = _chain([[1, 0], [2, 0], [4, 0], [3, 0], [4, 4]])
    # the first players kept control 0 at vertex 2; once its edge changed, they switched
    first = PlayCounts.of_traces([np.array([[0, 0], [1, 0], [2, 0]])] * 3)
    later = PlayCounts.of_traces([np.array([[0, 0], [1, 0], [2, 1]])] * 3, first=3)
    played = [(THEN, first), (now, later)]
    fit = fit_fresh_evidence(played, _uniform_blend, 5)
    held = later.control_counts(5, 2)
    by_hand = {
        (discount, depth): held_out_score(
            _uniform_blend, weighted_counts(played[:1], now, 5, discount, depth), held
        )
        for discount in (0.0, 0.1, 0.3)
        for depth in (1, 2, 3, 6)
    }
    by_hand[(1.0, 1)] = held_out_score(_uniform_blend, first.control_counts(5, 2), held)
    assert fit.scores == pytest.approx(by_hand)
    # forgetting vertex 2's stale steps wins; the depth is the smallest that forgets them
    assert (fit.discount, fit.depth) == (0.0, 1)
    # players who went on as before keep every step
    same = PlayCounts.of_traces([np.array([[0, 0], [1, 0], [2, 0]])] * 3, first=3)
    assert fit_fresh_evidence([(THEN, first), (now, same)], _uniform_blend, 5).discount == 1.0
    # one publication's sessions (or an empty later one): nothing to choose on
    assert fit_fresh_evidence([(THEN, first)], _uniform_blend, 5) == NO_DISCOUNT
    assert fit_fresh_evidence([(THEN, first), (now, PlayCounts.none())], _uniform_blend, 5) == (
        NO_DISCOUNT
    )


def test_mixed_fresh_is_mixed_until_the_graph_changes_under_its_players() -> None:
    mixed, fresh = toy_refiners(PlayerModelKind.MIXED, PlayerModelKind.MIXED_FRESH)
    published = freeze(fresh.graph)
    first = PlayCounts.of_traces([np.array([[0, 1], [1, 1], [3, 1]]), np.array([[0, 1], [1, 1]])])
    later = PlayCounts.of_traces([np.array([[0, 2], [2, 2], [5, 2]])], first=first.sessions)
    for play in (first, later):
        mixed.learn_counts(play, published)
        fresh.learn_counts(play, published)
    # nothing changed since both were played: every discount scores alike, none is taken
    assert fresh.fresh_fit().discount == 1.0
    np.testing.assert_array_equal(fresh.player_model(), mixed.player_model())
    np.testing.assert_array_equal(fresh.weights().weights, mixed.weights().weights)
    assert fresh.shrunk_fit() == mixed.shrunk_fit()


def test_mixed_fresh_needs_every_sessions_publication() -> None:
    (fresh,) = toy_refiners(PlayerModelKind.MIXED_FRESH)
    fresh.learn([np.array([[0, 1], [1, 1]])])
    with pytest.raises(ValueError, match="mixed-fresh model needs every session's publication"):
        fresh.player_model()
