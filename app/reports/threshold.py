"""Figures of a visible-error threshold study (``app.liquid.threshold``).

* ``threshold-<name>-scatter.png``: each blend's largest artifact relative to its limit
  against ``dist``, with the criterion line, the threshold and its bootstrap interval,
  and the fraction of visibly wrong blends with the logistic fit;
* ``threshold-<name>-measures.png``: the three measures against ``dist`` with their limits;
* ``threshold-<name>-strips.png``: rendered frames of the blends just below and just
  above the threshold, each under the simulated clip it stands in for.

PNGs are written with a 128-colour palette: the renders' path-tracing noise would
otherwise make each strip several hundred kilobytes.
"""

from __future__ import annotations

import io
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from PIL import Image  # noqa: E402

from app.core.liquid.error_threshold import fit_logistic, log_dist  # noqa: E402
from app.liquid.threshold import ThresholdStudy  # noqa: E402

MEASURES = (
    ("mismatch", "silhouette mismatch to the simulation"),
    ("swelling", "visible-area swelling"),
    ("jump", "one-frame jump beyond the simulation's"),
)
#: frames shown in the strips (frame 0 of a blend is the simulated clip's own)
STRIP_FRAMES = (1, 3, 5, 7, 9)


def _save(fig: Any, path: Path, colours: int = 128) -> Path:
    """Save a figure as a palette PNG (small files for the docs)."""
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png")
    plt.close(fig)
    buffer.seek(0)
    image = Image.open(buffer).convert("RGB")
    image.quantize(colors=colours, method=Image.Quantize.MEDIANCUT).save(path, optimize=True)
    return path


def _dist_axis(ax: Any, x: np.ndarray, zero: np.ndarray) -> None:
    ax.set_xscale("log")
    label = "blend error dist(d, t, c), eq. 3 (m³/√J)"
    if zero.any():
        label += f"\n(dist = 0 drawn at {x[zero].min():.1e})"
    ax.set_xlabel(label, fontsize=8)


def _threshold_lines(ax: Any, study: ThresholdStudy, old: float | None) -> None:
    low, high = study.details["ci95"]
    ax.axvspan(low, high, color="tab:green", alpha=0.15, label="95 % bootstrap interval")
    ax.axvline(study.threshold, color="tab:green", label=f"threshold {study.threshold:.3g}")
    if old is not None:
        ax.axvline(old, color="grey", ls=":", label=f"old 90th percentile {old:.3g}")


def plot_scatter(study: ThresholdStudy, path: Path, old_threshold: float | None = None) -> Path:
    """Largest artifact / its limit against dist, and P(visibly wrong) against dist."""
    c = study.criterion
    dist = np.array([b.dist for b in study.blends])
    x = 10.0 ** log_dist(dist)
    score = np.array(
        [
            max(b.mismatch / c.mismatch, b.swelling / c.swelling, b.jump / c.jump)
            for b in study.blends
        ]
    )
    wrong = np.array([b.wrong for b in study.blends])
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(10, 4), dpi=90, layout="constrained")
    ax.scatter(x[~wrong], score[~wrong], s=12, c="tab:blue", label="looks right")
    ax.scatter(x[wrong], score[wrong], s=12, c="tab:red", marker="x", label="visibly wrong")
    ax.axhline(1.0, color="k", ls="--", lw=1, label="criterion (artifact = its limit)")
    _threshold_lines(ax, study, old_threshold)
    ax.set_yscale("log")
    ax.set_ylim(max(score[score > 0].min() / 2, 1e-3), score.max() * 2)
    _dist_axis(ax, x, dist == 0)
    ax.set_ylabel("largest artifact / its limit\n(mismatch/20 %, swelling/10 %, jump/5 %)")
    ax.legend(fontsize=7, loc="upper left")
    ax.set_title(f"{len(dist)} blends of {study.details['dead_ends']} dead-end clips", fontsize=9)

    lx = np.log10(x)
    edges = np.linspace(lx.min(), lx.max() + 1e-9, 9)
    which = np.digitize(lx, edges) - 1
    centres, fractions, counts = [], [], []
    for k in range(len(edges) - 1):
        inside = which == k
        if inside.any():
            centres.append(10 ** lx[inside].mean())
            fractions.append(wrong[inside].mean())
            counts.append(int(inside.sum()))
    bx.scatter(
        centres,
        fractions,
        s=[8 + 2 * n for n in counts],
        c="tab:red",
        alpha=0.7,
        label="fraction visibly wrong (area ~ blends)",
    )
    fit = fit_logistic(lx, wrong.astype(float), ridge=study.details["ridge"])
    grid = np.linspace(lx.min(), lx.max(), 200)
    bx.plot(10**grid, fit.probability(grid), color="k", label="logistic fit on log10(dist)")
    bx.axhline(0.5, color="k", ls=":", lw=0.8)
    _threshold_lines(bx, study, old_threshold)
    _dist_axis(bx, x, dist == 0)
    bx.set_ylabel("P(visibly wrong)")
    bx.set_ylim(-0.03, 1.03)
    bx.legend(fontsize=7, loc="upper left")
    return _save(fig, path)


