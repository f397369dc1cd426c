"""The near-black measure of rendered water, and `srg bench look` over a stored graph."""

from __future__ import annotations

import hashlib
import json
import sqlite3
from pathlib import Path

import numpy as np
from cli_helpers import ok, one_line_error, srg

from app.render.animation import STRIP_MEDIA_TYPE, encode_strip
from app.render.look import dark_fractions, dark_inside, fraction_percentiles


def _frames_with_a_black_block(k: int, side: int) -> np.ndarray:
    """Light blue frames of 64 x 64, frame 1 with a black ``side`` x ``side`` square."""
    frames = np.full((k, 64, 64, 3), (150, 190, 235), dtype=np.uint8)
    frames[1, :side, :side] = 0
    return frames


def test_dark_fractions_count_pixels_dark_in_every_channel() -> None:
    frames = _frames_with_a_black_block(3, 16)
    frames[2, :, :, 0] = 0  # dark in one channel only: blue water, not a shard
    np.testing.assert_allclose(dark_fractions(frames), [0.0, 256 / 4096, 0.0])


def test_dark_pixels_are_counted_inside_the_water_only() -> None:
    frames = _frames_with_a_black_block(2, 16)
    masks = np.zeros((2, 64, 64), bool)
    masks[:, 8:, :] = True  # the water: rows 8 on; the black square's rows 8-15 are in it
    np.testing.assert_array_equal(dark_inside(frames, masks), [0, 8 * 16])
    shares = fraction_percentiles(np.array([0.0, 0.01, 0.02, 0.5]))
    assert shares["median"] == 0.015 and shares["max"] == 0.5


def test_bench_look_reports_the_dark_frames_of_a_graphs_strips(tmp_path: Path) -> None:
    var = tmp_path / "var"
    ok(var, "db", "upgrade")
    ok(var, "init", "t", "--dynamics", "toy")
    one_line_error(srg(var, "bench", "look", "t"), "has no rendered clips")
    assert json.loads(ok(var, "publish", "t", "--no-render", "--json"))["rendered"] == 0
    one_line_error(srg(var, "bench", "look", "t"), "has no rendered clips")  # still none
    ok(var, "publish", "t")
    with sqlite3.connect(var / "srg.sqlite3") as db:
        k = db.execute("SELECT frames_per_clip FROM graphs").fetchone()[0]
        clip = db.execute("SELECT min(idx) FROM clips WHERE animation IS NOT NULL").fetchone()[0]
        data = encode_strip(_frames_with_a_black_block(k, 16))
        digest = hashlib.sha256(data).hexdigest()
        path = var / "data" / digest[:2] / digest[2:4] / digest
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(data)
        db.execute(
            "INSERT INTO artifacts (hash, size, media_type) VALUES (?, ?, ?)",
            (digest, len(data), STRIP_MEDIA_TYPE),
        )
        db.execute("UPDATE clips SET animation = ? WHERE idx = ?", (digest, clip))
    report = json.loads(ok(var, "bench", "look", "t"))
    assert report["worst"] == {"clip": clip, "frame": 1}
    assert 0.04 < report["dark_fraction"]["max"] < 0.09  # 1/16 of the frame, after coding
    assert report["frames_above_half_percent"] == 1 / report["frames"]
    assert report["dark_inside_water"] is None  # the toy has no water to see
