"""`srg experiment`: stored, resumable after a kill with the same numbers, and its errors.

The interruption is real: the command runs as a subprocess and is SIGKILLed once its
first checkpoint is stored, in the middle of growing towards the next one.
"""

from __future__ import annotations

import contextlib
import json
import os
import signal
import subprocess
import time
from pathlib import Path
from typing import Any

import pytest
from cli_helpers import SRG, ok, one_line_error, srg
from process_helpers import alive
from sqlalchemy import create_engine, func, select

from app.models import ExperimentCheckpoint, GrowthEpoch
from app.services.experiment.results import comparable_figures

TOY_PLAN = ("--seeds", "0", "--checkpoints", "600,1500,2400", "--sessions", "10")
LIQUID_PLAN = (
    "--dynamics", "liquid", "--preset", "tiny", "--strategies", "baseline,sr-crowd",
    "--seeds", "3", "--checkpoints", "120,240", "--sessions", "8",
)  # fmt: skip


def differences(a: dict[str, Any], b: dict[str, Any]) -> list[str]:
    """(crowd, strategy, seed, checkpoint, figure) where two results' comparable figures
    differ."""
    found = []
    for bot, crowd in comparable_figures(a).items():
        for strategy, by_seed in crowd.items():
            for seed, rows in by_seed.items():
                other = comparable_figures(b)[bot][strategy][seed]
                assert len(rows) == len(other)
                for index, (row, twin) in enumerate(zip(rows, other, strict=True)):
                    where = f"{bot}/{strategy}/{seed}/{index}"
                    found += [f"{where}/{k}" for k in row if row[k] != twin.get(k)]
    return found


def results(result: dict[str, Any], bot: str = "goal-directed") -> dict[str, Any]:
    """What one crowd met: per strategy and seed, the rows of its checkpoints."""
    return dict(result["crowds"][bot]["results"])


def run_json(var: Path, *args: str) -> dict[str, Any]:
    """The result file of ``srg experiment args``, which ``--json`` prints alike."""
    printed = json.loads(
        ok(var, "experiment", *args, "--json", "--result", str(var / "result.json"))
    )
    result = dict(json.loads((var / "result.json").read_text()))
    assert printed == result
    return result


def checkpoints_stored(var: Path) -> int:
    engine = create_engine(f"sqlite:///{var / 'srg.sqlite3'}")
    try:
        with engine.connect() as connection:
            return int(connection.scalar(select(func.count()).select_from(ExperimentCheckpoint)))
    except Exception:  # the tables are not there yet
        return 0
    finally:
        engine.dispose()


def kill_after_first_checkpoint(var: Path, *args: str) -> None:
    """Start `srg experiment` and SIGKILL it (and its run processes) mid-growth."""
    env = {k: v for k, v in os.environ.items() if not k.startswith("SRG_")}
    env["SRG_VAR_DIR"] = str(var)
    process = subprocess.Popen(
        [str(SRG), "experiment", *args],
        env=env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        start_new_session=True,
    )
    deadline = time.monotonic() + 300
    while checkpoints_stored(var) < 1:
        assert process.poll() is None, "the experiment ended before it could be interrupted"
        assert time.monotonic() < deadline, "no checkpoint within 300 s"
        time.sleep(0.1)
    with contextlib.suppress(ProcessLookupError):  # ended by itself: the next assert says so
        os.killpg(process.pid, signal.SIGKILL)
    process.wait(30)


def children_of(pid: int) -> list[int]:
    """The live processes whose parent is ``pid`` (from /proc)."""
    found = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        with contextlib.suppress(OSError):
            fields = stat.read_text().rsplit(")", 1)[1].split()
            if int(fields[1]) == pid and fields[0] != "Z":
                found.append(int(stat.parent.name))
    return found


