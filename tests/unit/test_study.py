"""A study outside the loop: crowds in fixed shares, fresh judges who never teach, the
pre-registered plan bound to the run, and the scoreboard's bars and frames to clean."""

from __future__ import annotations

import json
from dataclasses import replace
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from database_helpers import migrate
from sqlalchemy import func, select

from app.config import get_settings
from app.core.errors import InvalidInput
from app.core.evaluation.comparison import ratio_interval
from app.core.evaluation.scoreboard import CleanGame, difference_bar, frames_to_clean, ratio_bar
from app.core.growth.kinds import Strategy
from app.core.players.kinds import BotKind
from app.db.sessions import transaction
from app.models import Trace
from app.services.experiment.conduct import conduct_experiment
from app.services.experiment.plan import ExperimentPlan, create_experiment
from app.services.experiment.play_files import read_plays, write_play
from app.services.experiment.preregistration import check_preregistration, preregistration_of
from app.services.experiment.runs import grow_in_process, run_experiment, runs_of_seeds
from app.services.experiment.scoreboard import read_play, scoreboard, scoreboard_figures
from app.services.loading import artifact_store
from app.store.experiments import checkpoint_rows

GD, HES, AV = BotKind.GOAL_DIRECTED, BotKind.HESITANT, BotKind.AVOIDER
MIXED = {"bots": (GD, HES, AV), "pooled": True, "shares": (0.5, 0.3, 0.2), "sessions": 10}


# ---- shares ------------------------------------------------------------------------------
def test_shares_split_the_sessions_exactly_and_survive_storage() -> None:
    plan = ExperimentPlan(**MIXED)
    assert [plan.crowd_sessions(b) for b in plan.bots] == [5, 3, 2]
    assert ExperimentPlan.from_dict(plan.to_dict()) == plan


@pytest.mark.parametrize(
    ("changes", "fragment"),
    [
        ({"shares": (0.5, 0.5)}, "one share per crowd"),
        ({"pooled": False}, "one share per crowd"),
        ({"shares": (0.5, 0.3, 0.3)}, "sum to 1"),
        ({"shares": (0.6, 0.6, -0.2)}, "positive"),
        ({"sessions": 7}, "not a whole number of sessions"),
    ],
)
def test_bad_shares_are_refused(changes: dict[str, Any], fragment: str) -> None:
    with pytest.raises(InvalidInput, match=fragment):
        ExperimentPlan(**{**MIXED, **changes})


def test_fresh_judges_are_labelled_apart_and_populations_gather_them() -> None:
    plan = ExperimentPlan(**MIXED, fresh_judges=True, judges=(BotKind.RANDOM,))
    assert plan.players == (
        "goal-directed", "hesitant", "avoider",
        "fresh-goal-directed", "fresh-hesitant", "fresh-avoider", "random",
    )  # fmt: skip
    assert plan.populations == {
        "population": ("goal-directed", "hesitant", "avoider"),
        "fresh-population": ("fresh-goal-directed", "fresh-hesitant", "fresh-avoider"),
    }
    groups = plan.groups(plan.runs[-1])
    assert [(g.label, g.sessions, g.stored) for g in groups] == [
        ("goal-directed", 5, True), ("hesitant", 3, True), ("avoider", 2, True),
        ("fresh-goal-directed", 5, False), ("fresh-hesitant", 3, False),
        ("fresh-avoider", 2, False), ("random", 10, False),
    ]  # fmt: skip


