"""The visible-error threshold service: target picking, and a small run on tiny."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import spearmanr

from app.core.liquid.visible_error import VisibilityCriterion, VisibleArtifacts
from app.liquid.adapter import LiquidDynamics
from app.liquid.threshold import measure_blends
from app.liquid.threshold_blends import pick_targets


def test_targets_run_from_the_best_to_the_worst_of_the_same_control() -> None:
    rng = np.random.default_rng(0)
    controls = [0] * 9 + [1] * 2 + [2]
    dists = rng.uniform(0, 1, (12, 12))
    picked = pick_targets(dists, controls)
    by_clip: dict[int, list[tuple[int, int]]] = {}
    for i, j, rank in picked:
        assert i != j and controls[i] == controls[j]
        by_clip.setdefault(i, []).append((rank, j))
    assert 11 not in by_clip  # the only clip of control 2 has no target
    for i in range(9):
        ranked = sorted((j for j in range(9) if j != i), key=lambda j: dists[i, j])
        ranks = dict(by_clip[i])
        assert sorted(ranks) == [0, 1, 2, 4, 5, 7]  # ranks 0-2, quartiles of ranks 0..7
        assert all(ranks[r] == ranked[r] for r in ranks)
    assert by_clip[9] == [(0, 10)]


@pytest.mark.slow
def test_a_small_study_on_tiny_labels_blends_and_places_a_threshold() -> None:
    # a lenient criterion so that 9 clips give both labels; the real one is the default
    criterion = VisibilityCriterion(mismatch=0.05, swelling=0.03, jump=0.01)
    study = measure_blends(
        LiquidDynamics("tiny"),
        clips=9,
        criterion=criterion,
        rendered=0,
        examples=False,
        n_boot=50,
    )
    blends = study.blends
    assert len(blends) >= 9 and study.details["dead_ends"] == 9
    for b in blends:
        assert min(b.mismatch, b.swelling, b.jump, b.volume_swelling) >= 0.0
        assert b.violations == criterion.violations(
            VisibleArtifacts(b.mismatch, b.swelling, b.jump)
        )
        if b.rank == 0:
            assert b.dist == min(o.dist for o in blends if o.dead_end == b.dead_end)
    dist = np.array([b.dist for b in blends])
    assert dist.min() <= study.threshold <= dist.max()
    low, high = study.details["ci95"]
    assert low <= high
    # what the method rests on: the farther the target, the more the picture differs
    assert spearmanr(dist, [b.mismatch for b in blends]).statistic > 0.5
    assert study.details["visibly_wrong"] == sum(b.wrong for b in blends)