def plot_measures(study: ThresholdStudy, path: Path) -> Path:
    """Each artifact measure against dist, with its limit."""
    dist = np.array([b.dist for b in study.blends])
    x = 10.0 ** log_dist(dist)
    wrong = np.array([b.wrong for b in study.blends])
    fig, axes = plt.subplots(1, 3, figsize=(12, 3.6), dpi=90, layout="constrained")
    for ax, (name, title) in zip(axes, MEASURES, strict=True):
        y = 100 * np.array([getattr(b, name) for b in study.blends])
        ax.scatter(x[~wrong], y[~wrong], s=10, c="tab:blue", label="looks right")
        ax.scatter(x[wrong], y[wrong], s=10, c="tab:red", marker="x", label="visibly wrong")
        ax.axhline(100 * getattr(study.criterion, name), color="k", ls="--", lw=1, label="limit")
        ax.axvline(study.threshold, color="tab:green", label="threshold")
        _dist_axis(ax, x, dist == 0)
        ax.set_ylabel(f"{name} (% of visible liquid area)")
        ax.set_title(title, fontsize=9)
    axes[0].legend(fontsize=7)
    return _save(fig, path)


def plot_strips(study: ThresholdStudy, path: Path) -> Path:
    """Rendered frames: per example, the simulated clip above the blend shown instead.

    The red line on the blend's frames is the simulated liquid's silhouette.
    """
    rows: list[tuple[str, np.ndarray, np.ndarray | None]] = []
    for name in ("below", "above", "above, visibly wrong"):
        if name in study.examples:
            simulated, blended, sim_masks, _, record = study.examples[name]
            verdict = (
                "visibly wrong: " + ", ".join(record.violations) if record.wrong else "looks right"
            )
            rows.append(("simulated d", simulated, None))
            rows.append(
                (
                    f"blend, dist {record.dist:.3g}\n{name.split(',')[0]} the threshold\n{verdict}",
                    blended,
                    sim_masks,
                )
            )
    n = len(STRIP_FRAMES)
    fig, axes = plt.subplots(
        len(rows),
        n,
        figsize=(1.35 * n + 1.7, 1.05 * len(rows) + 0.3),
        dpi=100,
        squeeze=False,
        layout="constrained",
    )
    for r, (label, images, outline) in enumerate(rows):
        for col, f in enumerate(STRIP_FRAMES):
            ax = axes[r, col]
            ax.imshow(images[f], interpolation="nearest")
            if outline is not None:
                ax.contour(outline[f], levels=[0.5], colors="red", linewidths=0.7)
            ax.set_xticks([])
            ax.set_yticks([])
            if r == 0:
                ax.set_title(f"frame {f} ({1000 * f / 30:.0f} ms)", fontsize=8)
            if col == 0:
                ax.set_ylabel(label, fontsize=7, rotation=0, ha="right", va="center")
    fig.suptitle(
        f"threshold {study.threshold:.3g}: the blends nearest it below and above, and the "
        "nearest visibly wrong one above\n(red: the silhouette of the simulated clip d)",
        fontsize=9,
    )
    return _save(fig, path, colours=48)


def write_threshold_figures(
    study: ThresholdStudy, directory: Path, name: str, old_threshold: float | None = None
) -> list[Path]:
    """All figures of the study into ``directory`` (created), named after ``name``."""
    directory.mkdir(parents=True, exist_ok=True)
    paths = [
        plot_scatter(study, directory / f"threshold-{name}-scatter.png", old_threshold),
        plot_measures(study, directory / f"threshold-{name}-measures.png"),
    ]
    if study.examples:
        paths.append(plot_strips(study, directory / f"threshold-{name}-strips.png"))
    return paths
