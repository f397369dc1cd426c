"""`srg bench grow`: bad sizes fail in one line before any service starts (no benchmark runs)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
from cli_helpers import ok, one_line_error, srg

import app.bench.grow

POSITIVE_INTS = "takes comma-separated positive integers, got"


@pytest.fixture
def bench_calls(monkeypatch: pytest.MonkeyPatch) -> list[dict[str, Any]]:
    """The benchmark replaced by a recorder: these tests check arguments, never timings."""
    calls: list[dict[str, Any]] = []

    def record(**kwargs: Any) -> dict[str, Any]:
        calls.append(kwargs)
        return {"recorded": True}

    monkeypatch.setattr(app.bench.grow, "bench_grow", record)
    return calls


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--frames", "abc"], f"--frames {POSITIVE_INTS} 'abc'"),
        (["--frames", "20000,0"], f"--frames {POSITIVE_INTS} '20000,0'"),
        (["--frames", "20000,-5"], f"--frames {POSITIVE_INTS} '20000,-5'"),
        (["--frames", "20000,"], f"--frames {POSITIVE_INTS} '20000,'"),
        (["--frames", "50"], "--frames must be at least 120 (the initial tree), got 50"),
        (["--frames", "2000", "--sizes", "1000"], "give --sizes (edges) or --frames, not both"),
        (["--sizes", "1k"], f"--sizes {POSITIVE_INTS} '1k'"),
        (["--workers", "1,x"], f"--workers {POSITIVE_INTS} '1,x'"),
        (["--batch", "0"], "'--batch': Input should be greater than or equal to 1"),
        (["--dynamics", "lava"], "lava"),
    ],
)
def test_bad_sizes_fail_in_one_line_before_any_work(
    tmp_path: Path, bench_calls: list[dict[str, Any]], args: list[str], message: str
) -> None:
    done = srg(tmp_path, "bench", "grow", "--integration-only", *args)
    one_line_error(done, message)
    assert done.stdout == ""
    assert bench_calls == []


def test_integration_only_passes_the_frame_sizes(
    tmp_path: Path, bench_calls: list[dict[str, Any]]
) -> None:
    out = json.loads(
        ok(tmp_path, "bench", "grow", "--integration-only", "--frames", "20000,200000")
    )
    assert out.pop("provenance")["command"].startswith("srg bench grow")
    assert out == {"recorded": True}
    (call,) = bench_calls
    assert call["frames"] == [20000, 200000]
    assert call["integration_only"] is True
    assert (call["dynamics"], call["preset"]) == ("toy", None)
    assert call["sizes"] == [1000, 10000, 100000]  # the default, unused with --frames