# ---- a mixed crowd end to end ----------------------------------------------------------
@pytest.fixture(scope="module")
def mixed_runs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    """Two toy experiments of one mixed crowd, one with fresh and other judges."""
    var = tmp_path_factory.mktemp("study")
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("SRG_VAR_DIR", str(var))
        patch.delenv("SRG_DATABASE_URL", raising=False)
        migrate(get_settings().resolved_database_url)
        settings = get_settings()
        common = {**MIXED, "seeds": (20, 21), "checkpoints": (300, 500), "mean_steps": 10}
        plans = {
            "judged": ExperimentPlan(**common, fresh_judges=True, judges=(BotKind.RANDOM,)),
            "alone": ExperimentPlan(**common),
        }
        results = {}
        grower = partial(grow_in_process, settings)
        for name, plan in plans.items():
            stored = create_experiment(settings, name, plan)
            results[name] = run_experiment(settings, name, stored, grower)
        # "judged" grown a world at a time, the later world first, a play file of each part
        split = create_experiment(settings, "split", plans["judged"])
        parts = []
        for seed in (21, 20):
            run_experiment(settings, "split", split, grower, runs=runs_of_seeds(split, (seed,)))
            play = read_play(settings, "split")
            rows = {key: steps for key, steps in play.rows.items() if key[2] == seed}
            parts.append(var / f"part-{seed}.npz")
            write_play(replace(play, rows=rows), parts[-1])
        yield {"settings": settings, "results": results, "parts": parts}


def test_the_crowd_stores_exactly_its_shares_at_every_checkpoint(
    mixed_runs: dict[str, Any],
) -> None:
    """Every publication holds 5 + 3 + 2 stored traces, each kind's own count: the fresh
    and the other judges' sessions are never stored."""
    settings = mixed_runs["settings"]
    with transaction(settings) as session:
        for name in ("judged", "alone"):
            rows = checkpoint_rows(session, _experiment_id(session, name))
            publications = {row.publication_id for row in rows}
            assert len(publications) == 3 * 2 * 2  # strategies x worlds x checkpoints
            for publication in publications:
                for kind, count in (("goal-directed", 5), ("hesitant", 3), ("avoider", 2)):
                    stored = session.scalar(
                        select(func.count()).where(
                            Trace.publication_id == publication,
                            Trace.idempotency_key.like(f"%.{kind}.%"),
                        )
                    )
                    assert stored == count, (name, publication, kind)
                total = select(func.count()).where(Trace.publication_id == publication)
                assert session.scalar(total) == 10


def test_judges_never_reach_what_growth_reads(mixed_runs: dict[str, Any]) -> None:
    """The crowd met the same errors with and without judges beside it: sr-crowd grew the
    same graphs, so no judge's play reached the sums its model learns from."""
    results = mixed_runs["results"]
    for kind in ("goal-directed", "hesitant", "avoider"):
        met = {
            name: [
                row["observed_mean_error"]
                for seed in ("20", "21")
                for row in result["crowds"][kind]["results"]["sr-crowd"][seed]
            ]
            for name, result in results.items()
        }
        assert met["judged"] == met["alone"]
    judged = results["judged"]["comparison"]
    assert {"fresh-population", "population", "fresh-hesitant", "random"} <= set(judged)


def test_the_primary_is_the_fresh_populations_pooled_steps(mixed_runs: dict[str, Any]) -> None:
    """The scoreboard's primary recomputed from the stored step arrays: each world's
    fresh kinds' steps together, sr-crowd's mean over sr-heuristic's."""
    settings = mixed_runs["settings"]
    board = scoreboard(read_play(settings, "judged"))
    assert board.primary.players == "fresh-population" and board.primary.frames == 500
    with transaction(settings) as session:
        rows = checkpoint_rows(session, _experiment_id(session, "judged"))
    store = artifact_store(settings)
    means: dict[str, list[float]] = {}
    for strategy in ("sr-crowd", "sr-heuristic"):
        for seed in (20, 21):
            steps = [
                store.get_arrays(row.arrays, ("step_errors",))["step_errors"]
                for row in rows
                if (row.strategy, row.seed, row.checkpoint) == (strategy, seed, 1)
                and row.bot.startswith("fresh-")
            ]
            assert len(steps) == 3
            means.setdefault(strategy, []).append(float(np.concatenate(steps).mean()))
    expected = ratio_interval(means["sr-crowd"], means["sr-heuristic"])
    assert board.primary.mean == pytest.approx(expected.mean)
    assert board.primary.high == pytest.approx(expected.high)
    figures = read_play(settings, "judged").figures()
    assert ("fresh-population", "baseline", 21, 0) in figures


