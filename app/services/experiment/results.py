"""An experiment's stored checkpoints read back: the result dict, its summary and ratios.

The comparison puts sr-crowd against sr-heuristic (the paper's claim: what the traces
add) and both against baseline, per crowd and checkpoint over seeds, against targets set
before any liquid run (docs/experiment.md); the summary gives the last checkpoint's
figures per strategy and the ratios seed by seed. ``app.reports.experiment`` renders it.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np

from app.config import Settings
from app.core.evaluation.comparison import (
    BASELINE,
    CROWD,
    HEURISTIC,
    CheckpointComparison,
    Target,
    compare_checkpoint,
    targets,
)
from app.core.evaluation.error_origin import error_origin
from app.core.evaluation.metrics import relative_difference
from app.db.sessions import transaction
from app.services.experiment.plan import ExperimentPlan, stored_experiment_id
from app.services.experiment.players import kind_of, with_populations
from app.services.loading import artifact_store
from app.store.experiments import checkpoint_rows

#: figures that depend on the machine or on the order processes created rows in: two
#: runs of one plan agree on everything else (see :func:`comparable_figures`)
UNCOMPARABLE_KEYS = ("grow_seconds", "checkpoint_seconds", "resident_mb", "publication_id")
#: the high-error fraction is also reported at these multiples of the threshold, fixed
#: beforehand like the visible-error criterion's own halved and doubled limits
THRESHOLD_SENSITIVITY = {"half": 0.5, "double": 2.0}
#: the per-seed ratios of the summary (sr-crowd / sr-heuristic, sr-crowd / baseline), and
#: the figures they divide
RATIOS = {
    "error_ratio": "observed_mean_error",
    "high_error_ratio": "high_error_fraction",
    **{
        f"high_error_ratio_at_{label}_threshold": f"high_error_fraction_at_{label}_threshold"
        for label in THRESHOLD_SENSITIVITY
    },
}
#: the prediction figures of both settings in the summary (app.core.evaluation.prediction)
PREDICTION_KEYS = (
    "expected_error_relative_difference",
    "density_correlation",
    "density_tv_distance",
    "per_vertex_bound_relative_difference",
    "predicted_mass_unvisited",
    "observed_mean_error_relative_se",
)


def collect(
    settings: Settings,
    name: str,
    plan: ExperimentPlan,
    seconds: float | None = None,
    through: int | None = None,
) -> dict[str, Any]:
    """Every stored checkpoint of the experiment ``name`` of ``plan`` (up to index
    ``through``, all when None)
    as the result dict the report reads; ``through`` reports an experiment run so far as
    one whose last checkpoint is that one.

    ``crowds.<bot>`` holds what that crowd met on every run it played, in the shape of a
    one-crowd experiment (``results.<strategy>.<seed>[i]`` and its ``summary``;
    ``app.reports.experiment.crowd_view`` adds the plan); ``comparison.<bot>[i]`` is
    sr-crowd against sr-heuristic and both against baseline at checkpoint i, over seeds
    with intervals, and the targets (:func:`compare_strategies`).
    """
    final_frames = plan.checkpoints[-1]
    if through is not None:
        plan = replace(plan, checkpoints=plan.checkpoints[: through + 1])
    with transaction(settings) as session:
        rows = checkpoint_rows(session, stored_experiment_id(session, name))
    # a part grown alone (--only-seeds) reports its own seeds
    rows = [
        row for row in rows if row.checkpoint < len(plan.checkpoints) and row.seed in plan.seeds
    ]
    crowds: dict[str, dict[str, dict[str, list[dict[str, Any]]]]] = {
        bot: {s.value: {str(seed): [] for seed in plan.seeds} for s in plan.strategies}
        for bot in plan.players
    }
    samples: dict[tuple[str, str, str, int], tuple[np.ndarray, float]] = {}
    artifacts = artifact_store(settings)
    #: each run's latest checkpoint's arrays: rows come in checkpoint order within a run
    earlier: dict[tuple[str, str, int], dict[str, np.ndarray]] = {}
    for row in rows:
        arrays = artifacts.get_arrays(row.arrays, CHECKPOINT_ARRAYS)
        errors = arrays["step_errors"]
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
        figures = {**row.figures, **derived, "arrays": row.arrays}
        run = (row.bot, row.strategy, row.seed)
        if run in earlier:
            figures["error_origin"] = _error_origin(arrays, earlier[run], row.figures)
        earlier[run] = arrays
        crowds[row.bot][row.strategy][str(row.seed)].append(figures)
        samples[(row.bot, row.strategy, str(row.seed), row.checkpoint)] = (errors, threshold)
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
        "comparison": compare_strategies(plan, samples, final_frames) if complete else {},
        "seconds": None if seconds is None else round(seconds, 2),
        "through_frames": None if through is None else plan.checkpoints[-1],
    }


#: a blend counts as large above this share of the visibility threshold: the lower of the
#: threshold's sensitivity multiples, where a step is half-way to visibly wrong
LARGE_BLEND = THRESHOLD_SENSITIVITY["half"]
#: the arrays :func:`collect` decodes of a checkpoint, each artifact read once
CHECKPOINT_ARRAYS = (
    "step_errors",
    "edge_kind",
    "edge_err",
    "observed_density",
    "predicted_density",
)


def _error_origin(
    arrays: dict[str, np.ndarray], earlier: dict[str, np.ndarray], figures: dict[str, Any]
) -> dict[str, Any]:
    """The split of a checkpoint's error by the age of the blends its players met it on
    (:mod:`app.core.evaluation.error_origin`), against the run's checkpoint before."""
    return error_origin(
        arrays["edge_kind"],
        arrays["edge_err"],
        arrays["observed_density"],
        arrays["predicted_density"],
        earlier["observed_density"],
        arrays["edge_kind"].size // figures["vertices"],
        LARGE_BLEND * float(figures["high_error_threshold"]),
    ).to_dict()


