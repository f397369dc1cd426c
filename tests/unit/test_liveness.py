"""What of an epoch's missing work counts as unheld: the rule the workers' watchdog applies."""

from __future__ import annotations

from collections.abc import Iterable

from app.services.epochs import EpochWork
from app.tasks.liveness import HeldWork, unheld_work


def held(clips: Iterable[tuple[int, int, int]] = (), epochs: Iterable[int] = ()) -> HeldWork:
    """What is held, as ``held_work`` reports it: a clip's step holds its epoch too."""
    steps = frozenset(clips)
    return HeldWork(steps, frozenset(epochs) | {e for e, _, _ in steps})


def test_a_missing_clip_is_held_only_by_a_step_of_that_clip() -> None:
    work = EpochWork(7, missing_clips=[(0, 1), (1, 2)], pending=[0, 1])
    assert unheld_work(work, held({(7, 0, 1), (7, 1, 2)})) == []
    # a step of another clip, or of the same clip of another epoch, holds nothing of it
    assert unheld_work(work, held({(7, 0, 1), (7, 1, 1), (8, 1, 2)})) == ["clip 1/2"]


def test_with_every_clip_recorded_some_step_of_the_epoch_must_be_held() -> None:
    work = EpochWork(7, missing_clips=[], pending=[1])
    assert unheld_work(work, held(epochs={7})) == []  # its integrating chain
    assert unheld_work(work, held(epochs={8})) == ["integration"]


def test_a_finished_epoch_needs_nothing_held() -> None:
    assert unheld_work(EpochWork(7, missing_clips=[], pending=[]), held()) == []
