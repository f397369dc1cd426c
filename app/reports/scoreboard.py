"""The scoreboard's two figures, the paper's Figs. 6 and 7 in a game maker's form: the
share of visibly wrong steps against simulated frames, and the errors players met at
each checkpoint, each strategy beside the others (docs/experiment.md, "Scoreboard")."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from app.reports.figures import plt, save_figure, tick_at_checkpoints

#: the clean-game bars, drawn as lines on the visibly-wrong figure
CLEAN_LINES = (0.01, 0.001)
#: the share drawn for a checkpoint where no world had a visibly wrong step (log axis)
FLOOR = 1e-4


def plot_visibly_wrong(
    shares: Mapping[str, np.ndarray], frames: Sequence[int], players: str, path: Path
) -> Path:
    """Per strategy, the mean over worlds of the visibly-wrong share at each checkpoint
    (worlds x checkpoints in ``shares``), with the range over worlds as a band, on a log
    scale where the clean-game bars (1 %, 0.1 %) are lines."""
    fig, ax = plt.subplots(figsize=(6.4, 4.4), layout="constrained")
    for strategy, values in shares.items():
        (line,) = ax.plot(
            frames, np.maximum(values.mean(axis=0), FLOOR), marker="o", label=strategy
        )
        low, high = np.maximum(values.min(axis=0), FLOOR), np.maximum(values.max(axis=0), FLOOR)
        ax.fill_between(frames, low, high, color=line.get_color(), alpha=0.15)
    for bar in CLEAN_LINES:
        ax.axhline(bar, color="black", linestyle=":", lw=1)
        ax.annotate(f"{bar:.1%}", (frames[0], bar), va="bottom", fontsize=8)
    ax.set_xscale("log")
    ax.set_yscale("log")
    tick_at_checkpoints(ax, list(frames))
    ax.set_xlabel("graph size (simulated frames)")
    ax.set_ylabel(f"visibly wrong steps (share; {FLOOR:g} = none)")
    worlds = next(iter(shares.values())).shape[0]
    ax.set_title(
        f"Time on visible artifacts, {players} (Fig. 6)\nmean and range over {worlds} worlds"
    )
    ax.grid(alpha=0.3)
    fig.legend(loc="outside lower center", ncols=3, fontsize=8)
    return save_figure(fig, path)


def plot_error_histograms(
    errors: Mapping[str, Sequence[np.ndarray]],
    frames: Sequence[int],
    threshold: float,
    players: str,
    path: Path,
) -> Path:
    """One panel per checkpoint: the errors of the steps ``players`` took, worlds pooled,
    per strategy (``errors[strategy][i]`` at checkpoint i), the visibility threshold
    dashed."""
    columns = min(len(frames), 4)
    rows = -(-len(frames) // columns)
    fig, axes = plt.subplots(
        rows, columns, figsize=(3.2 * columns, 2.8 * rows), layout="constrained", squeeze=False
    )
    top = max(2.0 * threshold, *(float(e.max(initial=0.0)) for per in errors.values() for e in per))
    bins = np.linspace(0.0, top, 25)
    for index, (ax, size) in enumerate(zip(axes.flat, frames, strict=False)):
        for strategy, per in errors.items():
            counts, _ = np.histogram(per[index], bins=bins)
            ax.stairs(counts / max(per[index].size, 1), bins, lw=1.2, label=strategy)
        ax.axvline(threshold, color="black", linestyle="--", lw=1)
        ax.set_yscale("log")
        ax.set_title(f"{size:,} frames", fontsize=9)
        ax.grid(alpha=0.3)
    for ax in list(axes.flat)[len(frames) :]:
        ax.set_visible(False)
    handles, labels = axes.flat[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncols=3, fontsize=8)
    fig.suptitle(f"Errors {players} met (share of steps; dashed: visibly wrong) (Fig. 7)")
    return save_figure(fig, path)
