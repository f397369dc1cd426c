"""The STATERANK benchmark runs end to end on a small chain and reports JSON-able numbers."""

from __future__ import annotations

import json

from app.bench.rank import bench_rank


def test_bench_rank_small_chain() -> None:
    report = bench_rank(n_edges=3_000, n_controls=3, seed=1)
    json.dumps(report, allow_nan=False)
    assert (report["n_vertices"], report["n_edges"]) == (1_000, 3_000)
    cold, warm = report["cold_iterations"], report["warm_iterations"]
    assert isinstance(cold, int) and isinstance(warm, int)
    assert 0 < warm < cold
    difference = report["networkx_max_abs_diff"]
    assert difference is None or (isinstance(difference, float) and difference < 1e-9)
