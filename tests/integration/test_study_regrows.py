"""Nothing moves: one world of the outside-the-loop study regrown at today's code gives
the figures its runs stored (studies/outside-the-loop/plan.md, section 2).

``tests/data/outside-the-loop-world20.json`` holds world 20's comparable figures at the
study's first two checkpoints (1k, 2k: sr-crowd has learned from the 1k traces by
2k), read from the study's database: the plan, then per player label, strategy and
checkpoint every figure that any run of the plan reproduces (``comparable_figures``),
less the fixed-graph setting, which a plan computes at its own last checkpoint. A change
of growth, play, the crowd model or the figures fails here before a resume of the study
could mix two codes. Regenerate only with a deviation written in the study.
"""

from __future__ import annotations

import json
from dataclasses import replace
from functools import partial
from pathlib import Path
from typing import Any

import pytest
from database_helpers import migrate

from app.config import get_settings
from app.services.experiment.plan import ExperimentPlan, create_experiment
from app.services.experiment.results import comparable_figures
from app.services.experiment.runs import grow_in_process, run_experiment

STORED = Path(__file__).resolve().parents[1] / "data" / "outside-the-loop-world20.json"
#: what a plan computes at its own last checkpoint, not at the study's
PLAN_DEPENDENT = ("fixed_graph",)


def world_figures(result: dict[str, Any], seed: str, checkpoints: int) -> dict[str, Any]:
    """One world's comparable figures at the first ``checkpoints`` checkpoints."""
    return {
        label: {
            strategy: [
                {k: v for k, v in row.items() if k not in PLAN_DEPENDENT}
                for row in by_seed[seed][:checkpoints]
            ]
            for strategy, by_seed in strategies.items()
        }
        for label, strategies in comparable_figures(result).items()
    }


@pytest.mark.slow
def test_world_20_regrows_to_the_studys_stored_figures(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    stored = json.loads(STORED.read_text())
    plan = ExperimentPlan.from_dict(stored["plan"])
    plan = replace(plan, seeds=(20,), checkpoints=plan.checkpoints[:2], preregistration=None)
    monkeypatch.setenv("SRG_VAR_DIR", str(tmp_path))
    monkeypatch.delenv("SRG_DATABASE_URL", raising=False)
    migrate(get_settings().resolved_database_url)
    settings = get_settings()
    plan = create_experiment(settings, "world20", plan)
    result = run_experiment(settings, "world20", plan, partial(grow_in_process, settings), jobs=3)
    assert world_figures(result, "20", 2) == stored["figures"]
