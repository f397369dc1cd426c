"""The experiment's prediction and its plan checks (the CLI tests run it end to end)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest
from database_helpers import migrate

from app.config import get_settings
from app.core.bots import play_sessions
from app.core.metrics import CheckpointReport, evaluate_checkpoint
from app.core.player_models import robust_session_length
from app.core.publication import Publication
from app.core.strategies import Strategy
from app.db import get_engine
from app.services import experiment
from app.services.experiment import (
    ExperimentPlan,
    create_experiment,
    parse_checkpoints,
    run_experiment,
)


@pytest.mark.parametrize("text", ["", "a,b", "300,200", "0,100", "100,100"])
def test_bad_checkpoints_are_refused(text: str) -> None:
    with pytest.raises(ValueError, match="checkpoints"):
        parse_checkpoints(text)


def test_prediction_is_for_the_publication_played_from_earlier_traces(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    """Predict, then observe: STATERANK runs on the relinked publication the bots get,
    with rho (and the crowd model) from the traces of earlier publications only."""
    monkeypatch.setenv("SRG_VAR_DIR", str(tmp_path))
    monkeypatch.delenv("SRG_DATABASE_URL", raising=False)
    get_settings.cache_clear()
    get_engine.cache_clear()
    migrate(get_settings().resolved_database_url)
    played: list[Publication] = []
    sessions: list[list[np.ndarray]] = []
    predictions: list[np.ndarray] = []

    def recording_play(publication: Publication, *args: object, **kwargs: Any) -> list:
        played.append(publication)
        sessions.append(play_sessions(publication, *args, **kwargs))  # type: ignore[arg-type]
        return sessions[-1]

    def recording_evaluate(
        traces: Any, err: Any, n: int, predicted: Any, *a: Any, **k: Any
    ) -> CheckpointReport:
        predictions.append(np.asarray(predicted))
        return evaluate_checkpoint(traces, err, n, predicted, *a, **k)

    monkeypatch.setattr(experiment, "play_sessions", recording_play)
    monkeypatch.setattr(experiment, "evaluate_checkpoint", recording_evaluate)
    plan = ExperimentPlan(
        strategies=(Strategy.SR_CROWD,), seeds=(1,), checkpoints=(600, 1_500), sessions=10,
        mean_steps=30,
    )  # fmt: skip
    create_experiment("prediction", plan)
    progress: list[int] = []
    result = run_experiment("prediction", progress=progress.append)
    rows = result["results"]["sr-crowd"]["1"]
    assert sum(progress) >= 1_500
    assert any(int(row["relinked_before_publish"]) > 0 for row in rows)  # type: ignore[call-overload]
    for row, publication, prob in zip(rows, played, predictions, strict=True):
        # stationary on the publication's edges: pi = (1 - rho) inflow + rho at the start
        n = publication.n_controls
        rho = 1.0 / float(row["predicted_session_steps"])  # type: ignore[arg-type]
        pi = prob.reshape(-1, n).sum(axis=1)
        inflow = np.bincount(publication.edge_dst, weights=prob, minlength=pi.size)
        restart = np.zeros_like(pi)
        restart[publication.start] = rho
        np.testing.assert_allclose(pi, (1.0 - rho) * inflow + restart, atol=1e-8)
        assert row["predicted_expected_error"] == pytest.approx(float(prob @ publication.edge_err))
    # the second prediction knows the first publication's sessions, not its own
    settings = get_settings()
    first = robust_session_length(
        sessions[0], default=settings.restart_steps, ceiling=settings.max_session_steps
    )
    assert rows[1]["predicted_session_steps"] == pytest.approx(first)
    assert rows[1]["predicted_session_steps"] != pytest.approx(rows[1]["observed_session_steps"])
    assert rows[0]["predicted_mass_prior_only"] is None
    assert 0.0 <= float(rows[1]["predicted_mass_prior_only"]) <= 1.0  # type: ignore[arg-type]


@pytest.fixture(autouse=True)
def _fresh_settings() -> Any:
    yield
    get_engine().dispose()
    get_settings.cache_clear()
    get_engine.cache_clear()