def test_the_run_processes_die_with_a_killed_experiment(tmp_path: Path) -> None:
    """SIGKILL of the experiment's own process alone, as its runs store their first
    checkpoints: its run processes die with it, and no checkpoint is stored after it died
    (they wrote some seconds later while a thread of theirs had to notice)."""
    var = tmp_path / "var"
    ok(var, "db", "upgrade")
    env = {k: v for k, v in os.environ.items() if not k.startswith("SRG_")}
    env["SRG_VAR_DIR"] = str(var)
    plan = ("--strategies", "baseline", "--seeds", "0,1", "--checkpoints", "300,3000")
    process = subprocess.Popen(
        [str(SRG), "experiment", *plan, "--sessions", "2", "--jobs", "2"],
        env=env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        start_new_session=True,
    )
    try:
        deadline = time.monotonic() + 300
        while checkpoints_stored(var) < 1:  # the two runs are at their first checkpoint
            assert process.poll() is None and time.monotonic() < deadline
            time.sleep(0.05)
        runs = children_of(process.pid)
        process.kill()
        process.wait(10)
        stored = checkpoints_stored(var)
        deadline = time.monotonic() + 10
        while any(alive(pid) for pid in runs) and time.monotonic() < deadline:
            time.sleep(0.1)
        assert not any(alive(pid) for pid in runs)
        assert checkpoints_stored(var) == stored
    finally:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(process.pid, signal.SIGKILL)


@pytest.mark.slow
@pytest.mark.parametrize(
    "plan",
    [TOY_PLAN, LIQUID_PLAN],
    ids=["toy", "liquid-tiny"],
)
def test_a_killed_experiment_resumes_to_the_numbers_of_an_uninterrupted_one(
    tmp_path: Path, plan: tuple[str, ...]
) -> None:
    whole, killed = tmp_path / "whole", tmp_path / "killed"
    for var in (whole, killed):
        ok(var, "db", "upgrade")
    expected = run_json(whole, *plan)
    kill_after_first_checkpoint(killed, *plan)
    stored = checkpoints_stored(killed)
    assert 1 <= stored < sum(len(s) for s in results(expected).values()) * 2
    resumed = run_json(killed, "--resume", "--name", expected["name"])
    assert resumed["complete"] and resumed["plan"] == expected["plan"]
    assert differences(resumed, expected) == []
    assert (
        resumed["crowds"]["goal-directed"]["summary"]
        == expected["crowds"]["goal-directed"]["summary"]
    )
    assert resumed["comparison"] == expected["comparison"]


def test_a_toy_experiment_reports_every_strategy_and_the_ratio_per_seed(tmp_path: Path) -> None:
    ok(tmp_path, "db", "upgrade")
    result = run_json(tmp_path, "--quick", "--seeds", "0,1", "--checkpoints", "600,1200")
    assert set(results(result)) == {"baseline", "sr-heuristic", "sr-crowd"}  # max-error if asked
    assert result["complete"] and len(results(result)["sr-crowd"]["1"]) == 2
    summary = result["crowds"]["goal-directed"]["summary"]
    per_seed = summary["sr_crowd_vs_baseline"]["per_seed"]
    assert [row["seed"] for row in per_seed] == ["0", "1"]
    assert all(row["error_ratio"] > 0 for row in per_seed)
    last = results(result)["baseline"]["0"][-1]
    assert last["size_frames"] >= 1200 and last["n_traces"] == 30
    report = (tmp_path / "experiment" / result["name"] / "report.md").read_text()
    assert "sr-crowd" in report
    # both prediction settings, and eq. 2's ingredients learned from sr-crowd's first play
    fixed = summary["prediction"]["fixed_graph"]["baseline"]
    assert len(fixed["density_correlation"]) == 2 and fixed["density_correlation"][0] > 0.5
    grown = summary["prediction"]["grown_graph"]["sr-crowd"]
    assert grown["seeds"] == ["0", "1"] and len(grown["expected_error_relative_difference"]) == 2
    assert "| fixed_graph | baseline |" in report
    assert "| as built | 1" in report and "| radius x 2 |" in report
    # a finished experiment resumes to the same result without growing anything
    engine = create_engine(f"sqlite:///{tmp_path / 'srg.sqlite3'}")
    with engine.connect() as connection:
        epochs = connection.scalar(select(func.count()).select_from(GrowthEpoch))
    again = run_json(tmp_path, "--resume", "--name", result["name"])
    with engine.connect() as connection:
        assert connection.scalar(select(func.count()).select_from(GrowthEpoch)) == epochs
    engine.dispose()
    assert comparable_figures(again) == comparable_figures(result)