def test_the_scoreboard_draws_figs_6_and_7_of_the_primarys_players(
    mixed_runs: dict[str, Any], tmp_path: Path
) -> None:
    play = read_play(mixed_runs["settings"], "judged")
    board = scoreboard(play)
    drawn = scoreboard_figures(board, play, tmp_path / "figures")
    assert [p.name for p in drawn] == ["visibly-wrong.png", "error-histograms.png"]
    assert all(p.read_bytes().startswith(b"\x89PNG") for p in drawn)


# ---- a study grown world by world --------------------------------------------------------
def test_worlds_grown_apart_store_the_rows_of_worlds_grown_together(
    mixed_runs: dict[str, Any],
) -> None:
    """Every checkpoint row of the experiment grown a world at a time (the later first)
    holds the per-step errors of the one grown whole: a world does not depend on which
    others were grown beside it."""
    settings = mixed_runs["settings"]
    whole, split = read_play(settings, "judged"), read_play(settings, "split")
    assert whole.rows.keys() == split.rows.keys() and len(whole.rows) == 3 * 2 * 2 * 7
    for key, steps in whole.rows.items():
        assert np.array_equal(steps, split.rows[key]), key


def test_play_files_of_the_parts_judge_as_the_whole(mixed_runs: dict[str, Any]) -> None:
    whole = scoreboard(read_play(mixed_runs["settings"], "judged")).to_dict()
    merged = scoreboard(read_plays(mixed_runs["parts"])).to_dict()
    assert merged.pop("name") == "split" and whole.pop("name") == "judged"
    assert json.dumps(merged, sort_keys=True) == json.dumps(whole, sort_keys=True)


def test_a_part_grown_alone_reports_its_own_worlds(
    mixed_runs: dict[str, Any], tmp_path: Path
) -> None:
    """``srg experiment --only-seeds``'s service: the other world's runs are not grown,
    and the result and the report cover the world that was (every checkpoint of it)."""
    settings = mixed_runs["settings"]
    plan = ExperimentPlan(**{**MIXED, "seeds": (20, 21), "checkpoints": (300,), "mean_steps": 10})
    done = conduct_experiment(settings, "part", plan, report_dir=tmp_path, only_seeds=(21,))
    assert done.result["plan"]["seeds"] == [21] and done.result["complete"]
    assert done.report.is_file()
    with transaction(settings) as session:
        rows = checkpoint_rows(session, _experiment_id(session, "part"))
    assert {row.seed for row in rows} == {21}


def test_play_files_that_overlap_or_differ_are_refused(
    mixed_runs: dict[str, Any], tmp_path: Path
) -> None:
    first, second = mixed_runs["parts"]
    with pytest.raises(InvalidInput, match="rows an earlier file holds"):
        read_plays([first, second, first])
    other = tmp_path / "other.npz"
    write_play(read_play(mixed_runs["settings"], "alone"), other)
    with pytest.raises(InvalidInput, match="another experiment's play"):
        read_plays([first, other])
    (tmp_path / "junk.npz").write_bytes(b"not a zip")
    with pytest.raises(InvalidInput, match="not a play file of srg"):
        read_plays([tmp_path / "junk.npz"])
    with pytest.raises(InvalidInput, match="--only-seeds must name seeds of the plan"):
        runs_of_seeds(read_play(mixed_runs["settings"], "judged").plan, (20, 99))


def _experiment_id(session: Any, name: str) -> int:
    from app.services.experiment.plan import stored_experiment_id

    return stored_experiment_id(session, name)


