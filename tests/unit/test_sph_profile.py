"""The profile's arithmetic: kernel times and the gaps between them, per substep."""

from __future__ import annotations

import pytest

from app.bench.sph_profile import summarise


def test_gaps_are_the_idle_time_between_consecutive_launches() -> None:
    ms = 1_000_000
    times = [
        ("find_neighbours", 0, 2 * ms),
        ("density_pressure", 3 * ms, 4 * ms),  # 1 ms gap before
        ("pressure_predict", 4 * ms, 6 * ms),
        ("density_pressure", 8 * ms, 9 * ms),  # 2 ms gap before
    ]
    out = summarise(times, substeps=1)
    assert out["device_ms_per_substep"] == pytest.approx(6.0)
    assert out["gaps_ms_per_substep"] == pytest.approx(3.0)
    assert out["span_ms_per_substep"] == pytest.approx(9.0)
    assert out["gap_share"] == pytest.approx(3.0 / 9.0)
    assert out["pressure_loop_share"] == pytest.approx(4.0 / 6.0)
    assert out["kernels"]["density_pressure"]["launches_per_substep"] == 2
    assert out["kernels"]["find_neighbours"]["ms_per_substep"] == pytest.approx(2.0)
    assert out["kernels"]["density_pressure"]["share"] == pytest.approx(2.0 / 6.0)


def test_overlapping_launches_leave_no_negative_gap() -> None:
    out = summarise([("a", 0, 5), ("b", 3, 9)], substeps=2)
    assert out["gaps_ms_per_substep"] == 0.0
