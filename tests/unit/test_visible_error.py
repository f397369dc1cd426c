"""Image-space blend artifacts and the threshold picker on synthetic data."""

from __future__ import annotations

import numpy as np
import pytest

from app.core.liquid.error_threshold import (
    ThresholdFitError,
    bootstrap_thresholds,
    fit_logistic,
    log_dist,
    logistic_threshold,
    separating_threshold,
)
from app.core.liquid.visible_error import (
    VisibilityCriterion,
    VisibleArtifacts,
    frame_changes,
    image_difference,
    jump,
    silhouette_mismatch,
    swelling,
    visible_areas,
    visible_artifacts,
)

K, H, W = 10, 120, 160


def block_clip(top_rows: np.ndarray, left: int = 20, right: int = 140) -> np.ndarray:
    """(K, H, W) masks of liquid from row ``top_rows[f]`` down to row 100."""
    masks = np.zeros((K, H, W), dtype=bool)
    for f, top in enumerate(top_rows):
        masks[f, int(top) : 100, left:right] = True
    return masks


def sloshing() -> np.ndarray:
    return block_clip(60 + np.round(3 * np.sin(np.linspace(0, np.pi, K))))


def test_identical_clips_have_no_artifacts() -> None:
    clip = sloshing()
    assert jump(clip, clip) == 0.0
    assert silhouette_mismatch(clip, clip) == 0.0
    assert visible_artifacts(clip, clip) == VisibleArtifacts(0.0, 0.0, 0.0)
    assert image_difference(clip[..., None].repeat(3, -1), clip[..., None].repeat(3, -1)) == 0.0


def test_a_swelling_mask_gives_its_relative_area_excess() -> None:
    reference = block_clip(np.full(K, 60))  # 40 rows x 120 columns
    blend = reference.copy()
    blend[5, 56:60, 20:140] = True  # frame 5 gains 4 rows: 10 % more liquid
    assert visible_areas(reference)[5] == 40 * 120
    assert swelling(visible_areas(blend), visible_areas(reference)) == pytest.approx(0.1)
    # the same excess as a volume, and never negative when the blend shrinks
    assert swelling(np.full(K, 1.0), np.full(K, 2.0)) == 0.0
    assert silhouette_mismatch(blend, reference) == pytest.approx(0.1)


def test_a_pop_is_a_jump_but_physical_motion_is_not() -> None:
    reference = sloshing()
    blend = reference.copy()
    blend[6:, 50:60, 60:80] = True  # a 10 x 20 lump appears in frame 6 and stays
    area = visible_areas(reference)
    physical = (frame_changes(reference) / area[1:]).max()
    own = (frame_changes(blend) / area[1:]).max()
    assert own > physical
    assert jump(blend, reference) == pytest.approx(own - physical)
    # a blend that only moves as fast as the simulation does shows no jump
    assert jump(reference[::-1], reference) == pytest.approx(0.0, abs=0.02)


def test_criterion_names_the_measures_over_their_limits() -> None:
    criterion = VisibilityCriterion(mismatch=0.2, swelling=0.1, jump=0.05)
    assert criterion.violations(VisibleArtifacts(0.1, 0.05, 0.01)) == ()
    assert not criterion.visibly_wrong(VisibleArtifacts(0.2, 0.1, 0.05))  # limits pass
    assert criterion.violations(VisibleArtifacts(0.3, 0.05, 0.06)) == ("mismatch", "jump")
    assert criterion.visibly_wrong(VisibleArtifacts(0.0, 0.11, 0.0))


def test_measures_reject_clips_of_different_shapes_or_without_liquid() -> None:
    with pytest.raises(ValueError):
        silhouette_mismatch(sloshing(), sloshing()[:5])
    with pytest.raises(ValueError):
        jump(sloshing(), np.zeros((K, H, W), bool))


# ---- the threshold picker ----------------------------------------------------------
def synthetic_blends(
    threshold: float, n: int = 400, spread: float = 0.15, seed: int = 1
) -> tuple[np.ndarray, np.ndarray]:
    """Dists over 4 decades; wrong with a logistic probability centred on ``threshold``."""
    rng = np.random.default_rng(seed)
    x = rng.uniform(-4, 0, n)
    p = 1 / (1 + np.exp(-(x - np.log10(threshold)) / spread))
    return 10.0**x, rng.random(n) < p


def test_logistic_recovers_a_known_midpoint_and_slope() -> None:
    rng = np.random.default_rng(0)
    x = rng.normal(0, 2, 5000)
    y = rng.random(5000) < 1 / (1 + np.exp(-(1.5 * x - 0.75)))
    fit = fit_logistic(x, y, ridge=0.0)
    assert fit.slope == pytest.approx(1.5, rel=0.1)
    assert fit.midpoint == pytest.approx(0.5, abs=0.1)


@pytest.mark.parametrize("threshold", [0.002, 0.02])
def test_logistic_threshold_recovers_the_separation_point(threshold: float) -> None:
    dist, wrong = synthetic_blends(threshold)
    assert np.log10(logistic_threshold(dist, wrong)) == pytest.approx(np.log10(threshold), abs=0.1)
    assert np.log10(separating_threshold(dist, wrong)) == pytest.approx(
        np.log10(threshold), abs=0.25
    )


def test_complete_separation_gives_a_threshold_in_the_gap() -> None:
    dist = np.array([0.0, 1e-4, 3e-4, 1e-3, 2e-3, 3e-3, 0.05, 0.08, 0.1, 0.2, 0.3, 0.5])
    wrong = dist > 0.01
    for estimate in (logistic_threshold(dist, wrong), separating_threshold(dist, wrong)):
        assert 3e-3 < estimate < 0.05
    assert separating_threshold(dist, wrong) == pytest.approx(np.sqrt(3e-3 * 0.05))


def test_no_threshold_without_both_groups_or_without_a_trend() -> None:
    dist = np.geomspace(1e-4, 1, 20)
    with pytest.raises(ThresholdFitError):
        logistic_threshold(dist, np.zeros(20, bool))
    with pytest.raises(ThresholdFitError):
        logistic_threshold(dist, dist < 0.01)  # wrong only at small dist


def test_log_dist_puts_zero_just_below_the_smallest_error() -> None:
    np.testing.assert_allclose(log_dist(np.array([0.0, 1e-3, 1.0])), np.log10([5e-4, 1e-3, 1]))


def test_cluster_bootstrap_interval_covers_the_truth_and_resamples_groups() -> None:
    dist, wrong = synthetic_blends(0.01, n=300, spread=0.2)
    groups = np.arange(300) // 6  # 50 dead-end clips of 6 blends
    result = bootstrap_thresholds(dist, wrong, groups, n_boot=200, seed=3)
    lo, hi = result.interval()
    assert lo < 0.01 < hi
    assert hi / lo < 3.0
    assert len(result.thresholds) + result.failed == 200
