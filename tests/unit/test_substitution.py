"""Finding a rendered clip that can stand in for another (app.core.graph.dedup)."""

from __future__ import annotations

import numpy as np

from app.core.graph.dedup import animation_owners, find_substitute, substitution_error
from app.core.graph.dynamics import ClipFeatures


class ShapeOnly:
    """A dynamics whose eq. 3 is the L1 distance of occupancy, plus 1 when src gains energy."""

    def dist(self, a: ClipFeatures, b: ClipFeatures, control: int) -> float:
        gain = 1.0 if b.kinetic > a.kinetic else 0.0
        return float(np.abs(a.occupancy - b.occupancy).sum()) + gain


def clip(control: int, occupancy: list[float], kinetic: float = 0.0) -> ClipFeatures:
    occ = np.asarray(occupancy)
    return ClipFeatures(control, kinetic, np.zeros(3), occ, occ.copy(), 0.0)


OWNED = [clip(0, [1.0, 0.0, 0.0]), clip(0, [0.0, 1.0, 0.0]), clip(1, [1.0, 0.0, 0.0])]


def search(features: ClipFeatures, max_error: float, candidates: int = 4):  # type: ignore[no-untyped-def]
    return find_substitute(
        features,
        np.array([10, 11, 12]),
        np.array([f.control for f in OWNED]),
        np.stack([f.descriptor for f in OWNED]),
        lambda c: OWNED[c - 10],
        ShapeOnly(),  # type: ignore[arg-type]
        max_error,
        candidates,
    )


def test_a_nearly_identical_clip_of_the_same_control_is_found() -> None:
    found = search(clip(0, [0.98, 0.02, 0.0]), max_error=0.1)
    assert found is not None and found.clip == 10
    assert abs(found.error - 0.04) < 1e-12
    assert abs(found.descriptor_distance - np.hypot(0.02, 0.02)) < 1e-12


def test_a_distinct_clip_another_control_or_a_zero_limit_find_none() -> None:
    assert search(clip(0, [0.5, 0.0, 0.5]), max_error=0.1) is None
    assert search(clip(2, [1.0, 0.0, 0.0]), max_error=0.1) is None
    assert search(clip(0, [1.0, 0.0, 0.0]), max_error=0.0) is None


def test_the_error_is_the_larger_direction() -> None:
    still, moving = clip(0, [1.0, 0.0, 0.0]), clip(0, [1.0, 0.0, 0.0], kinetic=1.0)
    assert substitution_error(ShapeOnly(), still, moving) == 1.0  # type: ignore[arg-type]
    assert substitution_error(ShapeOnly(), moving, still) == 1.0  # type: ignore[arg-type]
    assert search(clip(0, [1.0, 0.0, 0.0], kinetic=1.0), max_error=0.5) is None


def test_only_the_nearest_descriptors_are_measured() -> None:
    between = clip(0, [0.55, 0.45, 0.0])  # within 1.0 of both, nearer to 10 by descriptor
    assert search(between, max_error=1.0, candidates=1).clip == 10  # type: ignore[union-attr]
    nearer_11 = clip(0, [0.45, 0.55, 0.0])
    assert search(nearer_11, max_error=1.0, candidates=1).clip == 11  # type: ignore[union-attr]


def test_an_animation_belongs_to_the_first_clip_holding_it() -> None:
    assert animation_owners({7: "a", 3: "b", 5: "a", 9: "b", 4: "c"}) == {"a": 5, "b": 3, "c": 4}
