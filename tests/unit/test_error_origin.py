"""Where players met error, split by the age of the blends (app.core.evaluation.error_origin)."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from app.core.evaluation.error_origin import error_origin
from app.core.graph.state_graph import EdgeKind
from app.reports.error_origin import error_origin_section

SIM, BLEND = EdgeKind.SIM, EdgeKind.BLEND


def split() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Two controls; vertices 0 and 1 were published before, vertex 2 is new."""
    kind = np.array([SIM, BLEND, BLEND, BLEND, BLEND, SIM])
    err = np.array([0.0, 0.1, 0.2, 0.3, 0.4, 0.0])
    observed = np.array([0.3, 0.1, 0.0, 0.2, 0.25, 0.15])
    predicted = np.array([0.4, 0.0, 0.2, 0.1, 0.1, 0.2])
    earlier = np.array([0.5, 0.5, 0.0, 0.0])  # edges 0 and 1 taken; edge 3 not
    return kind, err, observed, predicted, earlier


def test_the_parts_are_the_error_met_on_new_taken_and_untaken_blends() -> None:
    origin = error_origin(*split(), n_controls=2, large=0.25)
    assert origin.observed == pytest.approx(
        {"new": 0.25 * 0.4, "old_taken": 0.1 * 0.1, "old_untaken": 0.2 * 0.3}
    )
    assert origin.predicted == pytest.approx(
        {"new": 0.1 * 0.4, "old_taken": 0.0, "old_untaken": 0.2 * 0.2 + 0.1 * 0.3}
    )


def test_the_observed_parts_add_up_to_the_mean_error_per_step() -> None:
    kind, err, observed, predicted, earlier = split()
    origin = error_origin(kind, err, observed, predicted, earlier, 2, 0.25)
    assert sum(origin.observed.values()) == pytest.approx(float(observed @ err))
    assert sum(origin.predicted.values()) == pytest.approx(float(predicted @ err))


def test_large_blends_are_counted_with_their_share_of_the_error_whatever_their_age() -> None:
    origin = error_origin(*split(), n_controls=2, large=0.25)
    # edges 3 (0.2 of play at 0.3) and 4 (0.25 at 0.4), of 0.17 met in all
    assert origin.large_blends == 2
    assert origin.large_share == pytest.approx((0.2 * 0.3 + 0.25 * 0.4) / 0.17)
    assert error_origin(*split(), n_controls=2, large=0.4).large_blends == 0


def test_an_earlier_publication_that_is_not_a_prefix_is_refused() -> None:
    kind, err, observed, predicted, _ = split()
    for earlier in (np.zeros(8), np.zeros(3)):
        with pytest.raises(ValueError, match="prefix"):
            error_origin(kind, err, observed, predicted, earlier, 2, 0.25)
    with pytest.raises(ValueError, match="6 entries"):
        error_origin(kind, err[:4], observed, predicted, np.zeros(2), 2, 0.25)


def _row(frames: int, origin: dict[str, Any] | None) -> dict[str, Any]:
    return {"size_frames": frames} | ({"error_origin": origin} if origin else {})


def test_the_report_gives_seed_means_and_shares_from_the_second_checkpoint() -> None:
    origin = error_origin(*split(), n_controls=2, large=0.25).to_dict()
    twice = {**origin, "observed": {k: 2 * v for k, v in origin["observed"].items()}}
    result = {
        "results": {
            "sr-crowd": {
                "0": [_row(100, None), _row(200, origin)],
                "1": [_row(100, None), _row(200, twice)],
            }
        }
    }
    lines = error_origin_section(result)
    rows = [line for line in lines if line.startswith("| sr-crowd")]
    assert len(rows) == 1
    # seed means 1.5 x the single split: 0.15 new of 0.255 in all
    assert rows[0].startswith("| sr-crowd | 200 | 0.255 | 0.15 (59%) | 0.015 (6%) | 0.09 (35%) |")
    assert rows[0].endswith("| 2 (94%) |")


def test_the_report_says_nothing_of_runs_with_one_checkpoint() -> None:
    assert error_origin_section({"results": {"baseline": {"0": [_row(100, None)]}}}) == []
