"""The human form of ``srg analytics``: tables headed in words, one number format per column.

The JSON keeps the snake_case keys scripts read; a person reads ``mean error``, and a
column whose rows are printed with different precision (``1``, ``0.5``, ``0.3333``) reads
as different quantities. So every column says how it is printed: counts with thousands
separators, shares and standard errors as percentages, and measured quantities with the
decimals that give the column's largest value three significant digits (the smaller ones
line up under it).
"""

from __future__ import annotations

import math
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

from rich import box
from rich.console import Console
from rich.table import Table

Format = Callable[[Sequence[Any]], list[str]]


def counts(values: Sequence[Any]) -> list[str]:
    return [f"{int(v):,}" for v in values]


def shares(values: Sequence[Any]) -> list[str]:
    return [f"{v:.1%}" for v in values]


def relative_errors(values: Sequence[Any]) -> list[str]:
    """Standard errors relative to their figure, in whole per cents (under one per cent says
    so rather than ±0 %); a dash where there is none to tell."""
    return [
        "-" if v is None or math.isnan(v) else "<1%" if v < 0.005 else f"±{v:.0%}" for v in values
    ]


def measures(values: Sequence[Any]) -> list[str]:
    """Every value with the decimals that give the largest three significant digits."""
    present = [abs(v) for v in values if v is not None and math.isfinite(v)]
    largest = max(present, default=0.0)
    decimals = 3 if largest == 0.0 else max(0, 2 - math.floor(math.log10(largest)))
    return ["-" if v is None or not math.isfinite(v) else f"{v:.{decimals}f}" for v in values]


def differences(values: Sequence[Any]) -> list[str]:
    """Relative differences, signed, as percentages."""
    return [f"{v:+.1%}" for v in values]


@dataclass(frozen=True)
class Column:
    key: str
    header: str
    format: Format


#: a table of one figure per row: groups of like figures, each group printed alike
Figures = tuple[tuple[Format, tuple[tuple[str, str], ...]], ...]

OBSERVED_ERROR = (
    Column("number", "publication", counts),
    Column("sessions", "sessions", counts),
    Column("steps", "steps", counts),
    Column("mean_error", "mean error", measures),
    Column("mean_error_relative_se", "std. error", relative_errors),
    Column("high_error_fraction", "high-error share", shares),
    Column("high_error_fraction_relative_se", "std. error", relative_errors),
)
VISITS = (
    Column("vertex", "vertex", counts),
    Column("visits", "steps from it", counts),
    Column("sessions", "sessions", counts),
)
CONTROLS = (
    Column("vertex", "vertex", counts),
    Column("control", "control", counts),
    Column("n", "steps", counts),
    Column("p", "probability", measures),
)
SESSION_LENGTHS: Figures = (
    (counts, (("sessions", "sessions"),)),
    (measures, (("mean", "mean"),)),
    (relative_errors, (("mean_relative_se", "standard error of the mean"),)),
    (
        counts,
        (
            ("min", "shortest"),
            ("p50", "median"),
            ("p90", "90th percentile"),
            ("p99", "99th percentile"),
            ("max", "longest"),
        ),
    ),
)
PREDICTION: Figures = (
    (
        measures,
        (
            ("predicted_expected_error", "predicted expected error"),
            ("observed_mean_error", "observed mean error"),
            ("per_vertex_bound_expected_error", "best per-vertex model's expected error"),
        ),
    ),
    (
        differences,
        (
            ("expected_error_relative_difference", "predicted against observed"),
            ("per_vertex_bound_relative_difference", "best per-vertex model against observed"),
        ),
    ),
    (
        measures,
        (
            ("density_correlation", "visit density correlation"),
            ("density_tv_distance", "visit density distance (total variation)"),
        ),
    ),
    (shares, (("predicted_mass_unvisited", "predicted play on vertices never visited"),)),
)
#: what the fit chose for a learned model (app.services.prediction.model_fit, each fitted
#: crowd model's ``figures``)
MODEL_FIT = {
    "radius": "kernel radius",
    "prior_weight": "prior weight",
    "cv_scores": "held-out log-likelihood per step by candidate",
    "unseen_share": "share of heuristic players ranked for",
    "share_scores": "latest publication's error-weighted log score by share",
}


