"""What players saw: error and visit statistics of traces on a publication.

See docs/design.md, "Evaluation".

Every function takes the traces (sequences of (vertex, control) steps), the per-edge error
``err`` indexed by ``e = v * N + c`` (0 on SIM edges, the blend error on BLEND edges) and N.
A step shows one clip of k frames, so "per step" and "fraction of play time" are the same
thing. :func:`evaluate_checkpoint` bundles the numbers of the paper's Figs. 5-9 and its
section 7.1 comparison of predicted and observed expected error.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import asdict, dataclass

import numpy as np

from app.core.graph.staterank import expected_error, predicted_edge_probabilities
from app.core.players.player_models import (
    Trace,
    observed_player_model,
    trace_edges,
)

#: Default histogram resolution: bins of equal width over [0, upper].
HISTOGRAM_BINS = 20
#: evaluate_checkpoint's histogram spans [0, HISTOGRAM_RANGE * high-error threshold], so the
#: threshold is a bin edge and histograms of different graphs share their bins (Fig. 7).
HISTOGRAM_RANGE = 4.0


def observed_step_errors(traces: Iterable[Trace], err: np.ndarray, n_controls: int) -> np.ndarray:
    """Error of the edge taken at every step of every trace, concatenated in order."""
    err = _validated_err(err, n_controls)
    return err[trace_edges(traces, err.size // n_controls, n_controls)]


def observed_mean_error(traces: Iterable[Trace], err: np.ndarray, n_controls: int) -> float:
    """Mean error per step that players saw (Fig. 5). Raises ValueError without steps."""
    return float(_nonempty(observed_step_errors(traces, err, n_controls)).mean())


def high_error_fraction(
    traces: Iterable[Trace], err: np.ndarray, n_controls: int, threshold: float
) -> float:
    """Fraction of steps (= of play time) on edges with error above ``threshold`` (Fig. 6).

    Raises ValueError without steps.
    """
    steps = _nonempty(observed_step_errors(traces, err, n_controls))
    return float(np.mean(steps > threshold))


def error_histogram(
    traces: Iterable[Trace],
    err: np.ndarray,
    n_controls: int,
    upper: float,
    bins: int = HISTOGRAM_BINS,
) -> tuple[np.ndarray, np.ndarray]:
    """Histogram of the errors players saw, over fixed bins (Fig. 7).

    The bins are ``bins`` equal bins over ``[0, upper]`` whatever the data, so histograms
    of different graphs and checkpoints compare bin by bin; errors above ``upper`` are
    counted in the last bin.

    Returns
    -------
    counts : ndarray of int64, shape (bins,)
        Steps per bin; they add up to the number of steps.
    edges : ndarray of float, shape (bins + 1,)
    """
    if upper <= 0.0 or bins < 1:
        raise ValueError(f"need upper > 0 and bins >= 1, got upper={upper}, bins={bins}")
    steps = observed_step_errors(traces, err, n_controls)
    edges = np.linspace(0.0, upper, bins + 1)
    counts, _ = np.histogram(np.minimum(steps, upper), bins=edges)
    return counts.astype(np.int64), edges


def observed_edge_density(traces: Iterable[Trace], n_edges: int, n_controls: int) -> np.ndarray:
    """Share of all steps taken on each edge: the observed P(e), shape (n_edges,), sum 1.

    Raises ValueError without steps.
    """
    if n_edges % n_controls:
        raise ValueError(f"n_edges {n_edges} is not a multiple of n_controls {n_controls}")
    edges = _nonempty(trace_edges(traces, n_edges // n_controls, n_controls))
    return np.bincount(edges, minlength=n_edges) / edges.size


def density_agreement(predicted: np.ndarray, observed: np.ndarray) -> tuple[float, float]:
    """How well predicted edge densities match observed ones (Figs. 8, 9).

    Both are normalised to sum 1 first.

    Returns
    -------
    correlation : float
        Pearson correlation over edges; NaN when either density is constant.
    tv_distance : float
        Total variation distance :math:`\\frac12 \\sum_e |p_e - q_e|` in [0, 1].
    """
    p = np.asarray(predicted, dtype=np.float64)
    q = np.asarray(observed, dtype=np.float64)
    if p.shape != q.shape or p.ndim != 1:
        raise ValueError(f"predicted {p.shape} and observed {q.shape} must be 1-D of one length")
    if np.any(p < 0.0) or np.any(q < 0.0) or p.sum() <= 0.0 or q.sum() <= 0.0:
        raise ValueError("densities must be non-negative and not all zero")
    p = p / p.sum()
    q = q / q.sum()
    tv_distance = 0.5 * float(np.abs(p - q).sum())
    if p.std() == 0.0 or q.std() == 0.0:
        return math.nan, tv_distance
    return float(np.corrcoef(p, q)[0, 1]), tv_distance


def per_vertex_bound_edge_probabilities(
    counts: np.ndarray, mean_length: float, edge_dst: np.ndarray, start: int, fallback: np.ndarray
) -> np.ndarray:
    """P(e) under :func:`~app.core.players.player_models.observed_player_model` of played sessions:
    their control ``counts`` (V, N) and their ``mean_length`` in steps.

    The restart is 1 / L with L the sessions' own mean length, so neither the per-vertex
    controls nor the session length are predicted: what still separates this expected
    error from the observed one is what no per-vertex Markov model can hold (controls that
    depend on more than the vertex) and sampling noise. ``fallback`` is the model for
    vertices no session visited.
    """
    model = observed_player_model(counts, fallback=np.asarray(fallback, dtype=np.float64))
    return predicted_edge_probabilities(edge_dst, model, start, 1.0 / max(mean_length, 1.0))


@dataclass(frozen=True)
class CheckpointReport:
    """The evaluation numbers of one graph at one checkpoint (docs/design.md, "Evaluation")."""

    n_traces: int
    n_steps: int
    observed_mean_error: float
    high_error_threshold: float
    high_error_fraction: float
    histogram_counts: list[int]
    histogram_edges: list[float]
    density_correlation: float
    density_tv_distance: float
    predicted_expected_error: float
    #: (predicted - observed) / observed: -0.5 means the prediction is half the observation
    expected_error_relative_difference: float
    #: expected error under the per-vertex bound (NaN when not given) and its relative
    #: difference to the observed error
    per_vertex_bound_expected_error: float
    per_vertex_bound_relative_difference: float

    def to_dict(self) -> dict[str, object]:
        """Plain JSON-able dict; NaN (undefined correlation or ratio) becomes None."""
        return {
            key: None if isinstance(value, float) and math.isnan(value) else value
            for key, value in asdict(self).items()
        }


def evaluate_checkpoint(
    traces: Sequence[Trace],
    err: np.ndarray,
    n_controls: int,
    predicted_edge_prob: np.ndarray,
    high_error_threshold: float,
    *,
    bins: int = HISTOGRAM_BINS,
    bound_edge_prob: np.ndarray | None = None,
) -> CheckpointReport:
    """Compare what players saw on a graph with what STATERANK predicted for it.

    Parameters
    ----------
    traces : sequence of traces
        The sessions played on the checkpoint's publication.
    err : ndarray, shape (V * N,)
        Per-edge error.
    n_controls : int
        Number of controls N.
    predicted_edge_prob : ndarray, shape (V * N,)
        STATERANK's P(e) (:func:`app.core.graph.staterank.edge_probabilities`).
    high_error_threshold : float
        Error above which a step counts as high-error.
    bins : int
        Histogram bins over ``[0, HISTOGRAM_RANGE * high_error_threshold]``.
    bound_edge_prob : ndarray, shape (V * N,), optional
        P(e) of :func:`per_vertex_bound_edge_probabilities` for the same traces, reported
        next to the prediction as the best any per-vertex model could have predicted.

    Raises ValueError when the traces have no step.
    """
    err = _validated_err(err, n_controls)
    predicted_edge_prob = np.asarray(predicted_edge_prob, dtype=np.float64)
    if predicted_edge_prob.shape != err.shape:
        raise ValueError(
            f"predicted_edge_prob {predicted_edge_prob.shape} and err {err.shape} differ"
        )
    if high_error_threshold <= 0.0:
        raise ValueError(f"high_error_threshold must be positive, got {high_error_threshold}")
    observed_mean = observed_mean_error(traces, err, n_controls)
    counts, edges = error_histogram(
        traces, err, n_controls, HISTOGRAM_RANGE * high_error_threshold, bins
    )
    correlation, tv_distance = density_agreement(
        predicted_edge_prob, observed_edge_density(traces, err.size, n_controls)
    )
    predicted = expected_error(predicted_edge_prob, err)
    bound = math.nan if bound_edge_prob is None else expected_error(bound_edge_prob, err)
    return CheckpointReport(
        n_traces=len(traces),
        n_steps=int(counts.sum()),
        observed_mean_error=observed_mean,
        high_error_threshold=float(high_error_threshold),
        high_error_fraction=high_error_fraction(traces, err, n_controls, high_error_threshold),
        histogram_counts=[int(c) for c in counts],
        histogram_edges=[float(x) for x in edges],
        density_correlation=correlation,
        density_tv_distance=tv_distance,
        predicted_expected_error=predicted,
        expected_error_relative_difference=relative_difference(predicted, observed_mean),
        per_vertex_bound_expected_error=bound,
        per_vertex_bound_relative_difference=relative_difference(bound, observed_mean),
    )


def relative_difference(predicted: float, observed: float) -> float:
    """(predicted - observed) / observed; NaN when ``observed`` is not positive."""
    return (predicted - observed) / observed if observed > 0.0 else math.nan


def _validated_err(err: np.ndarray, n_controls: int) -> np.ndarray:
    err = np.asarray(err, dtype=np.float64)
    if n_controls < 1:
        raise ValueError(f"n_controls must be at least 1, got {n_controls}")
    if err.ndim != 1 or err.size % n_controls:
        raise ValueError(f"err must be 1-D of length V * {n_controls}, got shape {err.shape}")
    return err


def _nonempty(steps: np.ndarray) -> np.ndarray:
    if steps.size == 0:
        raise ValueError("the traces have no step")
    return steps
