"""The markdown report of an experiment (``app.services.experiment.results.collect``).

Its tables, section 7.1's among them, and the paper's plots (:mod:`app.reports.figures`)
beside them.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from app.core.evaluation.comparison import (
    AIMLESS_CROWDS,
    BASELINE,
    CROWD,
    ERROR_RATIO_TARGET,
    HEURISTIC,
    HIGH_ERROR_FLOOR,
    HIGH_ERROR_RATIO_TARGET,
    NO_DIP_FROM_FRAMES,
)
from app.reports.error_origin import error_origin_section
from app.reports.figures import (
    COMPARED,
    FIGURES,
    ArraysLoader,
    high_error_threshold,
    plot_density_graph,
    plot_density_scatter,
    plot_histograms,
    plot_metric,
)
from app.reports.prediction import ingredients_section, settings_section
from app.reports.provenance import Provenance


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
        f"High-error threshold {high_error_threshold(result):.4g}."
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
    lines += error_origin_section(result)
    lines += settings_section(result)
    lines += ingredients_section(ingredients or [])
    lines += _per_seed_section(result["summary"])
    lines += _cost_section(result)
    lines += [""] + [f"![{p.stem}]({p.as_posix()})" for p in images]
    return "\n".join(lines) + "\n"


def _per_seed_section(summary: dict[str, Any]) -> list[str]:
    """sr-crowd's ratios to sr-heuristic's and baseline's figures, seed by seed."""
    lines: list[str] = []
    for key, other in (
        ("sr_crowd_vs_sr_heuristic", "sr-heuristic"),
        ("sr_crowd_vs_baseline", "baseline"),
    ):
        versus = summary.get(key)
        if not versus:
            continue
        lines += [
            "",
            f"## sr-crowd against {other} at the last checkpoint, per seed",
            "",
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
            f"A ratio is n/a where {other}'s players met no step above that threshold. "
            "Whether the targets are met is judged on the seeds together, with their "
            "interval (the comparison at the top), not seed by seed.",
        ]
    return lines


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
    """sr-crowd / sr-heuristic, sr-crowd / baseline and sr-heuristic / baseline per crowd
    and checkpoint, with intervals over seeds, the visibly-wrong shares, then the targets."""
    comparison = result.get("comparison") or {}
    if not comparison:
        return []
    seeds = len(result["plan"]["seeds"])
    methods = {
        label: row[key]["method"]
        for rows in comparison.values()
        for row in rows
        for key, label in (
            ("crowd_vs_heuristic", "ratios"),
            ("crowd_vs_baseline", "ratios"),
            ("heuristic_vs_baseline", "ratios"),
            ("high_error_difference", "share difference"),
        )
        if key in row
    }
    lines = [
        "",
        "## sr-crowd against sr-heuristic and baseline, per crowd",
        "",
        "Ratio of the mean error per step: sr-crowd / sr-heuristic is the headline (the "
        "same STATERANK growth, with and without the players' traces). Per seed the ratio "
        "of the two graphs' means (a seed pairs graphs grown from one initial tree); the "
        f"figure is the geometric mean over {seeds} seed(s), with its interval in brackets. "
        "Visibly wrong: the share of steps whose blend error is above the calibrated "
        "threshold (mean over seeds); sr-crowd - sr-heuristic is that share's difference.",
        "",
        "| crowd | frames | sr-crowd / sr-heuristic | sr-crowd / baseline "
        "| sr-heuristic / baseline | visibly wrong: baseline / sr-heuristic / sr-crowd "
        "| sr-crowd - sr-heuristic |",
        "|---|---|---|---|---|---|---|",
    ]
    for bot, rows in comparison.items():
        for row in rows:
            shares = row["high_error_fraction"]
            lines.append(
                f"| {bot} | {row['checkpoint_frames']} "
                + "".join(f"| {_interval_cell(row.get(key))} " for key in RATIO_KEYS)
                + "| "
                + " / ".join(_number(shares.get(s), 3) for s in SHARED)
                + f" | {_interval_cell(row.get('high_error_difference'), 3)} |"
            )
    lines += ["", f"Intervals: {'; '.join(f'{k}, {m}' for k, m in methods.items())}."]
    lines += _targets_table(comparison, seeds)
    return lines


#: the comparison's ratios of mean error, in the order of the report's columns
RATIO_LABELS = {
    "crowd_vs_heuristic": "sr-crowd / sr-heuristic",
    "crowd_vs_baseline": "sr-crowd / baseline",
    "heuristic_vs_baseline": "sr-heuristic / baseline",
}
RATIO_KEYS = tuple(RATIO_LABELS)
#: the strategies whose visibly-wrong shares the report shows, in order
SHARED = (BASELINE, HEURISTIC, CROWD)


