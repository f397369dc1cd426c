"""How a long service reports its work as it goes (app.services.progress): an
``advance(n)`` after each n more units, which add up to the whole of the work done, in the
units each service names (clips of a tree, expansions or frames grown, animations)."""

from __future__ import annotations

import typing
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest
from service_settings import session_settings
from sqlalchemy.orm import Session

from app.config import Settings
from app.core.graph.toy import ToyDynamics
from app.core.growth.expansion import initial_tree_clips
from app.services.catalogue import find_graph, size_frames
from app.services.creation import init_graph
from app.services.epochs import in_session
from app.services.growing import grow_graph
from app.services.progress import Advance
from app.services.publishing import publish_graph

TOY = ToyDynamics()


class Steps:
    """An :data:`Advance` that keeps every ``n`` it is given."""

    def __init__(self) -> None:
        self.calls: list[int] = []

    def __call__(self, n: int) -> None:
        self.calls.append(n)


@pytest.fixture
def settings(db_url: str, tmp_path: Path) -> Iterator[Settings]:
    yield from session_settings(db_url, tmp_path, growth_renders=False)


def test_advance_takes_the_units_done_and_returns_nothing() -> None:
    assert typing.get_origin(Advance) is Callable
    assert typing.get_args(Advance) == ([int], None)


@pytest.mark.parametrize("depth", [2, 3])
def test_an_initial_tree_advances_once_per_clip(
    session: Session, settings: Settings, depth: int
) -> None:
    steps = Steps()
    summary = init_graph(session, settings, name="tank", depth=depth, progress=steps)
    clips = initial_tree_clips(TOY.n_controls, depth)
    assert steps.calls == [1] * clips
    assert summary["size_frames"] == clips * TOY.frames_per_clip


def test_growth_by_expansions_advances_once_per_expansion(
    session: Session, settings: Settings
) -> None:
    init_graph(session, settings, name="tank")
    steps = Steps()
    grown = grow_graph(in_session(session), settings, name="tank", expansions=3, progress=steps)
    assert grown.expansions == 3 and steps.calls == [1, 1, 1]


def test_growth_by_frames_advances_by_the_frames_of_each_expansion(
    session: Session, settings: Settings
) -> None:
    init_graph(session, settings, name="tank")
    entry = find_graph(session, "tank")
    before = size_frames(session, entry.id)
    steps = Steps()
    grown = grow_graph(
        in_session(session),
        settings,
        name="tank",
        frames=2 * entry.frames_per_expansion,
        progress=steps,
    )
    assert steps.calls == [entry.frames_per_expansion] * grown.expansions
    assert grown.expansions >= 2
    assert sum(steps.calls) == size_frames(session, entry.id) - before == grown.size_frames - before


def test_a_publish_advances_once_per_animation_rendered(
    session: Session, settings: Settings
) -> None:
    init_graph(session, settings, name="tank")
    steps = Steps()
    published = publish_graph(session, settings, name="tank", progress=steps)
    assert published.rendered > 0 and steps.calls == [1] * published.rendered
    again = Steps()
    assert publish_graph(session, settings, name="tank", progress=again).rendered == 0
    assert again.calls == []  # nothing left to render, nothing reported
