"""The experiment report's plots: the paper's Figs. 5 to 9.

Fig. 5 (mean observed error against graph size), Fig. 6 (high-error fraction), Fig. 7
(error histograms at the last checkpoint), Figs. 8/9 (predicted against observed
edge-visit densities, as a scatter and on the drawn graph). Per-step errors and densities
come from each checkpoint's arrays artifact, read through ``load_arrays``.

Every figure uses matplotlib's constrained layout, which makes room for each title, label
and legend instead of letting them run off the figure or over each other; legends sit
outside the axes, off the data.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.collections import LineCollection  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402
from matplotlib.patches import Patch  # noqa: E402

from app.core.evaluation.seed_interval import seed_interval  # noqa: E402
from app.core.graph.state_graph import edge_vertex_control  # noqa: E402

ArraysLoader = Callable[[str], dict[str, np.ndarray]]

#: the unit of eq. 3's error: shape (m^3) plus w_e times energy (J, w_e in m^3/J), over
#: sqrt(kinetic energy) (eq. 6); the toy's quantities are per unit width and density
ERROR_UNITS = {"liquid": "m³/√J", "toy": "toy units"}
#: the y-axis of each metric against graph size; ``{unit}`` is the error's unit
FIGURES = {
    "observed_mean_error": (
        "Mean observed blend error per step (Fig. 5)",
        "mean error per step (eq. 3, {unit})",
        "error-per-step.png",
    ),
    "high_error_fraction": (
        "Play time on high-error edges (Fig. 6)",
        "steps above the high-error\nthreshold (share of steps, 0-1)",
        "high-error.png",
    ),
}
#: the coverage of the band drawn around a mean over seeds
BAND_LEVEL = 0.95
#: the paper's Fig. 8 colours: >= 10 % of the busiest edge red, 2-10 % orange, else grey
DENSITY_BANDS = ((0.10, "#d62728"), (0.02, "#ff9f1c"))
#: strategies compared in Figs. 7-9, as in the paper
COMPARED = ("baseline", "sr-crowd")
#: a density scatter panel's width (inches), and the figure's least width, which its
#: two-line title needs
SCATTER_PANEL_WIDTH = 3.4
SCATTER_MIN_WIDTH = 6.4


def _series(result: dict[str, Any], strategy: str, key: str) -> tuple[np.ndarray, np.ndarray]:
    by_seed = result["results"][strategy]
    sizes = np.array([[row["size_frames"] for row in rows] for rows in by_seed.values()])
    values = np.array(
        [[np.nan if row[key] is None else row[key] for row in rows] for rows in by_seed.values()]
    )
    return sizes.mean(axis=0), values


def error_unit(result: dict[str, Any]) -> str:
    """The unit of eq. 3's error for the experiment's dynamics."""
    return ERROR_UNITS.get(str(result["plan"].get("dynamics")), "dist units")


def high_error_threshold(result: dict[str, Any]) -> float:
    """The high-error threshold the experiment's metrics used (fixed in its plan)."""
    rows = next(iter(next(iter(result["results"].values())).values()))
    return float(rows[-1]["high_error_threshold"])


def save_figure(fig: Figure, path: Path) -> Path:
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def tick_at_checkpoints(ax: Any, checkpoints: list[int]) -> None:
    """Log x ticks at the checkpoints alone, written out: a log axis's own ticks within
    one decade are minor ones labelled 3x10^2, 4x10^2, which no checkpoint is."""
    ax.set_xticks(checkpoints, labels=[f"{c:,}" for c in checkpoints])
    ax.set_xticks([], minor=True)


