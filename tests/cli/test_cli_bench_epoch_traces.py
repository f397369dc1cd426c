"""`srg bench epoch-traces`: a grow beside stored steps, at a size that says nothing of
speed: the steps are stored and summed, both graphs grow, analytics counts the sessions."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from cli_helpers import srg


@pytest.mark.postgres
@pytest.mark.slow
def test_the_epoch_bench_stores_the_steps_it_reports(tmp_path: Path) -> None:
    done = srg(
        tmp_path, "bench", "epoch-traces", "--steps", "400", "--session-steps", "20",
        "--expansions", "1", "--repeats", "1", "--sessions", "2",
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    result = json.loads(done.stdout)
    quiet, played = result["stored_steps"]["quiet"], result["stored_steps"]["played"]
    # both graphs hold their bots' steps; the played one also the 400 the server wrote
    assert quiet > 0
    assert played > 400
    assert len(result["grow_s"]["quiet"]) == len(result["grow_s"]["played"]) == 1
    assert result["ratio"] > 0 and result["analytics_sessions"] > 0
