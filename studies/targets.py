"""Every bar of the evaluation, judged on the runs the README's results table quotes.

Each report judges its own run's targets, but four of the six crowd-and-fluid claims
grew no baseline: their sr-crowd / baseline bars read "not measured" there. This script
pairs each such run with the run of the same worlds that grew baseline (checked as
``baseline_from.py`` checks it: sr-heuristic's error equal at every checkpoint and seed)
and judges all of them with the code the reports use (``app.core.evaluation.comparison``), so one
table says which bars stand and which do not.

Then, for each crowd with an aim on the low fluid, the chance that three worlds put the
20k interval's upper end below 1 were the geometric mean what was measured and the
worlds to differ by no more than growth's own chaos: sr-crowd's null of
``sel-squared-fresh/factors.py`` (a world's sr-crowd / sr-heuristic, grown again with the
heuristic nudged by 0.01, over the stored one) gives the spread of one world's log ratio
as its root mean square over the square root of 2 (two independent draws), and the
chance is the power of the one-sided t test at 2.5 % with two degrees of freedom. Worlds
that differ by more than chaos make it smaller, so it is an upper end.

    PYTHONPATH=. python studies/targets.py
"""

from __future__ import annotations

import json
import sys
from dataclasses import dataclass

import numpy as np
from baseline_from import RESULTS, checkpoints, same_worlds
from scipy import optimize, stats

from app.core.evaluation.comparison import LEVEL, Target, compare_checkpoint, targets

sys.path.insert(0, str(RESULTS / "sel-squared-fresh"))
from factors import PAIRS, crowd_null  # noqa: E402


@dataclass(frozen=True)
class Claim:
    """One row group of the README's table: the run that grew sr-crowd and sr-heuristic
    for ``crowd`` on ``fluid``, and the run of the same worlds that grew baseline where
    it grew none."""

    fluid: str
    crowd: str
    run: str
    baseline_run: str | None = None


CLAIMS = (
    Claim("low", "goal-directed", "gd-mixed-error-20k-tiny"),
    Claim("low", "avoider", "av-mixed-error-20k-tiny", "avhes-mixed-20k-tiny"),
    Claim("low", "hesitant", "hes-mixed-error-20k-tiny", "avhes-mixed-20k-tiny"),
    Claim("high", "goal-directed", "high-gdav-mixed-error-20k-tiny"),
    Claim("high", "avoider", "high-gdav-mixed-error-20k-tiny"),
    Claim("high", "hesitant", "high-hes-mixed-error-20k-tiny", "high-hes-baseline-20k-tiny"),
)


def points(claim: Claim) -> dict[str, dict[str, dict[int, dict]]]:
    """Per strategy, seed and checkpoint size, the stored figures of ``claim``."""
    if claim.baseline_run is None:
        return checkpoints(claim.run, claim.crowd, ("baseline", "sr-heuristic", "sr-crowd"))
    grown = checkpoints(claim.run, claim.crowd, ("sr-heuristic", "sr-crowd"))
    other = checkpoints(claim.baseline_run, claim.crowd, ("baseline", "sr-heuristic"))
    seeds = sorted(grown["sr-crowd"], key=int)
    for size in grown["sr-crowd"][seeds[0]]:
        if any(size not in other["baseline"].get(seed, {}) for seed in seeds):
            sys.exit(f"{claim.baseline_run} grew no baseline to {size} frames on every seed")
        same_worlds(grown, other, seeds, size)
    return {**grown, "baseline": other["baseline"]}


def judged(claim: Claim) -> list[Target]:
    """The claim's targets over the checkpoints of its plan."""
    figures = points(claim)
    plan = json.loads((RESULTS / claim.run / "result.json").read_text())["plan"]
    seeds = [str(seed) for seed in plan["seeds"]]
    sizes = sorted(figures["sr-crowd"][seeds[0]])
    compared = []
    for planned, size in zip(plan["checkpoints"], sizes, strict=True):
        arms = {strategy: [figures[strategy][s][size] for s in seeds] for strategy in figures}
        compared.append(
            compare_checkpoint(
                planned,
                {k: [p["observed_mean_error"] for p in v] for k, v in arms.items()},
                {k: [p["high_error_fraction"] for p in v] for k, v in arms.items()},
            )
        )
    return targets(claim.crowd, compared)


def chance_below_one(geometric_mean: float, spread: float, worlds: int = 3) -> float:
    """The chance that a t interval on ``worlds`` log ratios, each drawn around
    log(``geometric_mean``) with standard deviation ``spread``, ends below 1."""
    critical = stats.t.ppf(1 - (1 - LEVEL) / 2, worlds - 1)
    shift = -np.log(geometric_mean) * np.sqrt(worlds) / spread
    return float(stats.nct.sf(critical, worlds - 1, shift))


def mean_for_chance(chance: float, spread: float, worlds: int = 3) -> float:
    """The geometric mean at which three worlds of that spread end below 1 with ``chance``."""
    return float(
        optimize.brentq(lambda mean: chance_below_one(mean, spread, worlds) - chance, 1e-6, 1.0)
    )


def main() -> None:
    judgements = {claim: judged(claim) for claim in CLAIMS}
    print("| fluid | crowd | frames | target | value | bar | met |")
    print("|---|---|---|---|---|---|---|")
    for claim, bars in judgements.items():
        for t in bars:
            value = "not measured" if t.value is None else f"{t.value:.3f}"
            print(
                f"| {claim.fluid} | {claim.crowd} | {t.frames} | {t.description} | {value} "
                f"| {t.relation} {t.bar:g} | {'met' if t.met else '**NOT met**'} |"
            )
    print()
    print(
        "met: "
        + "; ".join(
            f"{claim.fluid} {claim.crowd}: {sum(t.met for t in bars)} of {len(bars)}"
            for claim, bars in judgements.items()
        )
    )
    print()
    for claim, bars in judgements.items():
        if claim.fluid != "low" or claim.crowd not in PAIRS:
            continue
        upper = next(t for t in bars if "upper end" in t.description)
        mean = next(t for t in bars if t.description.endswith("error, mean"))
        assert mean.value is not None, "the quoted runs reach every checkpoint judged"
        _, ratio = crowd_null(claim.crowd)[upper.frames]
        spread = float(np.sqrt(np.mean(ratio**2)) / np.sqrt(2))
        print(
            f"{claim.fluid} {claim.crowd} {upper.frames}: mean {mean.value:.2f}, one world's "
            f"chaos {spread:.2f} in log ({ratio.size} worlds nudged): three worlds end "
            f"below 1 with chance at most {chance_below_one(mean.value, spread):.2f}; "
            f"four times in five at a mean of {mean_for_chance(0.8, spread):.3f}"
        )


if __name__ == "__main__":
    main()