def plot_metric(result: dict[str, Any], key: str, title: str, ylabel: str, path: Path) -> Path:
    """Mean over seeds against graph size, with its 95 % interval as a band.

    The band needs two seeds: with one the figure draws the line alone and its legend
    promises no interval. Points sit at the sizes the graphs reached (a growth epoch may
    overshoot a checkpoint); ticks mark the checkpoints.
    """
    fig, ax = plt.subplots(figsize=(6.4, 4.4), layout="constrained")
    banded = 0
    n_points = 0
    for strategy in result["results"]:
        sizes, values = _series(result, strategy, key)
        spread = seed_interval(values, level=BAND_LEVEL)
        (line,) = ax.plot(sizes, spread.mean, marker="o", label=strategy)
        if values.shape[0] > 1:
            ax.fill_between(sizes, spread.low, spread.high, color=line.get_color(), alpha=0.2)
            banded = max(banded, values.shape[0])
        n_points = max(n_points, sizes.size)
    ax.set_xscale("log")
    tick_at_checkpoints(ax, list(result["plan"]["checkpoints"][:n_points]))
    ax.set_xlabel("graph size (simulated frames; ticks at the checkpoints)")
    ax.set_ylabel(ylabel.format(unit=error_unit(result)))
    seeds = len(result["plan"]["seeds"])
    ax.set_title(f"{title}\n{f'mean over {seeds} seeds' if seeds > 1 else 'one seed'}")
    ax.grid(alpha=0.3)
    handles, _ = ax.get_legend_handles_labels()
    if banded:
        label = f"{round(100 * BAND_LEVEL)} % interval over {banded} seeds"
        handles.append(Patch(color="grey", alpha=0.3, label=label))
    fig.legend(handles=handles, loc="outside lower center", ncols=3, fontsize=8)
    return save_figure(fig, path)


def _last_arrays(
    result: dict[str, Any], strategy: str, load_arrays: ArraysLoader
) -> list[dict[str, np.ndarray]]:
    return [load_arrays(rows[-1]["arrays"]) for rows in result["results"][strategy].values()]


def plot_histograms(result: dict[str, Any], load_arrays: ArraysLoader, path: Path) -> Path:
    """Errors of the steps players took at the last checkpoint, seeds pooled (Fig. 7)."""
    threshold = high_error_threshold(result)
    compared = [s for s in COMPARED if s in result["results"]] or list(result["results"])
    errors = {
        s: np.concatenate([a["step_errors"] for a in _last_arrays(result, s, load_arrays)])
        for s in compared
    }
    top = max(2.0 * threshold, *(float(e.max()) for e in errors.values()))
    bins = np.linspace(0.0, top, 25)
    fig, ax = plt.subplots(figsize=(6.4, 4.6), layout="constrained")
    for strategy, values in errors.items():
        counts, _ = np.histogram(values, bins=bins)
        ax.stairs(counts / max(values.size, 1), bins, baseline=None, lw=1.5, label=strategy)
    label = f"high-error threshold {threshold:.3g}"
    ax.axvline(threshold, color="black", linestyle="--", label=label)
    ax.set_xlabel(f"error of the step taken (eq. 3, {error_unit(result)}; 0: a simulated edge)")
    ax.set_ylabel("steps (share of all steps, log scale)")
    ax.set_yscale("log")
    size = int(np.mean(_series(result, compared[0], "size_frames")[0][-1]))
    ax.set_title(f"Errors players saw at {size:,} frames (Fig. 7)")
    ax.grid(alpha=0.3)
    fig.legend(loc="outside lower center", ncols=3, fontsize=8)
    return save_figure(fig, path)


