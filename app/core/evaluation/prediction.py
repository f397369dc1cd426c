"""How well a player model predicted play it never saw (paper Figs. 8 and 9, section 7.1).

Both of the paper's settings end here: a model learned from some sessions predicts, through
STATERANK, where other sessions go on one publication, and the prediction is set against
what those sessions did. In the fixed-graph setting (Fig. 8) the two groups of sessions are
halves of one crowd on one publication; in the grown-graph setting (Fig. 9) the model comes
from earlier publications' play and predicts the next one's.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from app.core.evaluation.metrics import (
    density_agreement,
    observed_edge_density,
    per_vertex_bound_edge_probabilities,
    relative_difference,
)
from app.core.evaluation.session_figures import SessionFigure
from app.core.graph.publication import Publication
from app.core.graph.staterank import expected_error, predicted_edge_probabilities
from app.core.players.crowd_play import PlayCounts
from app.core.players.player_models import Trace


@dataclass(frozen=True)
class PlayedSessions:
    """Sessions played on one publication, as a prediction is judged against them: their
    sums (where they went) and each session's summed error and length, in one order (how
    sure their observed mean is). The store keeps all three as traces are accepted, so a
    prediction never reads the steps (docs/analytics.md)."""

    counts: PlayCounts
    errors: np.ndarray
    lengths: np.ndarray

    @classmethod
    def of_traces(cls, traces: Sequence[Trace], publication: Publication) -> PlayedSessions:
        """The sessions of ``traces`` (those with a step) played on ``publication``."""
        sessions = [np.asarray(t, dtype=np.int64).reshape(-1, 2) for t in traces if len(t)]
        return cls(
            PlayCounts.of_traces(sessions),
            np.array([publication.step_errors(t).sum() for t in sessions], dtype=np.float64),
            np.array([len(t) for t in sessions], dtype=np.int64),
        )

    def observed_mean_error(self) -> float:
        """Mean error per step. Raises ValueError without a step."""
        if not self.lengths.sum():
            raise ValueError("no session has a step; the observed error is undefined")
        return float(self.errors.sum() / self.lengths.sum())

    def error_relative_se(self) -> float:
        """Standard error of the observed mean error per step, relative to it (NaN when it
        cannot be told: fewer than two sessions, or no error met).

        Sessions are resampled, not steps
        (:class:`~app.core.evaluation.session_figures.SessionFigure`).
        A prediction cannot be judged closer to the observation than this: with 30 sessions
        on a refined graph, where a few blend steps carry all the error, it is tens of per
        cent.
        """
        relative_se = SessionFigure.over_sessions(self.errors, self.lengths).relative_se
        return float("nan") if relative_se is None else relative_se


def prediction_figures(
    publication: Publication,
    model: np.ndarray,
    restart: float,
    played: PlayedSessions,
    *,
    learned_from: PlayCounts,
) -> dict[str, float]:
    """The prediction of ``model`` (P(c|v), restart rate ``restart``) against ``played``.

    - ``density_correlation``, ``density_tv_distance``: predicted against observed edge
      densities;
    - ``predicted_expected_error``, ``observed_mean_error`` and their
      ``expected_error_relative_difference``;
    - ``per_vertex_bound_expected_error`` (and its relative difference): what the
      per-vertex model of ``played`` itself predicts, the best any per-vertex model can;
    - ``predicted_mass_unvisited``: the predicted share of play on vertices that no
      session of ``learned_from`` visited, where the model can only extrapolate.

    Raises ValueError when ``played`` has no step.
    """
    n, err, dst = publication.n_controls, publication.edge_err, publication.edge_dst
    counts = played.counts.control_counts(publication.n_vertices, n)
    observed = played.observed_mean_error()
    predicted = predicted_edge_probabilities(dst, model, publication.start, restart)
    correlation, tv_distance = density_agreement(predicted, counts.reshape(-1) / counts.sum())
    forecast = expected_error(predicted, err)
    bound = expected_error(
        per_vertex_bound_edge_probabilities(
            counts, float(played.lengths.mean()), dst, publication.start, fallback=model
        ),
        err,
    )
    visited = learned_from.control_counts(publication.n_vertices, n).sum(axis=1) > 0
    return {
        "observed_mean_error_relative_se": played.error_relative_se(),
        "density_correlation": correlation,
        "density_tv_distance": tv_distance,
        "predicted_expected_error": forecast,
        "observed_mean_error": observed,
        "expected_error_relative_difference": relative_difference(forecast, observed),
        "per_vertex_bound_expected_error": bound,
        "per_vertex_bound_relative_difference": relative_difference(bound, observed),
        "predicted_mass_unvisited": float(predicted.reshape(-1, n).sum(axis=1)[~visited].sum()),
    }


def split_half_correlation(
    first: Sequence[Trace], second: Sequence[Trace], publication: Publication
) -> float:
    """Correlation of the edge densities two groups of sessions observed on one publication.

    Even a perfect model is compared with a finite sample: this is how well one sample
    agrees with another of the same crowd, a ceiling for ``density_correlation``.
    """
    n_edges, n = publication.edge_err.size, publication.n_controls
    correlation, _ = density_agreement(
        observed_edge_density(first, n_edges, n), observed_edge_density(second, n_edges, n)
    )
    return correlation
