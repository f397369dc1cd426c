"""An experiment from its plan to its report in one call: what ``srg experiment`` does.

The plan is read or stored once here and handed down to every run, the results and the
report (docs/experiment.md). Growth runs on the Celery workers through the grower the
shell passes (the services never import the tasks), or else in this process's spawned
run processes.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from contextlib import AbstractContextManager, nullcontext
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import Any

from app.config import Settings
from app.core.growth.kinds import Strategy
from app.reports.experiment import write_report
from app.reports.provenance import with_provenance
from app.services.experiment.ablation import eq2_ingredients
from app.services.experiment.plan import ExperimentPlan, create_experiment, stored_plan
from app.services.experiment.preregistration import check_preregistration
from app.services.experiment.runs import (
    Grower,
    grow_in_process,
    plan_of_runs,
    run_experiment,
    runs_of_seeds,
)
from app.services.loading import artifact_store
from app.services.progress import Advance

#: a progress display for a total of frames, entered while the runs grow
ProgressFor = Callable[[int], AbstractContextManager[Advance | None]]


@dataclass(frozen=True)
class Conducted:
    """What an experiment left: its plan as stored, the result and the report's path."""

    plan: ExperimentPlan
    result: dict[str, Any]
    report: Path


def conduct_experiment(
    settings: Settings,
    name: str,
    plan: ExperimentPlan | None,
    *,
    report_dir: Path,
    workers: Grower | None = None,
    jobs: int | None = None,
    through: int | None = None,
    progress: ProgressFor | None = None,
    only_seeds: tuple[int, ...] | None = None,
) -> Conducted:
    """Store ``plan`` as the experiment ``name`` (None: resume the stored one, its
    pre-registered file checked first), grow and measure every run through the checkpoint
    at ``through`` frames (all when None), and write the report into ``report_dir``.

    ``workers`` grows on the Celery workers (None: in process); ``jobs`` runs go at once
    (default: the cores in process, every run on workers). Every refusal
    (a checkpoint not in the plan, a taken name, a changed pre-registration) comes before
    anything is written.
    """
    resume = plan is None
    if plan is None:
        plan = stored_plan(settings, name)
        check_preregistration(plan)
    last = plan.checkpoint_index(through)  # refused before anything is stored
    runs = runs_of_seeds(plan, only_seeds)
    if not resume:
        plan = create_experiment(settings, name, plan)
    grower: Grower
    if workers is None:
        grower = partial(grow_in_process, settings)
        jobs = jobs or min(os.cpu_count() or 1, len(runs))
    else:
        grower, jobs = workers, jobs or len(runs)
    display = progress or (lambda total: nullcontext(None))
    with display(len(runs) * plan.checkpoints[last]) as advance:
        stop = None if through is None else last
        result = run_experiment(
            settings, name, plan, grower, jobs=jobs, progress=advance, through=stop, runs=runs
        )
    result = with_provenance(result, settings)
    crowd = Strategy.SR_CROWD in plan.strategies and result["complete"]
    shown = plan_of_runs(plan, None if only_seeds is None else runs)
    report = write_report(
        result,
        report_dir,
        artifact_store(settings).get_arrays,
        ingredients=eq2_ingredients(settings, name, shown) if crowd else None,
    )
    return Conducted(plan, result, report)