# ---- the pre-registered plan -----------------------------------------------------------
def test_a_changed_or_missing_plan_file_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "plan.md"
    path.write_text("# plan\n")
    plan = ExperimentPlan(preregistration=preregistration_of(path))
    assert ExperimentPlan.from_dict(plan.to_dict()) == plan
    check_preregistration(plan)  # unchanged: goes on
    path.write_text("# plan, edited\n")
    with pytest.raises(InvalidInput, match="changed since the experiment started"):
        check_preregistration(plan)
    path.unlink()
    with pytest.raises(InvalidInput, match="missing"):
        check_preregistration(plan)


# ---- bars and frames to clean ----------------------------------------------------------
def test_frames_to_clean_against_a_hand_example() -> None:
    """World 0 is clean from 2k; world 1 dips at 2k, rises at 3k, so clean from 5k; world
    2 is never below the bar at the last checkpoint; world 3 is clean from the start."""
    frames = (1_000, 2_000, 3_000, 5_000)
    shares = np.array(
        [
            [0.05, 0.005, 0.0, 0.0],
            [0.05, 0.005, 0.02, 0.001],
            [0.05, 0.0, 0.0, 0.01],
            [0.0, 0.0, 0.0, 0.0],
        ]
    )
    found = frames_to_clean(shares, frames, 0.01)
    assert found.tolist() == [2_000, 5_000, np.inf, 1_000]
    assert frames_to_clean(shares, frames, 0.001).tolist() == [3_000, np.inf, np.inf, 1_000]
    assert frames_to_clean(shares[:, :0], (), 0.01).tolist() == [np.inf] * 4  # none reached


def test_clean_game_bar_needs_the_median_and_more_worlds_won() -> None:
    inf = float("inf")
    game = CleanGame(
        0.01,
        {
            "sr-crowd": [2_000, 3_000, inf],
            "sr-heuristic": [3_000, 3_000, inf],
            "baseline": [5_000, inf, inf],
        },
    )
    frames = (1_000, 2_000, 3_000, 5_000)
    bar = game.judged("sr-crowd", ("sr-heuristic", "baseline"), frames)
    assert bar.met and bar.can_fail and bar.mean == 3_000 and bar.frames == 5_000
    assert game.summary()["baseline"] == {"median": None, "min": 5_000, "max": None, "reached": 1}
    tied = CleanGame(0.01, {s: [2_000, 3_000] for s in ("sr-crowd", "sr-heuristic", "baseline")})
    assert not tied.judged("sr-crowd", ("sr-heuristic", "baseline"), frames).met
    clean = CleanGame(0.01, {s: [1_000, 1_000] for s in ("sr-crowd", "sr-heuristic", "baseline")})
    assert not clean.judged("sr-crowd", ("sr-heuristic", "baseline"), frames).can_fail


def test_a_bar_with_nothing_in_it_cannot_fail_and_a_missing_world_is_not_met() -> None:
    assert not ratio_bar("r", "p", 5_000, [0.0, 0.0], [0.0, 0.0]).can_fail
    assert not difference_bar("d", "p", 5_000, [0.0, 0.0], [0.0, 0.0]).can_fail
    undefined = ratio_bar("r", "p", 5_000, [0.1, 0.2], [0.2, 0.0])
    assert undefined.can_fail and not undefined.met
    better = ratio_bar("r", "p", 5_000, [0.1, 0.11, 0.09], [0.2, 0.2, 0.21])
    assert better.met and better.high is not None and better.high < 1
    assert difference_bar("d", "p", 5_000, [0.0, 0.01], [0.02, 0.03]).can_fail


def test_the_scoreboard_refuses_an_experiment_without_the_three_arms(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    monkeypatch.setenv("SRG_VAR_DIR", str(tmp_path))
    monkeypatch.delenv("SRG_DATABASE_URL", raising=False)
    migrate(get_settings().resolved_database_url)
    settings = get_settings()
    create_experiment(settings, "two", ExperimentPlan(strategies=(Strategy.SR_CROWD,)))
    with pytest.raises(InvalidInput, match="baseline, sr-heuristic and sr-crowd"):
        scoreboard(read_play(settings, "two"))
