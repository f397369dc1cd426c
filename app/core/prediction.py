"""How well a player model predicted play it never saw (paper Figs. 8 and 9, section 7.1).

Both of the paper's settings end here: a model learned from some sessions predicts, through
STATERANK, where other sessions go on one publication, and the prediction is set against
what those sessions did. In the fixed-graph setting (Fig. 8) the two groups of sessions are
halves of one crowd on one publication; in the grown-graph setting (Fig. 9) the model comes
from earlier publications' play and predicts the next one's.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from app.core.metrics import (
    density_agreement,
    observed_edge_density,
    observed_mean_error,
    per_vertex_bound_edge_probabilities,
    predicted_edge_probabilities,
    relative_difference,
)
from app.core.player_models import Trace, observed_control_counts, trace_edges
from app.core.publication import Publication
from app.core.session_figures import SessionFigure
from app.core.staterank import expected_error


def prediction_figures(
    publication: Publication,
    model: np.ndarray,
    restart: float,
    played: Sequence[Trace],
    *,
    learned_from: Sequence[Trace],
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
    predicted = predicted_edge_probabilities(dst, model, publication.start, restart)
    correlation, tv_distance = density_agreement(
        predicted, observed_edge_density(played, err.size, n)
    )
    observed = observed_mean_error(played, err, n)
    forecast = expected_error(predicted, err)
    bound = expected_error(
        per_vertex_bound_edge_probabilities(played, dst, publication.start, fallback=model),
        err,
    )
    visited = observed_control_counts(learned_from, publication.n_vertices, n).sum(axis=1) > 0
    return {
        "observed_mean_error_relative_se": observed_error_relative_se(played, err, n),
        "density_correlation": correlation,
        "density_tv_distance": tv_distance,
        "predicted_expected_error": forecast,
        "observed_mean_error": observed,
        "expected_error_relative_difference": relative_difference(forecast, observed),
        "per_vertex_bound_expected_error": bound,
        "per_vertex_bound_relative_difference": relative_difference(bound, observed),
        "predicted_mass_unvisited": float(predicted.reshape(-1, n).sum(axis=1)[~visited].sum()),
    }


def observed_error_relative_se(played: Sequence[Trace], err: np.ndarray, n_controls: int) -> float:
    """Standard error of the observed mean error per step, relative to it (NaN when it
    cannot be told: fewer than two sessions, or no error met).

    Sessions are resampled, not steps (:class:`~app.core.session_figures.SessionFigure`).
    A prediction cannot be judged closer to the observation than this: with 30 sessions on
    a refined graph, where a few blend steps carry all the error, it is tens of per cent.
    """
    n_vertices = err.size // n_controls
    sums = [float(err[trace_edges([t], n_vertices, n_controls)].sum()) for t in played]
    relative_se = SessionFigure.over_sessions(sums, [len(t) for t in played]).relative_se
    return float("nan") if relative_se is None else relative_se


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