def test_baseline_shared_by_crowds_gives_the_numbers_of_baseline_grown_per_crowd(
    tmp_path: Path,
) -> None:
    """Baseline reads no traces: grown once per seed (its world) and played by two
    crowds' bots of that seed, each crowd meets what it meets on a baseline of its own;
    each crowd grows its own sr-crowd per seed. sr-heuristic comes with sr-crowd."""
    shared, alone = tmp_path / "shared", tmp_path / "alone"
    plan = ("--strategies", "baseline,sr-crowd", "--seeds", "0,1", "--checkpoints", "600,1200",
            "--sessions", "10")  # fmt: skip
    for var in (shared, alone):
        ok(var, "db", "upgrade")
    both = run_json(shared, *plan, "--bots", "goal-directed,avoider")
    one = run_json(alone, *plan, "--bots", "avoider")
    assert set(both["crowds"]) == {"goal-directed", "avoider"}
    assert comparable_figures(both)["avoider"] == comparable_figures(one)["avoider"]
    assert both["comparison"]["avoider"] == one["comparison"]["avoider"]
    engine = create_engine(f"sqlite:///{shared / 'srg.sqlite3'}")
    with engine.connect() as connection:
        graphs = set(connection.exec_driver_sql("SELECT name FROM graphs").scalars())
    engine.dispose()
    name = both["name"]
    assert graphs == {
        *(f"{name}.{s}.{seed}" for s in ("baseline", "sr-heuristic") for seed in "01"),
        *(f"{name}.sr-crowd.{bot}.{seed}" for bot in ("goal-directed", "avoider") for seed in "01"),
    }
    # per crowd and checkpoint: sr-crowd / baseline over seeds, its interval, a verdict
    for rows in both["comparison"].values():
        assert [row["checkpoint_frames"] for row in rows] == [600, 1200]
        for row in rows:
            ratio = row["crowd_vs_baseline"]
            assert ratio["low"] <= ratio["mean"] <= ratio["high"]
            assert len(ratio["per_seed"]) == 2
            assert ratio["verdict"] and ratio["method"].startswith("Student t")
            assert set(row["high_error_fraction"]) >= {"baseline", "sr-crowd"}
        assert isinstance(rows[-1]["meets_targets"], bool)
        assert all(isinstance(t["met"], bool) for row in rows for t in row["targets"])
    report = (shared / "experiment" / name / "report.md").read_text()
    assert "## sr-crowd against sr-heuristic and baseline, per crowd" in report
    assert "Intervals: ratios, Student t on log ratios over seeds" in report
    assert "## Crowd `avoider`" in report and "## Crowd `goal-directed`" in report


