"""Figures over sessions: their standard error, the rule that flags too few sessions, and
whose sessions they are (people, bots or all)."""

from __future__ import annotations

import numpy as np
import pytest

from app.core.errors import InvalidInput
from app.core.evaluation.session_figures import (
    MAX_RELATIVE_SE,
    MIN_SESSIONS,
    SessionFigure,
    SessionLengths,
)
from app.core.players.kinds import PlayerKind, PlayerSelection, parse_player_selection


def sessions(n: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Per-session error totals and step counts of ``n`` sessions of a noisy crowd."""
    rng = np.random.default_rng(seed)
    steps = rng.integers(20, 200, size=n)
    return rng.exponential(0.01, size=n) * steps, steps


def test_a_figure_is_its_ratio_of_totals_with_a_seeded_error_over_sessions() -> None:
    totals, steps = sessions(40)
    figure = SessionFigure.over_sessions(totals, steps)
    assert figure.value == pytest.approx(totals.sum() / steps.sum())
    assert figure.sessions == 40 and figure.relative_se is not None
    assert SessionFigure.over_sessions(totals, steps) == figure  # the same every time
    many = SessionFigure.over_sessions(*sessions(1600))
    assert many.relative_se is not None
    # the standard error falls as one over the square root of the sessions (40 x: ~6 x)
    assert 3 < figure.relative_se / many.relative_se < 12


def test_a_plain_mean_over_sessions_has_the_textbook_standard_error() -> None:
    lengths = np.random.default_rng(1).geometric(1 / 90, size=400).astype(float)
    figure = SessionFigure.over_sessions(lengths, np.ones_like(lengths))
    textbook = lengths.std(ddof=1) / np.sqrt(len(lengths)) / lengths.mean()
    assert figure.relative_se == pytest.approx(textbook, rel=0.15)


def test_what_cannot_be_told_is_none() -> None:
    assert SessionFigure.over_sessions([], []) == SessionFigure(None, 0, None)
    assert SessionFigure.over_sessions([0.5], [10]) == SessionFigure(0.05, 1, None)
    assert SessionFigure.over_sessions([0.0, 0.0], [5, 9]) == SessionFigure(0.0, 2, None)


@pytest.mark.parametrize(
    ("figure", "too_few", "needed"),
    [
        (SessionFigure(0.01, MIN_SESSIONS - 1, 0.05), True, MIN_SESSIONS),  # too few to judge
        (SessionFigure(0.01, 4, None), True, MIN_SESSIONS),
        (SessionFigure(0.01, 30, MAX_RELATIVE_SE), False, 30),
        (SessionFigure(0.01, 30, 2 * MAX_RELATIVE_SE), True, 120),  # 4 x the sessions
        (SessionFigure(0.0, 30, None), False, MIN_SESSIONS),  # nobody met an error
        (SessionFigure(0.01, 20, 0.1), False, MIN_SESSIONS),
    ],
)
def test_a_figure_rests_on_too_few_sessions_below_nine_or_over_a_quarter(
    figure: SessionFigure, too_few: bool, needed: int
) -> None:
    assert figure.too_few_sessions is too_few
    assert figure.sessions_needed == needed


def test_session_lengths_are_summarised_with_nearest_rank_percentiles() -> None:
    lengths = SessionLengths.of([10, 2, 4])
    assert (lengths.sessions, lengths.min, lengths.max) == (3, 2, 10)
    assert lengths.mean == pytest.approx(16 / 3)
    assert lengths.percentiles == {"p50": 4, "p90": 10, "p99": 10}
    assert lengths.mean_figure.too_few_sessions
    hundred = SessionLengths.of(range(1, 101))
    assert hundred.percentiles == {"p50": 50, "p90": 90, "p99": 99}
    assert SessionLengths.of([]) == SessionLengths(0, None, None, None, None, {})


def test_players_are_chosen_by_kind() -> None:
    assert PlayerSelection.PEOPLE.kinds == (PlayerKind.PERSON,)
    assert PlayerSelection.BOTS.kinds == (PlayerKind.BOT,)
    assert set(PlayerSelection.ALL.kinds) == set(PlayerKind)
    assert parse_player_selection("people") is PlayerSelection.PEOPLE
    with pytest.raises(InvalidInput, match=r"unknown players 'humans' \(known: people"):
        parse_player_selection("humans")
