"""The report's prediction sections: both of the paper's settings, and eq. 2's ingredients."""

from __future__ import annotations

from collections import defaultdict
from typing import Any

import numpy as np

SETTINGS = {
    "fixed_graph": "fixed graph (Fig. 8): baseline's last publication, one crowd in halves",
    "grown_graph": "grown graph (Fig. 9): each run's own model on its next publication",
}


def settings_section(result: dict[str, Any]) -> list[str]:
    """``summary.prediction``: per setting and strategy, the last checkpoint's figures."""
    prediction = result["summary"].get("prediction")
    if not prediction:
        return []
    plan = result["plan"]
    lines = [
        "",
        "## How well the player model predicts play (Figs. 8, 9)",
        "",
        f"Player model of sr-crowd: `{plan.get('player_model', 'eq2')}`; bots: "
        f"`{plan.get('bot', 'goal-directed')}`; fixed-graph setting: "
        f"{plan.get('fixed_graph_sessions', 100)} sessions per half. Values per seed, "
        "last checkpoint. Targets: fixed graph within 10 % and density correlation >= 0.9; "
        "grown graph within 10 % (toy) or 20 % (liquid). The split-half correlation is how "
        "well the two halves' own densities agree: a ceiling for any model. The observed error's "
        "relative standard error (sessions bootstrapped) is how far the observation itself "
        "may be from the truth: no prediction can be judged closer than that.",
        "",
        "| setting | strategy | rel. diff. of expected error | density corr. | TV "
        "| bound rel. diff. | mass on unvisited | split-half corr. | observed error's rel. SE |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for setting, by_strategy in prediction.items():
        for strategy, figures in by_strategy.items():
            lines.append(
                f"| {setting} | {strategy} "
                f"| {_values(figures['expected_error_relative_difference'], '{:+.0%}')} "
                f"| {_values(figures['density_correlation'])} "
                f"| {_values(figures['density_tv_distance'])} "
                f"| {_values(figures['per_vertex_bound_relative_difference'], '{:+.0%}')} "
                f"| {_values(figures['predicted_mass_unvisited'])} "
                f"| {_values(figures.get('observed_split_half_correlation', []))} "
                f"| {_values(figures.get('observed_mean_error_relative_se', []), '{:.0%}')} |"
            )
    lines += ["", *(f"- {name}: {text}" for name, text in SETTINGS.items())]
    return lines


def ingredients_section(rows: list[dict[str, Any]]) -> list[str]:
    """Eq. 2 with one ingredient changed (app.services.experiment.ablation), seed means."""
    if not rows:
        return []
    grouped: dict[tuple[str, int], list[dict[str, Any]]] = defaultdict(list)
    for row in rows:
        grouped[(row["variant"], row["checkpoint_frames"])].append(row)
    lines = [
        "",
        "## Eq. 2's ingredients, one at a time (grown-graph setting, sr-crowd)",
        "",
        "Eq. 2 learned from the earlier checkpoints' traces predicts each checkpoint's play. "
        "Means over seeds.",
        "",
        "| variant | frames | rel. diff. of expected error | density corr. | TV "
        "| mass on unvisited |",
        "|---|---|---|---|---|---|",
    ]
    for (variant, frames), group in grouped.items():

        def mean(key: str, group: list[dict[str, Any]] = group) -> float:
            return float(np.mean([row[key] for row in group]))

        lines.append(
            f"| {variant} | {frames} | {mean('expected_error_relative_difference'):+.0%} "
            f"| {mean('density_correlation'):.2f} | {mean('density_tv_distance'):.2f} "
            f"| {mean('predicted_mass_unvisited'):.2f} |"
        )
    return lines


def _values(values: list[float | None], form: str = "{:.2f}") -> str:
    shown = ["n/a" if v is None or np.isnan(v) else form.format(v) for v in values]
    return ", ".join(shown) if shown else "n/a"
