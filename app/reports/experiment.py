"""Plots and a markdown report of an experiment (``app.services.experiment.results.collect``).

The figures are the paper's: Fig. 5 (mean observed error against graph size), Fig. 6
(high-error fraction), Fig. 7 (error histograms at the last checkpoint), Figs. 8/9
(predicted against observed edge-visit densities, as a scatter and on the drawn graph)
and section 7.1's table. Per-step errors and densities come from each checkpoint's
arrays artifact, read through ``load_arrays``.
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

from app.core.comparison import (  # noqa: E402
    ERROR_RATIO_TARGET,
    HIGH_ERROR_FLOOR,
    HIGH_ERROR_RATIO_TARGET,
)
from app.reports.prediction import ingredients_section, settings_section  # noqa: E402

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
#: the paper's Fig. 8 colours: >= 10 % of the busiest edge red, 2-10 % orange, else grey
DENSITY_BANDS = ((0.10, "#d62728"), (0.02, "#ff9f1c"))
#: strategies compared in Figs. 7-9, as in the paper
COMPARED = ("baseline", "sr-crowd")


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


def plot_metric(result: dict[str, Any], key: str, title: str, ylabel: str, path: Path) -> Path:
    """Mean over seeds against graph size, the band spanning the seeds (min to max)."""
    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    for strategy in result["results"]:
        sizes, values = _series(result, strategy, key)
        ax.plot(sizes, np.nanmean(values, axis=0), marker="o", label=strategy)
        if values.shape[0] > 1:
            ax.fill_between(sizes, np.nanmin(values, axis=0), np.nanmax(values, axis=0), alpha=0.2)
    ax.set_xscale("log")
    ax.set_xlabel("graph size (simulated frames)")
    ax.set_ylabel(ylabel.format(unit=error_unit(result)))
    seeds = len(result["plan"]["seeds"])
    ax.set_title(f"{title}\nmean over {seeds} seed(s), band: min to max")
    ax.grid(alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def _last_arrays(
    result: dict[str, Any], strategy: str, load_arrays: ArraysLoader
) -> list[dict[str, np.ndarray]]:
    return [load_arrays(rows[-1]["arrays"]) for rows in result["results"][strategy].values()]


def _threshold(result: dict[str, Any]) -> float:
    rows = next(iter(next(iter(result["results"].values())).values()))
    return float(rows[-1]["high_error_threshold"])


def plot_histograms(result: dict[str, Any], load_arrays: ArraysLoader, path: Path) -> Path:
    """Errors of the steps players took at the last checkpoint, seeds pooled (Fig. 7)."""
    threshold = _threshold(result)
    compared = [s for s in COMPARED if s in result["results"]] or list(result["results"])
    errors = {
        s: np.concatenate([a["step_errors"] for a in _last_arrays(result, s, load_arrays)])
        for s in compared
    }
    top = max(2.0 * threshold, *(float(e.max()) for e in errors.values()))
    bins = np.linspace(0.0, top, 25)
    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    for strategy, values in errors.items():
        counts, _ = np.histogram(values, bins=bins)
        ax.step(bins[:-1], counts / max(values.size, 1), where="post", label=strategy)
    label = f"high-error threshold {threshold:.3g}"
    ax.axvline(threshold, color="black", linestyle="--", label=label)
    ax.set_xlabel(f"error of the step taken (eq. 3, {error_unit(result)}; 0: a simulated edge)")
    ax.set_ylabel("steps (share of all steps, log scale)")
    ax.set_yscale("log")
    size = int(np.mean(_series(result, compared[0], "size_frames")[0][-1]))
    ax.set_title(f"Errors players saw at {size} frames (Fig. 7)")
    ax.grid(alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def plot_density_scatter(result: dict[str, Any], load_arrays: ArraysLoader, path: Path) -> Path:
    """Predicted against observed P(e) per edge at the last checkpoint, first seed."""
    strategies = list(result["results"])
    fig, axes = plt.subplots(1, len(strategies), figsize=(3.4 * len(strategies), 3.6))
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
        ax.set_xlabel("predicted edge-visit density (share of steps)")
        ax.set_ylabel("observed edge-visit density (share of steps)")
        ax.legend(loc="lower right", fontsize=7)
    fig.suptitle(
        "Predicted against observed edge-visit densities at the last checkpoint (Figs. 8/9);"
        " on the bottom edge: edges no bot took",
        fontsize=10,
    )
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


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
    src, dst = sim // n_controls, arrays["edge_dst"][sim]
    segments = np.stack([xy[src], xy[dst]], axis=1)
    fig, axes = plt.subplots(1, 2, figsize=(9.6, 4.4))
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
    fig.legend(handles=handles, loc="lower center", ncol=3, fontsize=8)
    size = int(arrays["edge_dst"].size // n_controls)
    fig.suptitle(
        f"Edge-visit densities on the {strategy} graph ({size} vertices, SIM edges)", fontsize=10
    )
    fig.tight_layout(rect=(0, 0.06, 1, 1))
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def markdown(
    result: dict[str, Any], images: list[Path], ingredients: list[dict[str, Any]] | None = None
) -> str:
    plan = result["plan"]
    scene = plan["dynamics"] + "".join(f" / {plan[k]}" for k in ("preset", "fluid") if plan.get(k))
    seconds = result["seconds"]
    lines = [
        f"## Crowd `{plan['bot']}` on `{scene}`",
        "",
        f"Strategies {', '.join(plan['strategies'])}; seeds {plan['seeds']}; checkpoints "
        f"{plan['checkpoints']} frames; {plan['sessions']} "
        f"{plan['bot']} bot sessions of mean {plan['mean_steps']} steps "
        f"per checkpoint; {plan['batch_size']} expansions per growth epoch. "
        f"High-error threshold {_threshold(result):.4g}."
        + (
            f" This invocation ran {seconds} s (a resume runs only what was not stored;"
            " growth seconds per run are under Cost)."
            if seconds is not None
            else ""
        ),
        "",
        "| strategy | frames | mean error/step | high-error fraction | steps on blends "
        "| error per blend step | predicted expected error | density corr. | density TV "
        "| score/step |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for strategy, by_seed in result["results"].items():
        for rows in zip(*by_seed.values(), strict=True):

            def mean(key: str, rows: tuple[dict[str, Any], ...] = rows) -> str:
                values = [r[key] for r in rows if r[key] is not None]
                return f"{np.mean(values):.4g}" if values else "n/a"

            lines.append(
                f"| {strategy} | {rows[0]['size_frames']} | {mean('observed_mean_error')} "
                f"| {mean('high_error_fraction')} | {mean('blend_step_fraction')} "
                f"| {mean('mean_error_on_blend_steps')} | {mean('predicted_expected_error')} "
                f"| {mean('density_correlation')} | {mean('density_tv_distance')} "
                f"| {mean('mean_score_per_step')} |"
            )
    lines += _prediction_section(result)
    lines += settings_section(result)
    lines += ingredients_section(ingredients or [])
    versus = result["summary"].get("sr_crowd_vs_baseline")
    if versus:
        lines += ["", "## sr-crowd against baseline at the last checkpoint", ""]
        lines += [
            "| seed | error ratio | high-error ratio | at half the threshold "
            "| at double the threshold |",
            "|---|---|---|---|---|",
        ]
        lines += [
            f"| {s['seed']} | {_number(s['error_ratio'], 3)} | {_number(s['high_error_ratio'], 3)} "
            f"| {_number(s.get('high_error_ratio_at_half_threshold'), 3)} "
            f"| {_number(s.get('high_error_ratio_at_double_threshold'), 3)} |"
            for s in versus["per_seed"]
        ]
        lines += [
            "",
            "A ratio is n/a where baseline's players met no step above that threshold. "
            "Whether the targets are met is judged on the mean over seeds with its "
            "interval (the comparison at the top), not seed by seed.",
        ]
    lines += _cost_section(result)
    lines += [""] + [f"![{p.stem}]({p.as_posix()})" for p in images]
    return "\n".join(lines) + "\n"


def _prediction_section(result: dict[str, Any]) -> list[str]:
    """Predicted against observed expected error per step (paper section 7.1), seed means.

    The relative differences are of the seed means. The per-vertex bound is STATERANK under
    the control frequencies of the very traces it is compared with: the closest any
    per-vertex player model could come. Baseline and sr-heuristic predict with the
    heuristic model, so their predictions are not expected to hold (as in the paper).
    """
    lines = [
        "",
        "## Predicted against observed expected error per step (section 7.1)",
        "",
        "Predicted on each publication by STATERANK from the strategy's player model "
        "(sr-crowd: learned from earlier checkpoints' traces only) before the bots play it; "
        "the per-vertex bound uses the same traces' own control frequencies and session "
        "length. Prior-only mass: share of predicted play on vertices the crowd kernel does "
        "not reach.",
        "",
        "| strategy | frames | predicted | observed | rel. diff. | per-vertex bound "
        "| bound rel. diff. | L predicted / observed | prior-only mass |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for strategy, by_seed in result["results"].items():
        for rows in zip(*by_seed.values(), strict=True):

            def mean(key: str, rows: tuple[dict[str, Any], ...] = rows) -> float:
                values = [r[key] for r in rows if r.get(key) is not None]
                return float(np.mean(values)) if values else float("nan")

            observed = mean("observed_mean_error")
            predicted = mean("predicted_expected_error")
            bound = mean("per_vertex_bound_expected_error")
            lines.append(
                f"| {strategy} | {mean('size_frames'):.0f} | {predicted:.4g} "
                f"| {observed:.4g} | {_relative(predicted, observed)} | {bound:.4g} "
                f"| {_relative(bound, observed)} | {mean('predicted_session_steps'):.0f} / "
                f"{mean('observed_session_steps'):.0f} "
                f"| {_number(mean('predicted_mass_prior_only'))} |"
            )
    return lines


def _cost_section(result: dict[str, Any]) -> list[str]:
    """Where the time and memory went, per strategy at the last checkpoint (seed means)."""
    lines = [
        "",
        "## Cost",
        "",
        "Growth seconds per checkpoint (wall, in the run's process; runs share the cores) "
        "and peak resident memory of that process.",
        "",
        "| strategy | grow s (sum over checkpoints) | frames | peak resident MB, first "
        "/ last checkpoint | KB per frame grown in between |",
        "|---|---|---|---|---|",
    ]
    for strategy, by_seed in result["results"].items():
        runs = list(by_seed.values())
        grow = np.mean([sum(float(r["grow_seconds"]) for r in rows) for rows in runs])
        first, last = (
            np.mean([[rows[i]["size_frames"], rows[i]["resident_mb"]] for rows in runs], axis=0)
            for i in (0, -1)
        )
        per_frame = 1024 * (last[1] - first[1]) / max(last[0] - first[0], 1)
        lines.append(
            f"| {strategy} | {grow:.0f} | {last[0]:.0f} | {first[1]:.0f} / {last[1]:.0f} "
            f"| {per_frame:.1f} |"
        )
    return lines


def _relative(value: float, observed: float) -> str:
    if not observed > 0.0 or np.isnan(value):
        return "n/a"
    return f"{(value - observed) / observed:+.0%}"


def _number(value: float | None, digits: int = 2) -> str:
    return "n/a" if value is None or np.isnan(value) else f"{value:.{digits}f}"


def crowd_view(result: dict[str, Any], bot: str) -> dict[str, Any]:
    """What one crowd met, shaped as a one-crowd result: ``results`` and ``summary`` of
    ``crowds.<bot>``, and the plan naming that bot (what a crowd's section reads)."""
    return {
        **{k: v for k, v in result.items() if k not in ("crowds", "comparison")},
        "plan": {**result["plan"], "bot": bot},
        **result["crowds"][bot],
    }


def comparison_section(result: dict[str, Any]) -> list[str]:
    """sr-crowd / baseline per crowd and checkpoint: seed mean, interval, verdict."""
    comparison = result.get("comparison") or {}
    if not comparison:
        return []
    seeds = len(result["plan"]["seeds"])
    lines = [
        "",
        "## sr-crowd against baseline, per crowd",
        "",
        f"Ratio of sr-crowd's to baseline's figure, mean over {seeds} seed(s) (each seed "
        "pairs two graphs grown from one initial tree); the 95 % interval resamples the "
        "seeds and, inside each, both graphs' sessions (a two-level bootstrap). Targets at "
        f"the last checkpoint: error ratio <= {ERROR_RATIO_TARGET} with the interval's "
        f"upper end below 1; high-error ratio <= {HIGH_ERROR_RATIO_TARGET} where "
        f"baseline's high-error fraction is above {HIGH_ERROR_FLOOR}.",
        "",
        "| crowd | frames | error ratio [95 % interval] | per seed | verdict "
        "| high-error ratio [95 % interval] | baseline high-error | targets |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for bot, rows in comparison.items():
        for row in rows:
            error, high = row["error_ratio"], row["high_error_ratio"]
            met = row.get("meets_targets")
            lines.append(
                f"| {bot} | {row['checkpoint_frames']} | {interval_text(error)} "
                f"| {', '.join(_number(r, 2) for r in error['per_seed'])} "
                f"| {row['error_verdict']} | {interval_text(high)} "
                f"| {row['baseline_high_error_fraction']:.3f} "
                f"| {'' if met is None else ('met' if met else 'NOT met')} |"
            )
    return lines


def interval_text(ratio: dict[str, Any], digits: int = 2) -> str:
    """``mean [low, high]`` of a comparison's ratio (``n/a`` where undefined)."""
    mean, low, high = (_number(ratio[key], digits) for key in ("mean", "low", "high"))
    return f"{mean} [{low}, {high}]"


def write_report(
    result: dict[str, Any],
    out_dir: Path,
    load_arrays: ArraysLoader,
    ingredients: list[dict[str, Any]] | None = None,
) -> Path:
    """``report.md`` into ``out_dir``: sr-crowd against baseline per crowd with intervals,
    then one section per crowd with its PNG plots (in ``out_dir/<crowd>/``); returns the
    markdown path.

    ``ingredients``: rows of :func:`app.services.ingredients.eq2_ingredients`, if wanted.
    """
    out_dir.mkdir(parents=True, exist_ok=True)
    sections = [f"# Self-refining experiment `{result['name']}`", *comparison_section(result)]
    for bot in result["crowds"]:
        view = crowd_view(result, bot)
        pages = out_dir / bot
        pages.mkdir(exist_ok=True)
        images = [
            plot_metric(view, key, title, ylabel, pages / name)
            for key, (title, ylabel, name) in FIGURES.items()
        ]
        images.append(plot_histograms(view, load_arrays, pages / "error-histogram.png"))
        images.append(plot_density_scatter(view, load_arrays, pages / "density-scatter.png"))
        for strategy in (s for s in COMPARED if s in view["results"]):
            images.append(
                plot_density_graph(view, strategy, load_arrays, pages / f"density-{strategy}.png")
            )
        crowd_rows = [row for row in ingredients or [] if row["bot"] == bot]
        sections += [
            "",
            markdown(view, [image.relative_to(out_dir) for image in images], crowd_rows),
        ]
    report = out_dir / "report.md"
    report.write_text("\n".join(sections))
    return report
