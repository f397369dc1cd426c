"""The report's table of where players met error (:mod:`app.core.evaluation.error_origin`)."""

from __future__ import annotations

from typing import Any

import numpy as np

from app.core.evaluation.error_origin import PARTS


def error_origin_section(result: dict[str, Any]) -> list[str]:
    """Per strategy and checkpoint after the first, the seed means of the error per step
    met on new blends, on old blends the last checkpoint's players took and on old ones
    they did not, each with its share of the whole; then the same parts as the strategy's
    player model predicted them. Nothing where no run has a second checkpoint."""
    rows = [
        _row(strategy, rows)
        for strategy, by_seed in result["results"].items()
        for rows in zip(*by_seed.values(), strict=True)
        if any("error_origin" in r for r in rows)
    ]
    if not rows:
        return []
    return [
        "",
        "## Where players met error",
        "",
        "Error per step on the blends that leave vertices added since the checkpoint "
        "before (new), on older blends that checkpoint's players took, and on older blends "
        "they did not take; seed means, the part's share of the mean error in brackets. "
        "Predicted: the same parts under the play the strategy's model predicted. Large "
        "blends: blends above half the high-error threshold, and the share of the error "
        'met on them (docs/experiment.md, "Where the error lay").',
        "",
        "| strategy | frames | mean error/step | new | old, taken before | old, not taken before "
        "| predicted: new / old taken / old not taken | large blends (share of error) |",
        "|---|---|---|---|---|---|---|---|",
        *rows,
    ]


def _row(strategy: str, rows: tuple[dict[str, Any], ...]) -> str:
    origins = [r["error_origin"] for r in rows if "error_origin" in r]
    observed = {p: float(np.mean([o["observed"][p] for o in origins])) for p in PARTS}
    predicted = {p: float(np.mean([o["predicted"][p] for o in origins])) for p in PARTS}
    total = sum(observed.values())
    cells = [f"{observed[p]:.4g} ({observed[p] / total:.0%})" if total > 0 else "0" for p in PARTS]
    return (
        f"| {strategy} | {rows[0]['size_frames']} | {total:.4g} | "
        + " | ".join(cells)
        + " | "
        + " / ".join(f"{predicted[p]:.2g}" for p in PARTS)
        + f" | {np.mean([o['large_blends'] for o in origins]):.0f} "
        + f"({np.mean([o['large_share'] for o in origins]):.0%}) |"
    )