def compare_strategies(
    plan: ExperimentPlan,
    samples: dict[tuple[str, str, str, int], tuple[np.ndarray, float]],
    final_frames: int | None = None,
) -> dict[str, list[dict[str, Any]]]:
    """Per crowd and checkpoint, sr-crowd / sr-heuristic (the headline: what the traces
    add), sr-crowd / baseline and sr-heuristic / baseline of the mean error per step,
    each strategy's visibly-wrong share and sr-crowd's minus sr-heuristic's, with their
    intervals over seeds (:mod:`app.core.evaluation.comparison`); each row holds the targets judged
    at its checkpoint, and the last row whether all of them are met.

    ``samples``: one checkpoint's per-step errors and threshold per (player label,
    strategy, seed, checkpoint index); a population of the plan
    (:attr:`ExperimentPlan.populations`) is judged on its members' steps together.
    ``final_frames``: the stored plan's last checkpoint, where ``plan`` stops earlier (a
    report ``--through``); its bars, unmeasured, go on the last row. A comparison whose
    arms the plan lacks is left out; empty without two of the three strategies.
    """
    planned = {s.value for s in plan.strategies}
    compared = [s for s in (BASELINE, HEURISTIC, CROWD) if s in planned]
    if len(compared) < 2:
        return {}
    samples = _population_samples(plan, samples)
    comparison: dict[str, list[dict[str, Any]]] = {}
    for bot in (*plan.players, *plan.populations):
        points = []
        for index, frames in enumerate(plan.checkpoints):
            played = {
                strategy: [samples[(bot, strategy, str(seed), index)] for seed in plan.seeds]
                for strategy in compared
            }
            points.append(
                compare_checkpoint(
                    frames,
                    {s: [float(np.mean(e)) for e, _ in runs] for s, runs in played.items()},
                    {s: [float(np.mean(e > t)) for e, t in runs] for s, runs in played.items()},
                )
            )
        judged = targets(kind_of(bot), points, final_frames) if CROWD in compared else []
        rows = [_comparison_row(point, judged) for point in points]
        if unreached := [t.to_dict() for t in judged if t.frames > points[-1].frames]:
            rows[-1]["targets"] += unreached
        if judged:
            rows[-1]["meets_targets"] = all(target.met for target in judged)
        comparison[bot] = rows
    return comparison


def _population_samples(
    plan: ExperimentPlan, samples: dict[tuple[str, str, str, int], tuple[np.ndarray, float]]
) -> dict[tuple[str, str, str, int], tuple[np.ndarray, float]]:
    """``samples`` with each population's (:func:`with_populations`), at the threshold of
    the place they were played."""
    threshold = {key[1:]: t for key, (_, t) in samples.items()}
    errors = with_populations(plan.populations, {k: e for k, (e, _) in samples.items()})
    return {key: (e, threshold[key[1:]]) for key, e in errors.items()}


def _comparison_row(point: CheckpointComparison, judged: list[Target]) -> dict[str, Any]:
    row: dict[str, Any] = {"checkpoint_frames": point.frames}
    for key, first, second, compared in (
        ("crowd_vs_heuristic", CROWD, HEURISTIC, point.crowd_vs_heuristic),
        ("crowd_vs_baseline", CROWD, BASELINE, point.crowd_vs_baseline),
        ("heuristic_vs_baseline", HEURISTIC, BASELINE, point.heuristic_vs_baseline),
        ("high_error_difference", CROWD, HEURISTIC, point.high_error_difference),
    ):
        if compared is not None:
            row[key] = compared.to_dict(first, second)
    row["high_error_fraction"] = point.high_error_fraction
    if judged:
        row["targets"] = [t.to_dict() for t in judged if t.frames == point.frames]
    return row


def summarise(results: dict[str, dict[str, list[dict[str, Any]]]]) -> dict[str, object]:
    """Last-checkpoint figures per strategy (mean over seeds) and sr-crowd's ratios to
    sr-heuristic's and baseline's per seed."""
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
    for other in (HEURISTIC, BASELINE):
        if other not in results or CROWD not in results:
            continue
        per_seed: list[dict[str, Any]] = []
        for seed, rows in results[CROWD].items():
            crowd, versus = rows[-1], results[other][seed][-1]
            ratios = {name: _ratio(crowd[key], versus[key]) for name, key in RATIOS.items()}
            per_seed.append({"seed": seed, **ratios})
        # the targets are judged once, on the seeds together with their interval
        # (compare_strategies): these are the seeds it combines
        summary[f"sr_crowd_vs_{other.replace('-', '_')}"] = {"per_seed": per_seed}
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
