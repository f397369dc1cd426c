"""``srg demo`` as a service (app.services.demo), on the toy dynamics: its plan, a run
that goes on from its stored checkpoints and refuses other settings under its name, its
table, and the playable graph published with every animation, framed in its report.

One small demo (two checkpoints, 4 sessions) is run once for the module, on SQLite: the
demo adds nothing of its own to what the experiment stores on either backend.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import replace
from functools import partial
from pathlib import Path
from typing import Any

import pytest
from service_settings import committed_settings

from app.config import Settings
from app.core.errors import InvalidInput
from app.core.growth.kinds import Strategy
from app.core.liquid.defaults import QUICK_LIQUID_PRESET
from app.core.players.kinds import PlayerModelKind
from app.db.sessions import transaction
from app.reports.provenance import with_provenance
from app.services.catalogue import find_graph, latest_publication_id, missing_animations
from app.services.demo import (
    DEMO_CHECKPOINTS,
    DEMO_STRATEGIES,
    PLAYABLE,
    demo_plan,
    demo_rows,
    publish_playable,
    run_demo,
    unrendered_edges,
    visited_frames,
    write_demo_report,
)
from app.services.dynamics import UnknownDynamics
from app.services.experiment.plan import ExperimentExists, ExperimentPlan, stored_plan
from app.services.experiment.runs import grow_in_process
from app.services.loading import artifact_store

NAME = "demo"
CHECKPOINTS = (200, 300)
PLAN = demo_plan("toy", checkpoints=CHECKPOINTS, sessions=4)
PLAYABLE_GRAPH = f"{NAME}.{PLAYABLE.value}.0"


class NoGrowth:
    """A grower that only counts the growth asked of it."""

    def __init__(self) -> None:
        self.asked: list[tuple[Any, ...]] = []

    def __call__(self, *asked: Any) -> None:
        self.asked.append(asked)


@pytest.fixture(scope="module")
def settings(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Settings]:
    yield from committed_settings("sqlite", tmp_path_factory.mktemp("demo"))


@pytest.fixture(scope="module")
def result(settings: Settings) -> dict[str, Any]:
    """The demo's result, as its first run returned it."""
    assert unrendered_edges(settings, NAME, PLAN) == 0  # no playable graph yet
    return run_demo(settings, NAME, PLAN, partial(grow_in_process, settings), jobs=1)


def test_the_plan_grows_the_three_strategies_side_by_side_from_one_world() -> None:
    plan = demo_plan()
    assert (plan.dynamics, plan.preset, plan.fluid) == ("liquid", QUICK_LIQUID_PRESET, None)
    assert plan.strategies == DEMO_STRATEGIES
    assert DEMO_STRATEGIES == (Strategy.BASELINE, Strategy.SR_HEURISTIC, Strategy.SR_CROWD)
    assert (plan.seeds, plan.checkpoints, plan.sessions) == ((0,), DEMO_CHECKPOINTS, 30)
    assert plan.player_model is PlayerModelKind.EQ2
    assert [plan.run_graph(NAME, run) for run in plan.runs] == [
        f"{NAME}.baseline.0",
        f"{NAME}.sr-heuristic.0",
        PLAYABLE_GRAPH,
    ]
    assert [run.world for run in demo_plan(seed=7).runs] == [7, 7, 7]


def test_the_toy_has_no_preset() -> None:
    assert demo_plan("toy", preset="tiny").preset is None
    expected = ExperimentPlan(
        dynamics="toy", strategies=DEMO_STRATEGIES, seeds=(0,), checkpoints=CHECKPOINTS, sessions=4
    )
    assert expected == PLAN


@pytest.mark.parametrize(
    ("arguments", "error", "fragment"),
    [
        ({"dynamics": "fire"}, UnknownDynamics, "unknown dynamics 'fire'"),
        ({"dynamics": "toy", "fluid": "low"}, InvalidInput, "the toy dynamics has no preset"),
        ({"checkpoints": (600, 300)}, InvalidInput, "checkpoints must be increasing positive"),
        ({"checkpoints": ()}, InvalidInput, "checkpoints must be increasing positive"),
        ({"sessions": 0}, InvalidInput, "sessions and batch size must be positive"),
        ({"seed": -1}, InvalidInput, "seeds are worlds"),
    ],
)
def test_a_plan_that_cannot_run_is_refused(
    arguments: dict[str, Any], error: type[Exception], fragment: str
) -> None:
    with pytest.raises(error) as refused:
        demo_plan(**arguments)
    assert fragment in str(refused.value)