def rows_table(
    console: Console, title: str, columns: Sequence[Column], rows: Sequence[dict[str, Any]]
) -> Table | str:
    """A table of ``rows`` under ``columns``; a line saying so when there is none.

    Headers stay on one line where the table fits the terminal; where it does not, they
    wrap at their spaces, never inside a word (which rich would cut short).
    """
    if not rows:
        return f"{title}: no sessions"
    cells = [column.format([row[column.key] for row in rows]) for column in columns]
    widest = [max(len(cell) for cell in column) for column in cells]
    for header_width in (len, lambda header: max(len(word) for word in header.split())):
        out = Table(title=title, box=box.SIMPLE_HEAD)
        for column, width in zip(columns, widest, strict=True):
            out.add_column(
                column.header, justify="right", width=max(header_width(column.header), width)
            )
        unbounded = console.options.update_width(sys.maxsize)  # measure() clamps to it
        if console.measure(out, options=unbounded).maximum <= console.width:
            break
    for row in zip(*cells, strict=True):
        out.add_row(*row)
    return out


def figures_table(
    title: str, figures: Figures, values: dict[str, Any], caption: str | None = None
) -> Table:
    """One figure per row, its name in words beside its value."""
    out = Table(title=title, caption=caption, box=box.SIMPLE_HEAD)
    out.add_column("figure")
    out.add_column("value", justify="right")
    for format_, rows in figures:
        shown = format_([values[key] for key, _ in rows])
        for (_, name), value in zip(rows, shown, strict=True):
            out.add_row(name, value)
    return out


def print_report(report: dict[str, Any], top: int) -> None:
    console = Console()
    kinds = report["sessions_by_kind"]
    console.print(
        f"players: {report['players']} (sessions on this graph: {kinds['person']:,} by people, "
        f"{kinds['bot']:,} by bots)",
        markup=False,
    )
    threshold = report["threshold"]
    console.print(
        rows_table(
            console,
            f"observed error (threshold {threshold:g})",
            OBSERVED_ERROR,
            report["observed_error"],
        )
    )
    lengths = dict(report["session_lengths"])
    lengths.update(lengths.pop("percentiles"))
    if lengths["sessions"]:
        console.print(figures_table("session lengths (steps)", SESSION_LENGTHS, lengths))
    else:
        console.print("session lengths (steps): no sessions")
    visits = report["visit_counts"][:top]
    console.print(rows_table(console, f"visits (top {top} vertices)", VISITS, visits))
    shown = {row["vertex"] for row in visits}
    controls = [r for r in report["control_probabilities"] if r["vertex"] in shown]
    title = "observed control probabilities (those vertices)"
    console.print(rows_table(console, title, CONTROLS, controls))
    _print_prediction(console, report["prediction"])
    for warning in report["warnings"]:  # one line each, for grep
        console.print(f"warning: {warning['message']}", markup=False, soft_wrap=True)


def _print_prediction(console: Console, prediction: dict[str, Any] | None) -> None:
    """The latest publication's play against what the crowd model predicted for it."""
    if prediction is None:
        console.print("prediction: fewer than two publications played, nothing to compare yet")
        return
    caption = (
        f"the {prediction['player_model']} model, learned from "
        f"{prediction['sessions_learned_from']} sessions on "
        f"{prediction['publications_learned_from']} earlier publication(s), against "
        f"{prediction['sessions_predicted']} sessions on the latest"
    )
    title = "prediction of the latest publication's play"
    console.print(figures_table(title, PREDICTION, prediction, caption))
    if prediction["model_fit"] is not None:
        fit = "; ".join(
            f"{MODEL_FIT[k]} {_fit_value(v)}" for k, v in prediction["model_fit"].items()
        )
        console.print(f"model fit: {fit}", markup=False, soft_wrap=True)


def _fit_value(value: Any) -> str:
    """A model-fit value: numbers to four significant digits, lists and maps flattened,
    "none" where nothing was chosen."""
    if isinstance(value, dict):
        return ", ".join(f"{k}: {_fit_value(v)}" for k, v in value.items())
    if isinstance(value, list):
        return ", ".join(_fit_value(v) for v in value)
    if value is None:
        return "none"
    return f"{value:.4g}" if isinstance(value, float) else str(value)
