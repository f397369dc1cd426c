"""The high-error threshold from what players see (``docs/threshold.md``).

The paper set its threshold "through gameplay testing": blends whose animations looked
objectionable. Here the looking is measured. Clips of the liquid are simulated from the
settled tank (a fresh depth-2 tree and random control sequences); every clip in turn is
a dead end ``d`` blended into other clips ``t`` of its control, from its best target to
its worst, so that ``dist(d, t, c)`` spans from about zero to far above any blend a graph
keeps. Each blend's silhouette through the game camera is compared with ``d``'s, the
simulated continuation the blend stands in for (``app.core.liquid.visible_error``); the
pre-registered :class:`~app.core.liquid.visible_error.VisibilityCriterion` labels it visibly
wrong or not, and the threshold is the dist where the two are equally likely
(``app.core.liquid.error_threshold``).

A few blends spread over the range of dist are also rendered with Mitsuba: their mean
RGB difference to the rendered simulation is reported next to the silhouette measures,
and the silhouettes are checked against the renders (the pixels where the render differs
from the empty tank). The clips and the blends' measures are
``app.liquid.threshold_blends``'s; this module fits the threshold and checks it.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np
from scipy.stats import spearmanr

from app.core.graph.dynamics import ClipFeatures
from app.core.liquid.error_threshold import (
    DEFAULT_RIDGE,
    ThresholdFitError,
    bootstrap_thresholds,
    log_dist,
    logistic_threshold,
    separating_threshold,
)
from app.core.liquid.silhouette import silhouettes
from app.core.liquid.surface import dequantise_sdf
from app.core.liquid.visible_error import VisibilityCriterion, VisibleArtifacts, image_difference
from app.liquid.adapter import LiquidDynamics
from app.liquid.threshold_blends import (
    DEFAULT_CLIPS,
    BlendRecord,
    Say,
    measure_pairs,
    no_progress,
    pick_targets,
    study_clips,
)

#: blends rendered with Mitsuba for the RGB comparison
DEFAULT_RENDERED = 16
BOOTSTRAP_RESAMPLES = 1000
#: a pixel whose rendered colour differs from the empty tank's by more than this (0-255,
#: any channel) counts as showing liquid in the render check; the 16 spp noise is ~20
RENDER_LIQUID_LEVEL = 40


@dataclass
class ThresholdStudy:
    """Everything one measurement produced; ``details`` is what the calibration stores."""

    threshold: float
    details: dict[str, Any]
    blends: list[BlendRecord]
    criterion: VisibilityCriterion
    #: name -> (simulated images, blend images, simulated masks, blend masks, record)
    examples: dict[str, tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, BlendRecord]] = field(
        default_factory=dict
    )

    def records(self) -> list[dict[str, Any]]:
        """The blends as JSON-able dicts (with the ``wrong`` label)."""
        return [
            {**asdict(b), "violations": list(b.violations), "wrong": b.wrong} for b in self.blends
        ]


def _stratified(values: np.ndarray, count: int) -> list[int]:
    """Indices of ``count`` entries spread evenly over the sorted ``values``."""
    if count <= 0 or len(values) == 0:
        return []
    order = np.argsort(values, kind="stable")
    picks = np.unique(np.round(np.linspace(0, len(values) - 1, min(count, len(values)))))
    return [int(order[int(p)]) for p in picks]


def measure_blends(
    dyn: LiquidDynamics,
    *,
    clips: int = DEFAULT_CLIPS,
    seed: int = 0,
    criterion: VisibilityCriterion | None = None,
    rendered: int = DEFAULT_RENDERED,
    examples: bool = True,
    n_boot: int = BOOTSTRAP_RESAMPLES,
    progress: Say | None = None,
) -> ThresholdStudy:
    """Simulate, blend, project and label; fit the threshold (see the module docstring).

    Parameters
    ----------
    dyn : LiquidDynamics
        The preset and fluid to measure, with its calibration's T0 and w_e (the dist the
        threshold applies to).
    clips : int
        Clips simulated; each is a dead end for up to 7 blends.
    rendered : int
        Blends rendered (with their simulated clips) for the RGB comparison; 0: none.
    examples : bool
        Also render the blends nearest the threshold below and above it, and the nearest
        visibly wrong one above it (for the docs).

    Raises
    ------
    ThresholdFitError
        Too few blends on either side of the criterion to place a threshold.
    """
    say = progress or no_progress
    criterion = criterion or VisibilityCriterion()
    sims = study_clips(dyn, clips, seed, say)
    feats: list[ClipFeatures] = [dyn.features(s) for s in sims]
    controls = [f.control for f in feats]
    dists = np.array(
        [
            [dyn.dist(a, b, b.control) if a.control == b.control else np.inf for b in feats]
            for a in feats
        ]
    )
    pairs = pick_targets(dists, controls)
    say(f"{len(sims)} clips, {len(pairs)} blends")

    measured = measure_pairs(dyn, sims, dists, pairs, criterion, say)
    blends, blend_frames, masks = measured.records, measured.frames, measured.masks
    grid, projector = dyn.grid, measured.projector

    dist = np.array([b.dist for b in blends])
    wrong = np.array([b.wrong for b in blends])
    groups = np.array([b.dead_end for b in blends])
    threshold = logistic_threshold(dist, wrong)
    boot = bootstrap_thresholds(dist, wrong, groups, n_boot=n_boot, seed=seed)
    low, high = boot.interval()
    say(f"threshold {threshold:.4g} (95 % {low:.4g}-{high:.4g}) from {len(blends)} blends")

    renders: dict[int, np.ndarray] = {}

    def render_clip(i: int) -> np.ndarray:
        if i not in renders:
            renders[i] = dyn.render(sims[i].frames)
        return renders[i]

    chosen = _stratified(log_dist(dist), rendered)
    for n, b in enumerate(chosen):
        images = dyn.render(blend_frames[b])
        blends[b] = _with_image_difference(
            blends[b], image_difference(images, render_clip(blends[b].dead_end))
        )
        say(f"rendered {n + 1}/{len(chosen)} blends")
    render_check = _render_check(dyn, blends, renders, masks) if chosen else {}

    found: dict[str, tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, BlendRecord]] = {}
    if examples:
        # the nearest blends on either side, and the nearest visibly wrong one above (at
        # the threshold a blend is wrong only half the time, so "above" may look right)
        x, x_thr = log_dist(dist), np.log10(threshold)
        sides = (
            ("below", x <= x_thr),
            ("above", x > x_thr),
            ("above, visibly wrong", (x > x_thr) & wrong),
        )
        for name, side in sides:
            if side.any():
                b = int(np.flatnonzero(side)[np.argmin(np.abs(x[side] - x_thr))])
                record = blends[b]
                if any(r[4] == record for r in found.values()):
                    continue
                found[name] = (
                    render_clip(record.dead_end),
                    dyn.render(blend_frames[b]),
                    masks[record.dead_end],
                    silhouettes(projector, dequantise_sdf(grid, blend_frames[b])),
                    record,
                )

    details = {
        "method": "visible error: logistic 50 % point of visibly wrong blends on log10(dist)",
        "criterion": asdict(criterion),
        "clips": len(sims),
        "seed": seed,
        "blends": len(blends),
        "dead_ends": len(np.unique(groups)),
        "visibly_wrong": int(wrong.sum()),
        "wrong_by": {
            name: int(sum(name in b.violations for b in blends))
            for name in ("mismatch", "swelling", "jump")
        },
        "threshold": threshold,
        "ci95": [low, high],
        "bootstrap_resamples": n_boot,
        "bootstrap_failed": boot.failed,
        "separating_threshold": separating_threshold(dist, wrong),
        "ridge": DEFAULT_RIDGE,
        "dist_range": [float(dist.min()), float(dist.max())],
        "best_target_wrong_fraction": float(np.mean([b.wrong for b in blends if b.rank == 0])),
        "criterion_sensitivity": _sensitivity(blends, criterion, dist),
        "render_check": render_check,
    }
    return ThresholdStudy(threshold, details, blends, criterion, found)


#: factors the criterion's limits are scaled by in the sensitivity report
SENSITIVITY_SCALES = (0.5, 2.0)


def _sensitivity(
    blends: list[BlendRecord], criterion: VisibilityCriterion, dist: np.ndarray
) -> dict[str, float | None]:
    """The threshold with every limit of the criterion scaled (not used, only reported).

    It says how much the threshold rests on the just-noticeable differences chosen: a
    criterion twice as strict or twice as lenient moves it this far.
    """
    out: dict[str, float | None] = {}
    for scale in SENSITIVITY_SCALES:
        limits = VisibilityCriterion(
            criterion.mismatch * scale, criterion.swelling * scale, criterion.jump * scale
        )
        labels = np.array(
            [limits.visibly_wrong(VisibleArtifacts(b.mismatch, b.swelling, b.jump)) for b in blends]
        )
        try:
            out[f"limits_x{scale:g}"] = logistic_threshold(dist, labels)
        except ThresholdFitError:
            out[f"limits_x{scale:g}"] = None
    return out


def _with_image_difference(record: BlendRecord, value: float) -> BlendRecord:
    return BlendRecord(**{**asdict(record), "image_difference": value})


def _render_check(
    dyn: LiquidDynamics,
    blends: list[BlendRecord],
    renders: dict[int, np.ndarray],
    masks: list[np.ndarray],
) -> dict[str, Any]:
    """How the rendered blends and simulated clips agree with the silhouette measures.

    The silhouette of a rendered simulated clip is compared with the pixels where its
    render differs from the empty tank's: the intersection over union is below 1 mostly
    from render noise and the liquid's shadows, not from misplaced outlines.
    """
    empty = dyn.render(np.full((1, *dyn.grid.shape), 127, dtype=np.int8))[0].astype(np.int16)
    ious = []
    for i, images in renders.items():
        seen = np.abs(images.astype(np.int16) - empty).max(axis=-1) > RENDER_LIQUID_LEVEL
        union = (seen | masks[i]).sum(axis=(1, 2))
        ious.append(float(np.median((seen & masks[i]).sum(axis=(1, 2)) / np.maximum(union, 1))))
    rendered = [b for b in blends if b.image_difference is not None]
    diff = np.array([b.image_difference for b in rendered], dtype=np.float64)
    mismatch = np.array([b.mismatch for b in rendered])
    rho = spearmanr(diff, mismatch).statistic if len(rendered) > 2 else float("nan")
    return {
        "blends": len(rendered),
        "simulated_clips": len(renders),
        "silhouette_render_iou_median": float(np.median(ious)),
        "image_difference_range": [float(diff.min()), float(diff.max())],
        "image_difference_vs_mismatch_spearman": float(rho),
    }


def measure_visible_threshold(
    dyn: LiquidDynamics,
    *,
    clips: int = DEFAULT_CLIPS,
    seed: int = 0,
    rendered: int = DEFAULT_RENDERED,
    progress: Say | None = None,
) -> tuple[float, dict[str, Any]]:
    """The high-error threshold of ``dyn``'s preset and fluid and how it was measured.

    Returns ``(threshold, details)``; ``details`` is JSON-able (the calibration stores
    it). Raises :class:`~app.core.liquid.error_threshold.ThresholdFitError` when the blends do
    not straddle the criterion. 4-8 min on tiny with the defaults (2 loaded cores).
    """
    study = measure_blends(
        dyn, clips=clips, seed=seed, rendered=rendered, examples=False, progress=progress
    )
    return study.threshold, study.details
