"""`srg bench dedup`: the replay's figures on a rendered toy graph; bad limits in one line."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from cli_helpers import ok, one_line_error, srg


def test_the_replay_reports_every_limit(tmp_path: Path) -> None:
    ok(tmp_path, "init", "toy")
    ok(tmp_path, "grow", "toy", "--expansions", "4")
    figures = json.loads(ok(tmp_path, "bench", "dedup", "toy", "--fractions", "0.1,1"))
    assert figures["graph"] == "toy" and figures["high_error_threshold"] > 0
    assert figures["clips_with_strips"] > 0 and figures["strip_bytes_per_frame"] > 0
    assert [run["fraction"] for run in figures["runs"]] == [0.1, 1.0]
    for run in figures["runs"]:
        assert 0 <= run["reused"] <= figures["clips_with_strips"]
        assert run["strip_bytes_per_frame_after"] <= figures["strip_bytes_per_frame"]
        if run["reused"]:
            assert run["error_over_threshold"]["max"] <= run["fraction"]


@pytest.mark.parametrize("fractions", ["0", "0.1,x", "1.5", "-0.1"])
def test_a_limit_outside_0_to_1_is_refused(tmp_path: Path, fractions: str) -> None:
    one_line_error(srg(tmp_path, "bench", "dedup", "toy", "--fractions", fractions), "--fractions")


def test_an_unknown_graph_is_refused(tmp_path: Path) -> None:
    one_line_error(srg(tmp_path, "bench", "dedup", "nope"), "no graph 'nope'")
