"""The browser test's check of the client and ``srg bench client``'s figures of the
browser, on frame and callback times made by hand."""

from __future__ import annotations

import numpy as np
import pytest

from app.bench.client import client_waits, stall_figures, undrawn_due_frames

PERIOD = 1000.0 / 30
NO_WAITS = np.empty((0, 2))


def callbacks(start: float, end: float, every: float = 1000.0 / 60) -> np.ndarray:
    return np.arange(start, end, every)


def test_a_client_drawing_every_due_frame_leaves_none_undrawn_across_a_browser_stall() -> None:
    """Callbacks at 60 Hz, a frame drawn at every other one, and a stall of 200 ms in which
    the browser called nothing: the gap is the browser's, not the client's."""
    ticks = np.concatenate([callbacks(0, 500), callbacks(700, 1200)])
    frames = ticks[::2]
    assert len(undrawn_due_frames(frames, ticks, PERIOD)) == 0
    figures = stall_figures(frames, ticks, PERIOD, NO_WAITS)
    assert figures["stalls"] == 1 and figures["undrawn_due"] == 0
    assert figures["longest_gap_ms"] > 200 and figures["drawn_per_due"] < 1


def test_a_callback_past_a_due_frame_that_drew_nothing_is_the_clients_gap() -> None:
    """A frame every 60 ms where one is due every 33 ms, while the browser called every
    10 ms: no gap as long as a stall, yet due frames left out."""
    ticks = callbacks(0, 1000, every=10.0)
    frames = ticks[::6]
    undrawn = undrawn_due_frames(frames, ticks, PERIOD)
    assert len(undrawn) > 0 and set(undrawn) <= set(ticks) - set(frames)
    assert stall_figures(frames, ticks, PERIOD, NO_WAITS)["stalls"] == 0  # no gap over two periods


def test_a_frame_held_past_its_time_in_a_long_gap_is_found() -> None:
    ticks = callbacks(0, 1000)
    frames = np.concatenate([ticks[:10:2], ticks[30::2]])
    undrawn = undrawn_due_frames(frames, ticks, PERIOD)
    assert undrawn.min() > frames[4] + PERIOD and undrawn.max() < frames[5]


def test_a_frame_held_for_a_late_clip_is_the_machines_and_counted() -> None:
    """The last frame held 300 ms for a clip still decoding: not the client's gap inside
    the recorded hold, the client's outside it; the bench counts the hold."""
    ticks = callbacks(0, 1000)
    frames = np.concatenate([ticks[:20:2], ticks[38::2]])
    hold = client_waits({"waits": [[frames[9] + PERIOD, ticks[38]]]})
    assert len(undrawn_due_frames(frames, ticks, PERIOD, hold)) == 0
    short = client_waits({"waits": [[frames[9] + PERIOD, ticks[30]]]})
    assert undrawn_due_frames(frames, ticks, PERIOD, short).min() > ticks[30]
    lasting = client_waits({"waits": [[frames[9] + PERIOD, None]]})
    assert len(undrawn_due_frames(frames, ticks, PERIOD, lasting)) == 0
    figures = stall_figures(frames, ticks, PERIOD, hold)
    assert figures["late_clips"] == 1 and figures["undrawn_due"] == 0
    assert figures["late_held_ms"] == pytest.approx(ticks[38] - frames[9] - PERIOD, abs=0.1)