@pytest.mark.parametrize(
    ("args", "fragment"),
    [
        (("--dynamics", "liquid", "--preset", "huge"), "'--preset': 'huge' is not one of"),
        (("--dynamics", "liquid", "--preset", "tiny", "--fluid", "syrup"), "'syrup' is not one"),
        (("--dynamics", "fluid"), "'--dynamics': 'fluid' is not one of"),
        (("--preset", "tiny"), "the toy dynamics has no preset or fluid"),
        (("--checkpoints", "300,200"), "checkpoints must be increasing"),
        (("--checkpoints", "a,b"), "checkpoints must be comma-separated"),
        (("--strategies", "best"), "unknown strategy"),
        (("--seeds", "x"), "seeds must be comma-separated integers"),
        (("--sessions", "0"), "sessions"),
        (("--player-model", "softmax"), "'--player-model': 'softmax' is not one of"),
        (("--bots", "cheater"), "unknown bot 'cheater'"),
        (("--bots", "avoider,avoider"), "distinct bots"),
        (("--fixed-graph-sessions", "0"), "'--fixed-graph-sessions': Input should be greater"),
        (("--jobs", "0"), "'--jobs': Input should be greater than or equal to 1"),
        (("--resume", "--name", "never-ran"), "no experiment named 'never-ran' to resume"),
        (("--resume", "--seeds", "1"), "--resume runs the stored plan"),
        (("--resume", "--player-model", "shrunk"), "--resume runs the stored plan"),
        (("--resume", "--bots", "random"), "--resume runs the stored plan"),
        (("--resume", "--fixed-graph-sessions", "5"), "--resume runs the stored plan"),
        (("--name", "a/b"), "no '/'"),
        (("--only-seeds", "x"), "--only-seeds must be comma-separated integers"),
        (("--seeds", "0,1", "--only-seeds", "0,5"), "--only-seeds must name seeds of the plan"),
    ],
)
def test_bad_experiment_input_is_one_line_and_writes_nothing(
    tmp_path: Path, args: tuple[str, ...], fragment: str
) -> None:
    ok(tmp_path, "db", "upgrade")
    one_line_error(srg(tmp_path, "experiment", *args), fragment)
    engine = create_engine(f"sqlite:///{tmp_path / 'srg.sqlite3'}")
    with engine.connect() as connection:
        assert connection.scalar(select(func.count()).select_from(ExperimentCheckpoint)) == 0
        assert connection.exec_driver_sql("SELECT COUNT(*) FROM experiments").scalar() == 0
        assert connection.exec_driver_sql("SELECT COUNT(*) FROM graphs").scalar() == 0
    engine.dispose()


def test_the_experiment_benchmark_times_a_fresh_run_and_refuses_resume(tmp_path: Path) -> None:
    args = ("--seeds", "0", "--checkpoints", "300", "--sessions", "3", "--strategies", "baseline")
    figures = json.loads(ok(tmp_path, "bench", "experiment", *args))
    assert figures["frames"] >= 300 and figures["wall_s"] > 0 and figures["cpu_s"] > 0
    assert set(figures["runs"]) == {"baseline/0"}
    one_line_error(srg(tmp_path, "bench", "experiment", "--resume"), "fresh experiment")
    one_line_error(srg(tmp_path, "bench", "experiment", "--preset", "tiny"), "no preset")


def test_through_stops_at_a_checkpoint_with_a_complete_report_and_resume_goes_on(
    tmp_path: Path,
) -> None:
    ok(tmp_path, "db", "upgrade")
    plan = ("--strategies", "baseline,sr-crowd", "--seeds", "0,1", "--checkpoints", "600,1500")
    bad = srg(tmp_path, "experiment", *plan, "--sessions", "6", "--through", "900")
    one_line_error(bad, "--through must be one of the plan's checkpoints (600, 1500)")
    assert checkpoints_stored(tmp_path) == 0
    first = run_json(tmp_path, *plan, "--sessions", "6", "--through", "600")
    assert first["complete"] and first["through_frames"] == 600
    assert [row["checkpoint_frames"] for row in first["comparison"]["goal-directed"]] == [600]
    # three strategies (sr-heuristic with sr-crowd), two seeds, the first checkpoint only
    assert checkpoints_stored(tmp_path) == 3 * 2
    whole = run_json(tmp_path, "--resume", "--name", first["name"])
    assert whole["complete"] and whole["through_frames"] is None
    assert len(whole["comparison"]["goal-directed"]) == 2
    at_600 = first["comparison"]["goal-directed"][0]
    # the last checkpoint of what was asked holds the verdict; the plan's last bars are
    # listed at 1,500 frames, unmeasured, not judged on 600
    unreached = [t for t in at_600["targets"] if t["frames"] == 1500]
    assert len(unreached) == 3 and all(t["value"] is None for t in unreached)
    assert at_600["meets_targets"] is False
    again_at_600 = whole["comparison"]["goal-directed"][0]
    assert again_at_600["crowd_vs_baseline"] == at_600["crowd_vs_baseline"]


def test_a_second_experiment_of_one_name_needs_resume(tmp_path: Path) -> None:
    ok(tmp_path, "db", "upgrade")
    args = ("--seeds", "0", "--checkpoints", "300", "--sessions", "3", "--strategies", "baseline")
    ok(tmp_path, "experiment", *args)
    one_line_error(srg(tmp_path, "experiment", *args), "add --resume")