def test_the_table_has_a_row_per_checkpoint_of_each_strategys_figures(
    result: dict[str, Any],
) -> None:
    rows = demo_rows(result)
    assert [row.frames for row in rows] == list(CHECKPOINTS)
    played = result["crowds"]["goal-directed"]["results"]
    compared = result["comparison"]["goal-directed"]
    for i, row in enumerate(rows):
        assert set(row.error) == set(row.high_error) == {s.value for s in DEMO_STRATEGIES}
        for strategy in DEMO_STRATEGIES:
            figures = played[strategy.value]["0"][i]
            assert row.error[strategy.value] == figures["observed_mean_error"]
            assert row.high_error[strategy.value] == figures["high_error_fraction"]
            assert 0.0 <= row.high_error[strategy.value] <= 1.0
        assert row.crowd_vs_heuristic == compared[i]["crowd_vs_heuristic"]["mean"]
        assert row.crowd_vs_baseline == compared[i]["crowd_vs_baseline"]["mean"]
        ratio = row.error["sr-crowd"] / row.error["sr-heuristic"]
        assert row.crowd_vs_heuristic == pytest.approx(ratio)


def test_a_demo_run_again_goes_on_from_its_stored_checkpoints(
    settings: Settings, result: dict[str, Any]
) -> None:
    grower = NoGrowth()
    again = run_demo(settings, NAME, PLAN, grower, jobs=1)
    assert grower.asked == []  # every checkpoint is stored: nothing left to grow
    assert demo_rows(again) == demo_rows(result)


@pytest.mark.parametrize(
    "other",
    [replace(PLAN, sessions=5), replace(PLAN, checkpoints=(200, 400)), demo_plan("toy", seed=1)],
    ids=["sessions", "checkpoints", "seed"],
)
def test_a_demo_of_other_settings_under_its_name_is_refused_and_nothing_grows(
    settings: Settings, result: dict[str, Any], other: ExperimentPlan
) -> None:
    grower = NoGrowth()
    with pytest.raises(ExperimentExists) as refused:
        run_demo(settings, NAME, other, grower, jobs=1)
    assert str(refused.value) == (
        f"a demo named {NAME!r} was run with other settings: choose another --name"
    )
    assert grower.asked == []
    assert replace(stored_plan(settings, NAME), high_error_threshold=None) == PLAN


def test_the_playable_graph_is_published_with_every_animation_and_framed_in_the_report(
    settings: Settings, result: dict[str, Any], tmp_path: Path
) -> None:
    with transaction(settings) as session:
        # checkpoints publish for bots: no strip to show
        assert visited_frames(session, settings, PLAYABLE_GRAPH) is None
        missing = missing_animations(session, PLAYABLE_GRAPH)
    assert unrendered_edges(settings, NAME, PLAN) == missing > 0

    rendered: list[int] = []
    graph, published = publish_playable(settings, NAME, PLAN, rendered.append)
    assert graph == published.graph == PLAYABLE_GRAPH
    assert published.rendered == missing and rendered == [1] * missing
    assert unrendered_edges(settings, NAME, PLAN) == 0
    with transaction(settings) as session:
        assert latest_publication_id(session, graph) == published.publication_id
        frames_per_clip = find_graph(session, graph).frames_per_clip
        shown = visited_frames(session, settings, graph)
        three = visited_frames(session, settings, graph, edges=3)
    assert shown is not None and three is not None
    title, tiles = shown
    assert title == (
        f"{graph}, publication {published.number}: middle frames of edges, most visited first"
    )
    assert 0 < len(tiles) <= 12 and len(three[1]) == 3
    middle = f"frame {frames_per_clip // 2 + 1} of {frames_per_clip}"
    assert all(tile.caption[2].startswith(middle) for tile in tiles)
    assert all(tile.image.ndim == 3 for tile in tiles)

    out = tmp_path / "report"
    report = write_demo_report(
        settings,
        with_provenance(result, settings),
        graph,
        out,
        artifact_store(settings).get_arrays,
    )
    text = report.read_text()
    assert (out / "contact-sheet.png").is_file()
    assert f"Frames of the edges bots visited most on `{graph}`" in text
    assert f"http://127.0.0.1:8000/?graph={graph}" in text