def _interval_cell(compared: dict[str, Any] | None, digits: int = 2) -> str:
    return "" if compared is None else interval_text(compared, digits)


def _targets_table(comparison: dict[str, Any], seeds: int) -> list[str]:
    """Each crowd's targets (app.core.evaluation.comparison.targets): the number, the bar, met
    or not.

    One world (the demo) gives no interval: the targets that need one are not judged
    there but named as needing more worlds, so a one-world run reports what it can say
    instead of a verdict it cannot reach."""
    judged = [
        (bot, t) for bot, rows in comparison.items() for r in rows for t in r.get("targets", [])
    ]
    if not judged:
        return []
    lines = [
        "",
        f"Targets, set before any liquid run: with an aim, at the last checkpoint "
        f"sr-crowd / sr-heuristic <= {ERROR_RATIO_TARGET} with the interval's upper end "
        f"below 1 and sr-crowd / baseline <= {ERROR_RATIO_TARGET}, and from "
        f"{NO_DIP_FROM_FRAMES:,} frames on sr-crowd / sr-heuristic <= 1; aimless "
        f"({', '.join(sorted(AIMLESS_CROWDS))}): the upper end against sr-heuristic "
        "below 1. Every crowd and checkpoint: sr-crowd's visibly-wrong share not above "
        "sr-heuristic's beyond the noise, and at most "
        f"{HIGH_ERROR_RATIO_TARGET} x baseline's where baseline's is above {HIGH_ERROR_FLOOR}.",
        "",
        "| crowd | frames | target | value | bar | met |",
        "|---|---|---|---|---|---|",
    ]
    lines += [
        f"| {bot} | {t['frames']} | {t['target']} | {_number(t['value'], 3)} "
        f"| {t['relation']} {t['bar']:g} | {_verdict(t, seeds)} |"
        for bot, t in judged
    ]
    if seeds < 2:
        return lines + ["", _one_world(judged)]
    verdicts = [
        f"{bot}: {'all met' if rows[-1]['meets_targets'] else 'NOT all met'}"
        for bot, rows in comparison.items()
        if "meets_targets" in rows[-1]
    ]
    return lines + ["", "; ".join(verdicts) + "."]


def _one_world(judged: list[tuple[str, dict[str, Any]]]) -> str:
    """What one world can say of its targets: those with a number, and how many wait for
    an interval over worlds (``srg experiment --seeds 0,1,2``)."""
    parts = []
    for bot in dict.fromkeys(b for b, _ in judged):
        mine = [t for b, t in judged if b == bot]
        measured = [t for t in mine if t["value"] is not None]
        parts.append(
            f"{bot}: {sum(t['met'] for t in measured)} of the {len(measured)} targets one "
            f"world measures met, {len(mine) - len(measured)} need an interval over worlds"
        )
    return "One world: " + "; ".join(parts) + " (`srg experiment --seeds 0,1,2` judges them all)."


def _verdict(target: dict[str, Any], seeds: int) -> str:
    """A target without its number is not met, and the report says why: one world gives
    no interval; otherwise the run did not grow a strategy the target compares."""
    if target["met"]:
        return "met"
    if target["value"] is not None:
        return "NOT met"
    return "needs more worlds" if seeds < 2 else "NOT met: not measured"


def interval_text(compared: dict[str, Any], digits: int = 2) -> str:
    """``mean [low, high]`` of a comparison (``n/a`` where undefined)."""
    mean, low, high = (_number(compared[key], digits) for key in ("mean", "low", "high"))
    return f"{mean} [{low}, {high}]"


def write_report(
    result: dict[str, Any],
    out_dir: Path,
    load_arrays: ArraysLoader,
    ingredients: list[dict[str, Any]] | None = None,
) -> Path:
    """``report.md`` into ``out_dir``: where it came from (``result["provenance"]``),
    sr-crowd against sr-heuristic and baseline per crowd with intervals and targets, then
    one section per crowd with its PNG plots (in ``out_dir/<crowd>/``); returns the
    markdown path.

    ``ingredients``: rows of :func:`app.services.experiment.ablation.eq2_ingredients`, if wanted.
    """
    out_dir.mkdir(parents=True, exist_ok=True)
    sections = [
        f"# Self-refining experiment `{result['name']}`",
        "",
        Provenance(**result["provenance"]).markdown(),
        *comparison_section(result),
    ]
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