def plot_density_scatter(result: dict[str, Any], load_arrays: ArraysLoader, path: Path) -> Path:
    """Predicted against observed P(e) per edge at the last checkpoint, first seed."""
    strategies = list(result["results"])
    width = max(SCATTER_PANEL_WIDTH * len(strategies), SCATTER_MIN_WIDTH)
    fig, axes = plt.subplots(1, len(strategies), figsize=(width, 4.2), layout="constrained")
    for ax, strategy in zip(np.atleast_1d(axes), strategies, strict=True):
        arrays = _last_arrays(result, strategy, load_arrays)[0]
        row = next(iter(result["results"][strategy].values()))[-1]
        predicted, observed = arrays["predicted_density"], arrays["observed_density"]
        floor = 0.1 / max(int(row["n_steps"]), 1)  # below one observed step: unvisited
        ax.scatter(np.maximum(predicted, floor), np.maximum(observed, floor), s=5, alpha=0.5, lw=0)
        ax.plot([floor, 1], [floor, 1], color="black", lw=0.8, label="predicted = observed")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlim(floor / 2, 1)
        ax.set_ylim(floor / 2, 1)
        corr = row["density_correlation"]
        ax.set_title(f"{strategy}\ncorrelation {corr:.2f}" if corr is not None else strategy)
        ax.set_xlabel("predicted edge-visit density\n(share of steps)")
        ax.set_ylabel("observed edge-visit density\n(share of steps)")
    first = np.atleast_1d(axes)[0]
    fig.legend(handles=first.get_lines(), loc="outside lower center", fontsize=8)
    fig.suptitle(
        "Predicted against observed edge-visit densities at the last checkpoint\n"
        "(Figs. 8/9; on the bottom edge: edges no bot took)",
        fontsize=10,
    )
    return save_figure(fig, path)


def _layout(descriptors: np.ndarray) -> np.ndarray:
    """2-D positions of vertices: the first two principal components of their descriptors."""
    centred = descriptors - descriptors.mean(axis=0)
    _, _, vt = np.linalg.svd(centred, full_matrices=False)
    return centred @ vt[:2].T


def plot_density_graph(
    result: dict[str, Any], strategy: str, load_arrays: ArraysLoader, path: Path
) -> Path:
    """The graph with SIM edges coloured by predicted and by observed density (Figs. 8/9).

    Vertices sit at the first two principal components of their occupancy descriptors,
    so states that look alike sit together; blend edges are hidden, as in the paper.
    """
    arrays = _last_arrays(result, strategy, load_arrays)[0]
    n_vertices = arrays["vertex_descriptors"].shape[0]
    n_controls = arrays["edge_dst"].size // n_vertices
    xy = _layout(arrays["vertex_descriptors"].astype(np.float64))
    sim = np.flatnonzero(arrays["edge_kind"] == 0)
    src, dst = edge_vertex_control(sim, n_controls)[0], arrays["edge_dst"][sim]
    segments = np.stack([xy[src], xy[dst]], axis=1)
    fig, axes = plt.subplots(1, 2, figsize=(9.6, 4.6), layout="constrained")
    for ax, key, label in zip(
        axes,
        ("predicted_density", "observed_density"),
        ("predicted by the strategy's player model", "observed in the bots' play"),
        strict=True,
    ):
        density = arrays[key][sim]
        relative = density / max(float(density.max()), 1e-300)
        colours = np.full(sim.size, "#c8c8c8", dtype=object)
        widths = np.full(sim.size, 0.3)
        for level, colour in reversed(DENSITY_BANDS):
            colours[relative >= level] = colour
            widths[relative >= level] = 1.2
        order = np.argsort(relative)  # the busiest edges drawn last, on top
        ax.add_collection(
            LineCollection(
                list(segments[order]), colors=list(colours[order]), linewidths=widths[order]
            )
        )
        ax.scatter(xy[:, 0], xy[:, 1], s=1, color="#555555")
        ax.autoscale()
        ax.set_title(label, fontsize=9)
        ax.set_xlabel("descriptor PC 1 (occupied share of the tank's cells)")
        ax.set_ylabel("descriptor PC 2 (occupied share)")
    handles = [
        plt.Line2D([], [], color=DENSITY_BANDS[0][1], label=">= 10 % of the busiest edge"),
        plt.Line2D([], [], color=DENSITY_BANDS[1][1], label="2-10 %"),
        plt.Line2D([], [], color="#c8c8c8", label="< 2 %"),
    ]
    fig.legend(handles=handles, loc="outside lower center", ncols=3, fontsize=8)
    size = int(arrays["edge_dst"].size // n_controls)
    fig.suptitle(
        f"Edge-visit densities on the {strategy} graph ({size} vertices, SIM edges)", fontsize=10
    )
    return save_figure(fig, path)
