"""`srg bench bytes`: a graph's stored bytes by kind agree with what the dedup bench reads."""

from __future__ import annotations

import json
from pathlib import Path

from cli_helpers import ok, one_line_error, srg


def test_the_bytes_add_up_and_match_the_strips_read_back(tmp_path: Path) -> None:
    ok(tmp_path, "init", "toy")
    ok(tmp_path, "grow", "toy", "--expansions", "4")
    ok(tmp_path, "publish", "toy")
    figures = json.loads(ok(tmp_path, "bench", "bytes", "toy"))
    counts, stored, per_frame = figures["counts"], figures["bytes"], figures["bytes_per_frame"]
    assert figures["simulated_frames"] == counts["clips"] * 10
    assert counts["sim_edges"] + counts["blend_edges"] == counts["clips"] > 0
    assert counts["sim_edges"] == counts["vertices"] - 1
    parts = ("bundles", "clip_strips", "blend_strips", "array_columns")
    assert all(stored[kind] > 0 for kind in parts)
    assert stored["total"] == sum(stored[kind] for kind in parts)
    assert per_frame["total"] == round(stored["total"] / figures["simulated_frames"])
    assert 0 <= figures["unshown_clip_strips_per_frame"] <= per_frame["clip_strips"]
    members = figures["bundle_members_per_frame"]
    assert set(members) == {"end_state", "frames"}  # occupancy and descriptor are derived
    assert 0 < sum(members.values()) <= per_frame["bundles"]
    # the strips' bytes as the dedup bench reads them back, file by file
    dedup = json.loads(ok(tmp_path, "bench", "dedup", "toy", "--fractions", "0.1"))
    strips = (stored["clip_strips"] + stored["blend_strips"]) / figures["simulated_frames"]
    assert abs(strips - dedup["strip_bytes_per_frame"]) < 1e-6


def test_an_unknown_graph_is_refused(tmp_path: Path) -> None:
    one_line_error(srg(tmp_path, "bench", "bytes", "nope"), "no graph 'nope'")
