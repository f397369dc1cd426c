"""Who plays an experiment's runs (app.services.experiment.players): labels, fresh judges
and the shares a pooled crowd is split by, kept exactly in whole sessions.

tests/unit/test_study.py holds the shares through :class:`ExperimentPlan`; here the
module's own functions are held to their docstrings, float shares that are not exact in
binary included.
"""

from __future__ import annotations

import math

import pytest

from app.core.errors import InvalidInput
from app.core.players.kinds import BotKind
from app.services.experiment.players import (
    FRESH,
    POPULATION,
    PlayerGroup,
    check_shares,
    kind_of,
    share_sessions,
)


@pytest.mark.parametrize(
    ("label", "kind"),
    [
        ("goal-directed", "goal-directed"),
        (f"{FRESH}goal-directed", "goal-directed"),
        (f"{FRESH}{POPULATION}", POPULATION),
        ("random", "random"),
    ],
)
def test_a_label_names_its_kind_and_a_fresh_judge_its_crowds(label: str, kind: str) -> None:
    assert kind_of(label) == kind


def test_only_a_fresh_label_marks_a_fresh_judge() -> None:
    crowd = PlayerGroup("hesitant", BotKind.HESITANT, 10, stored=True)
    fresh = PlayerGroup(f"{FRESH}hesitant", BotKind.HESITANT, 10, stored=False)
    judge = PlayerGroup("random", BotKind.RANDOM, 10, stored=False)
    assert (crowd.fresh, fresh.fresh, judge.fresh) == (False, True, False)
    # "fresh" inside a label is not its prefix
    assert not PlayerGroup("not-fresh-hesitant", BotKind.HESITANT, 1, stored=False).fresh


@pytest.mark.parametrize(
    ("shares", "sessions", "whole"),
    [
        ((0.5, 0.3, 0.2), 10, [5, 3, 2]),
        # 0.57 * 100 is 56.99999999999999 in binary: the share meant is 57 sessions
        ((0.57, 0.43), 100, [57, 43]),
        # 0.7 + 0.2 + 0.1 sums to 0.9999999999999999 in binary
        ((0.7, 0.2, 0.1), 10, [7, 2, 1]),
        ((1.0,), 7, [7]),
    ],
)
def test_shares_that_give_whole_sessions_are_kept_exactly(
    shares: tuple[float, ...], sessions: int, whole: list[int]
) -> None:
    check_shares(shares, len(shares), sessions, pooled=True)
    split = [share_sessions(share, sessions) for share in shares]
    assert split == whole and sum(split) == sessions


@pytest.mark.parametrize(
    ("shares", "crowds", "sessions", "pooled", "fragment"),
    [
        ((0.5, 0.5), 2, 10, False, "one share per crowd of pooled crowds (--pooled)"),
        ((0.5, 0.5), 3, 10, True, "one share per crowd of pooled crowds"),
        ((0.5, 0.6), 2, 10, True, "shares must be positive and sum to 1, got 0.5, 0.6"),
        ((1.2, -0.2), 2, 10, True, "shares must be positive and sum to 1, got 1.2, -0.2"),
        ((1.0, 0.0), 2, 10, True, "shares must be positive and sum to 1, got 1, 0"),
        ((0.5, 0.5), 2, 7, True, "a share of 0.5 of 7 sessions is not a whole number"),
        ((0.25, 0.75), 2, 10, True, "a share of 0.25 of 10 sessions is not a whole number"),
    ],
)
def test_shares_that_would_not_keep_the_mix_are_refused(
    shares: tuple[float, ...], crowds: int, sessions: int, pooled: bool, fragment: str
) -> None:
    with pytest.raises(InvalidInput) as refused:
        check_shares(shares, crowds, sessions, pooled=pooled)
    assert fragment in str(refused.value)


@pytest.mark.parametrize("shares", [(math.nan, 1.0), (0.5, math.nan)], ids=["first", "last"])
def test_a_share_that_is_no_number_is_refused(shares: tuple[float, ...]) -> None:
    with pytest.raises(InvalidInput, match="shares must be positive and sum to 1"):
        check_shares(shares, 2, 10, pooled=True)
