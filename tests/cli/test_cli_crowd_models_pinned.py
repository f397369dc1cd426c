"""The default crowd model grows a toy experiment to the figures it gave before the crowd
models became estimators (commit d10dfb4): the path a stored result took, through the
store's sums, each publication learnt with its sessions, every checkpoint's model fit.
tests/unit/test_crowd_models_pinned.py pins every kept model on the refiner alone."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import pytest
from cli_helpers import ok

from app.services.experiment.results import comparable_figures

#: sha256 of the sorted JSON of the run's comparable figures, recorded at commit d10dfb4
PINNED = "3306623b4eb1d85e87b5ab61a2985ea61238138e17cd0e29cdb3a64ac1e2a30e"


@pytest.mark.slow
def test_mixed_error_grows_the_toy_experiment_to_its_recorded_figures(tmp_path: Path) -> None:
    ok(tmp_path, "db", "upgrade")
    plan = ("--dynamics", "toy", "--strategies", "sr-crowd", "--seeds", "0")
    grown = ("--checkpoints", "300,600,900", "--sessions", "10", "--player-model", "mixed-error")
    result = tmp_path / "result.json"
    ok(tmp_path, "experiment", *plan, *grown, "--name", "pin", "--result", str(result))
    figures = comparable_figures(json.loads(result.read_text()))
    # the third checkpoint's model chose its share on the second's players: the seam's path
    fit = figures["goal-directed"]["sr-crowd"]["0"][-1]["model_fit"]
    assert fit["unseen_share"] == 0.25 and len(fit["share_scores"]) == 4
    digest = hashlib.sha256(json.dumps(figures, sort_keys=True).encode()).hexdigest()
    assert digest == PINNED
