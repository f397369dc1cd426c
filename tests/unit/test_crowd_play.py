"""The crowd's play summed: the same counts, folds and median as the sessions themselves."""

from __future__ import annotations

import numpy as np
import pytest

from app.core.players.crowd_play import FOLD_BUCKETS, PlayCounts
from app.core.players.player_models import observed_control_counts
from app.core.players.session_folds import SessionFolds


def sessions(seed: int, count: int, n_vertices: int = 12) -> list[np.ndarray]:
    rng = np.random.default_rng(seed)
    return [
        np.column_stack([rng.integers(0, n_vertices, size=n), rng.integers(0, 3, size=n)]).astype(
            np.int64
        )
        for n in rng.integers(0, 9, size=count)  # some empty: not sessions
    ]


@pytest.mark.parametrize("count", [1, 2, 3, 4, 5, 7, FOLD_BUCKETS + 13])
@pytest.mark.parametrize("folds", [2, 3, 5])
def test_folds_of_the_sums_are_the_folds_of_sessions_dealt_in_turn(count: int, folds: int) -> None:
    traces = sessions(count, count)
    played = [t for t in traces if len(t)]
    if not played:
        pytest.skip("no session drawn")
    n_folds = max(2, min(folds, len(played)))
    dealt = [observed_control_counts(played[i::n_folds], 12, 3) for i in range(n_folds)]
    summed = SessionFolds.of(PlayCounts.of_traces(traces), 12, 3, folds)
    assert len(summed.fold_counts) == n_folds
    for ours, theirs in zip(summed.fold_counts, dealt, strict=True):
        assert ours.dtype == theirs.dtype
        np.testing.assert_array_equal(ours, theirs)
    np.testing.assert_array_equal(
        PlayCounts.of_traces(traces).control_counts(12, 3), observed_control_counts(traces, 12, 3)
    )


def test_sums_learnt_in_parts_number_their_sessions_on() -> None:
    traces = sessions(4, 70)
    first = PlayCounts.of_traces(traces[:30])
    rest = PlayCounts.of_traces(traces[30:], first=first.sessions)
    whole, parted = PlayCounts.of_traces(traces), PlayCounts.merged([first, rest])
    assert parted.sessions == whole.sessions
    for a, b in zip(parted.fold_counts(5, 12, 3), whole.fold_counts(5, 12, 3), strict=True):
        np.testing.assert_array_equal(a, b)
    # numbered from 0 again, the second part's sessions land in other folds
    restarted = PlayCounts.merged([first, PlayCounts.of_traces(traces[30:])])
    assert not all(
        np.array_equal(a, b)
        for a, b in zip(restarted.fold_counts(5, 12, 3), whole.fold_counts(5, 12, 3), strict=True)
    )


@pytest.mark.parametrize("lengths", [[5], [3, 8], [4, 4, 9], [1, 2, 2, 7, 100, 3], [6, 2] * 9])
def test_the_median_length_is_numpys(lengths: list[int]) -> None:
    traces = [np.zeros((n, 2), dtype=np.int64) for n in lengths]
    halves = PlayCounts.merged(
        [PlayCounts.of_traces(traces[::2]), PlayCounts.of_traces(traces[1::2])]
    )
    assert halves.median_length() == float(np.median(lengths))
    assert PlayCounts.none().median_length() is None


def test_folds_that_do_not_divide_the_buckets_and_stray_steps_are_refused() -> None:
    play = PlayCounts.of_traces([np.array([[0, 1], [5, 2]])])
    with pytest.raises(ValueError, match="divide"):
        play.fold_counts(7, 6, 3)
    with pytest.raises(ValueError, match="vertex outside"):
        play.control_counts(5, 3)
    with pytest.raises(ValueError, match="buckets"):
        PlayCounts(*(np.array([n]) for n in (FOLD_BUCKETS, 0, 0, 1, 1, 1)))
