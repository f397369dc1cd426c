"""An experiment's stored checkpoints read back: the result dict, its summary and ratios.

The summary compares strategies at the last checkpoint (mean over seeds) and sr-crowd
with baseline seed by seed, against targets set before any liquid run
(docs/experiment.md); ``app.reports.experiment`` renders the result.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np

from app.config import Settings
from app.core.comparison import (
    SessionSample,
    error_ratio_target,
    meets_targets,
    ratio_interval,
)
from app.core.metrics import relative_difference
from app.core.strategies import Strategy
from app.db.sessions import transaction
from app.services.experiment.plan import ExperimentPlan, stored_experiment_id, stored_plan
from app.services.loading import artifact_store
from app.store.artifacts import ArtifactStore
from app.store.experiments import checkpoint_rows

#: figures that depend on the machine or on the order processes created rows in: two
#: runs of one plan agree on everything else (see :func:`comparable_figures`)
UNCOMPARABLE_KEYS = ("grow_seconds", "checkpoint_seconds", "resident_mb", "publication_id")
#: the high-error fraction is also reported at these multiples of the threshold, fixed
#: beforehand like the visible-error criterion's own halved and doubled limits
THRESHOLD_SENSITIVITY = {"half": 0.5, "double": 2.0}
#: the sr-crowd / baseline ratios of the summary, and the figures they divide
RATIOS = {
    "error_ratio": "observed_mean_error",
    "high_error_ratio": "high_error_fraction",
    **{
        f"high_error_ratio_at_{label}_threshold": f"high_error_fraction_at_{label}_threshold"
        for label in THRESHOLD_SENSITIVITY
    },
}
#: the prediction figures of both settings in the summary (app.core.prediction)
PREDICTION_KEYS = (
    "expected_error_relative_difference",
    "density_correlation",
    "density_tv_distance",
    "per_vertex_bound_relative_difference",
    "predicted_mass_unvisited",
    "observed_mean_error_relative_se",
)


def collect(
    settings: Settings, name: str, seconds: float | None = None, through: int | None = None
) -> dict[str, Any]:
    """Every stored checkpoint of the experiment (up to index ``through``, all when None)
    as the result dict the report reads; ``through`` reports an experiment run so far as
    one whose last checkpoint is that one.

    ``crowds.<bot>`` holds what that crowd met on every run it played, in the shape of a
    one-crowd experiment (``results.<strategy>.<seed>[i]`` and its ``summary``;
    ``app.reports.experiment.crowd_view`` adds the plan); ``comparison.<bot>`` is
    sr-crowd against baseline at every checkpoint, mean over seeds with its interval
    (:func:`compare_with_baseline`).
    """
    plan = stored_plan(settings, name)
    if through is not None:
        plan = replace(plan, checkpoints=plan.checkpoints[: through + 1])
    with transaction(settings) as session:
        rows = checkpoint_rows(session, stored_experiment_id(session, name))
    rows = [row for row in rows if row.checkpoint < len(plan.checkpoints)]
    crowds: dict[str, dict[str, dict[str, list[dict[str, Any]]]]] = {
        bot.value: {s.value: {str(seed): [] for seed in plan.seeds} for s in plan.strategies}
        for bot in plan.bots
    }
    samples: dict[tuple[str, str, str], list[tuple[np.ndarray, np.ndarray, float]]] = {}
    artifacts = artifact_store(settings)
    for row in rows:
        errors, sessions = _step_errors(artifacts, row.arrays)
        threshold = float(row.figures["high_error_threshold"])
        derived = {
            f"high_error_fraction_at_{label}_threshold": float(np.mean(errors > factor * threshold))
            for label, factor in THRESHOLD_SENSITIVITY.items()
        }
        # SIM edges have no error: what separates strategies is how often players meet a
        # blend, and how bad the blends they meet are
        blends = errors[errors > 0.0]
        derived["blend_step_fraction"] = float(blends.size / max(errors.size, 1))
        derived["mean_error_on_blend_steps"] = float(blends.mean()) if blends.size else 0.0
        crowds[row.bot][row.strategy][str(row.seed)].append(
            {**row.figures, **derived, "arrays": row.arrays}
        )
        samples.setdefault((row.bot, row.strategy, str(row.seed)), []).append(
            (errors, sessions, threshold)
        )
    complete = all(
        len(by_seed) == len(plan.checkpoints)
        for results in crowds.values()
        for runs in results.values()
        for by_seed in runs.values()
    )
    return {
        "name": name,
        "plan": plan.to_dict(),
        "complete": complete,
        "crowds": {
            bot: {"results": results, "summary": summarise(results) if complete else {}}
            for bot, results in crowds.items()
        },
        "comparison": compare_with_baseline(plan, samples) if complete else {},
        "seconds": None if seconds is None else round(seconds, 2),
        "through_frames": None if through is None else plan.checkpoints[-1],
    }


def _step_errors(artifacts: ArtifactStore, digest: str) -> tuple[np.ndarray, np.ndarray]:
    """A checkpoint's per-step errors and its sessions' lengths, decoding nothing else;
    checkpoints stored before the lengths were kept count as one session."""
    try:
        arrays = artifacts.get_arrays(digest, ("step_errors", "session_steps"))
    except KeyError:
        errors = artifacts.get_arrays(digest, ("step_errors",))["step_errors"]
        return errors, np.array([errors.size])
    return arrays["step_errors"], arrays["session_steps"]


def compare_with_baseline(
    plan: ExperimentPlan,
    samples: dict[tuple[str, str, str], list[tuple[np.ndarray, np.ndarray, float]]],
) -> dict[str, list[dict[str, Any]]]:
    """Per crowd and checkpoint, sr-crowd / baseline of the observed error and of the
    high-error fraction: mean over seeds, 95 % interval, verdict, and at the last
    checkpoint whether the targets are met; empty without both strategies."""
    names = {s.value for s in plan.strategies}
    if not {Strategy.BASELINE.value, Strategy.SR_CROWD.value} <= names:
        return {}
    comparison: dict[str, list[dict[str, Any]]] = {}
    for bot in (b.value for b in plan.bots):
        rows: list[dict[str, Any]] = []
        for index, frames in enumerate(plan.checkpoints):
            arms = [
                [samples[(bot, strategy, str(seed))][index] for seed in plan.seeds]
                for strategy in (Strategy.SR_CROWD.value, Strategy.BASELINE.value)
            ]
            errors, high = (
                ratio_interval(
                    *[[SessionSample.of(measure(e, t), n) for e, n, t in arm] for arm in arms]
                )
                for measure in (_error, _high_error)
            )
            baseline_high = float(np.mean([np.mean(e > t) for e, _, t in arms[1]]))
            row: dict[str, Any] = {
                "checkpoint_frames": frames,
                "error_ratio": errors.to_dict(),
                "error_verdict": errors.verdict("sr-crowd", "baseline"),
                "high_error_ratio": high.to_dict(),
                "high_error_verdict": high.verdict("sr-crowd", "baseline"),
                "baseline_high_error_fraction": baseline_high,
            }
            if index == len(plan.checkpoints) - 1:
                target = error_ratio_target(bot)
                row["meets_targets"] = meets_targets(errors, high, baseline_high, target)
            rows.append(row)
        comparison[bot] = rows
    return comparison


def _error(errors: np.ndarray, threshold: float) -> np.ndarray:
    return errors


def _high_error(errors: np.ndarray, threshold: float) -> np.ndarray:
    return (errors > threshold).astype(np.float64)


def summarise(results: dict[str, dict[str, list[dict[str, Any]]]]) -> dict[str, object]:
    """Last-checkpoint figures per strategy (mean over seeds) and sr-crowd / baseline ratios."""
    last: dict[str, dict[str, float]] = {}
    for strategy, by_seed in results.items():
        finals = [rows[-1] for rows in by_seed.values()]
        last[strategy] = {
            key: float(np.mean([float(row[key]) for row in finals]))
            for key in (
                "observed_mean_error",
                "high_error_fraction",
                "mean_score_per_step",
                "predicted_expected_error",
                "per_vertex_bound_expected_error",
                "size_frames",
            )
        }
        observed = last[strategy]["observed_mean_error"]
        for key, source in (
            ("expected_error_relative_difference", "predicted_expected_error"),
            ("per_vertex_bound_relative_difference", "per_vertex_bound_expected_error"),
        ):
            # of the seed means, so that one seed's tiny observed error does not dominate
            last[strategy][key] = relative_difference(last[strategy][source], observed)
    summary: dict[str, object] = {
        "last_checkpoint_mean_over_seeds": last,
        "prediction": prediction_summary(results),
    }
    if "baseline" in results and "sr-crowd" in results:
        per_seed: list[dict[str, Any]] = []
        for seed, rows in results["sr-crowd"].items():
            crowd, base = rows[-1], results["baseline"][seed][-1]
            ratios = {name: _ratio(crowd[key], base[key]) for name, key in RATIOS.items()}
            per_seed.append({"seed": seed, **ratios})
        # the targets are judged once, on the mean over seeds with its interval
        # (compare_with_baseline): these are the seeds it averages
        summary["sr_crowd_vs_baseline"] = {"per_seed": per_seed}
    return summary


def prediction_summary(results: dict[str, dict[str, list[dict[str, Any]]]]) -> dict[str, Any]:
    """Per setting and strategy, the last checkpoint's prediction figures, a list per key
    with one entry per seed (in ``seeds``' order): ``fixed_graph`` (Fig. 8, baseline's
    graph) and ``grown_graph`` (Fig. 9, every strategy's own model on its own graph)."""
    settings: dict[str, dict[str, Any]] = {"fixed_graph": {}, "grown_graph": {}}
    for strategy, by_seed in results.items():
        seeds = list(by_seed)
        finals = [by_seed[seed][-1] for seed in seeds]
        settings["grown_graph"][strategy] = {
            "seeds": seeds,
            **{key: [row.get(key) for row in finals] for key in PREDICTION_KEYS},
        }
        fixed = [row["fixed_graph"] for row in finals if "fixed_graph" in row]
        if len(fixed) == len(finals):
            keys = (*PREDICTION_KEYS, "observed_split_half_correlation")
            settings["fixed_graph"][strategy] = {
                "seeds": seeds,
                **{key: [row.get(key) for row in fixed] for key in keys},
            }
    return settings


def comparable_figures(result: dict[str, Any]) -> dict[str, Any]:
    """The result's figures that any run of its plan reproduces exactly (resumed or not,
    in processes or on workers), per crowd: all but :data:`UNCOMPARABLE_KEYS`."""
    return {
        bot: {
            strategy: {
                seed: [{k: v for k, v in row.items() if k not in UNCOMPARABLE_KEYS} for row in rows]
                for seed, rows in by_seed.items()
            }
            for strategy, by_seed in crowd["results"].items()
        }
        for bot, crowd in result["crowds"].items()
    }


def _ratio(numerator: object, denominator: object) -> float | None:
    """numerator / denominator; None when the denominator is 0 (nothing to compare with)."""
    num, den = float(numerator), float(denominator)  # type: ignore[arg-type]
    return num / den if den > 0 else None
