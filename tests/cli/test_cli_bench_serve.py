"""`srg bench serve`: players at once through `srg serve` with two workers on PostgreSQL,
at a size that says nothing of speed: every request answered and every trace stored."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from cli_helpers import one_line_error, srg


@pytest.mark.postgres
@pytest.mark.slow
def test_the_serve_bench_accounts_for_every_player(tmp_path: Path) -> None:
    done = srg(tmp_path, "bench", "serve", "--players", "2,3", "--workers", "2")
    assert done.returncode == 0, done.stderr
    result = json.loads(done.stdout)
    assert (result["backend"], result["server"], result["ok"]) == (
        "postgresql",
        "srg serve --workers 2",
        True,
    )
    assert [r["players"] for r in result["rounds"]] == [2, 3]
    for played in result["rounds"]:
        players = played["players"]
        assert played["ok_sessions"] == played["stored_traces"] == players
        assert played["errors"] == 0
        assert set(played["statuses"]) == {"200", "201"}
        # per player: a registration and an upload (201), the publication and its clips (200)
        assert played["statuses"]["201"] == 2 * players
        assert played["statuses"]["200"] == played["requests"] - 2 * players >= 2 * players
        latency = played["latency_ms"]
        assert set(latency) == {"all", "register", "publication", "clip", "trace"}
        assert latency["all"]["max"] >= latency["all"]["p99"] >= latency["all"]["p50"] > 0
        assert played["sessions_per_s"] > 0
        assert played["sums_equal_steps"] is True


@pytest.mark.parametrize(
    ("args", "says"),
    [
        (["--players", "10,0"], "--players takes comma-separated positive integers"),
        (["--players", "many"], "--players takes comma-separated positive integers"),
        (["--workers", "0"], "--workers"),
        (["--database-url", "mysql://x/y"], "SRG_DATABASE_URL: "),
    ],
)
def test_bad_serve_bench_options_are_one_line(tmp_path: Path, args: list[str], says: str) -> None:
    one_line_error(srg(tmp_path, "bench", "serve", *args), says)


@pytest.mark.postgres
@pytest.mark.slow
def test_the_upload_bench_sends_only_uploads_and_checks_the_sums(tmp_path: Path) -> None:
    args = ("--players", "4", "--uploads-only", "--mean-steps", "300")
    done = srg(tmp_path, "bench", "serve", *args)
    assert done.returncode == 0, done.stderr
    result = json.loads(done.stdout)
    assert (result["uploads_only"], result["mean_steps"], result["ok"]) == (True, 300, True)
    (played,) = result["rounds"]
    # per player a registration before the round and an upload in it, both 201
    assert played["statuses"] == {"201": 8}
    assert played["stored_traces"] == played["ok_sessions"] == 4
    assert played["sums_equal_steps"] is True
    assert played["uploads_per_s"] > 0
    assert 2 <= played["mean_uploaded_steps"] <= 2_000  # cut to the server's limit
    assert played["latency_ms"]["trace"]["p99"] >= played["latency_ms"]["trace"]["p50"] > 0
    assert played["latency_ms"]["clip"] == played["latency_ms"]["publication"] == {}
