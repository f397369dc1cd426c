"""Results carry where they came from: a fresh ``result.json`` and ``report.md`` of
``srg experiment``, and a benchmark's JSON, name the date, srg's version and commit, the
host's CPU and OpenCL device, and the command line (app/reports/provenance.py)."""

from __future__ import annotations

import json
from datetime import UTC, datetime, timedelta
from importlib.metadata import version
from pathlib import Path

from cli_helpers import ok

from app.reports.provenance import Provenance

FIELDS = {"date", "srg_version", "commit", "cpu", "cpu_count", "opencl_device", "command", "growth"}


def test_a_fresh_result_json_and_report_say_where_they_came_from(tmp_path: Path) -> None:
    ok(tmp_path, "db", "upgrade")
    args = ("experiment", "--quick", "--seeds", "0", "--checkpoints", "600", "--sessions", "4")
    ok(tmp_path, *args, "--name", "stamped", "--result", str(tmp_path / "result.json"))
    result = json.loads((tmp_path / "result.json").read_text())
    stamp = result["provenance"]
    assert set(stamp) == FIELDS
    written = datetime.fromisoformat(stamp["date"])
    assert timedelta(0) <= datetime.now(UTC) - written < timedelta(hours=1)
    assert stamp["srg_version"] == version("srg")
    assert stamp["command"].startswith("srg experiment --quick --seeds 0")
    assert stamp["cpu"] and stamp["cpu_count"] >= 1 and stamp["opencl_device"]
    report = (tmp_path / "experiment" / "stamped" / "report.md").read_text()
    assert Provenance(**stamp).markdown() in report


def test_a_benchmark_prints_its_provenance_first(tmp_path: Path) -> None:
    printed = json.loads(ok(tmp_path, "bench", "rank", "--edges", "300", "--controls", "3"))
    assert list(printed)[0] == "provenance" and set(printed["provenance"]) == FIELDS
    assert printed["provenance"]["command"] == "srg bench rank --edges 300 --controls 3"
