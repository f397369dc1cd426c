"""A player model that generalises to states nobody visited: a logit prior under eq. 2.

Eq. 2 (:func:`~app.core.player_models.crowd_player_model`) answers for a vertex by
the choices made at visited vertices that look alike, and elsewhere by its eps prior: the
control frequencies of the vertex's whole control group, whatever its state. A graph that
grows adds vertices faster than players visit them, and most of the next publication's
play falls where eq. 2 has only that prior. What players do there is not unknowable: they
play a game with a goal, and the graph says where each choice leads.

So the prior here is a multinomial logit over features of each (vertex, control)::

    P_logit(c | v) = exp(F[v, c] . w) / sum_c' exp(F[v, c'] . w)

- ``goal``: the expected clip score of taking c at v and then ``horizon - 1`` controls
  drawn uniformly, discounted by ``discount`` (:func:`goal_values`), scaled per vertex
  to [-1, 0]. It is written apart from how any bot decides (the bots look ahead for the
  best path, ``app.core.lookahead``), so that the model does not contain the policy of the
  bots that judge it, and its grid holds none of their parameters;
- ``goal_before``: the same at the vertex's parent, for players who react late;
- ``keep``: c is the control that produced v (players hold a tilt);
- one indicator per control but the first (a bias per control).

and the evidence is eq. 2's kernel-weighted counts K (:func:`kernel_counts`), as in a
Dirichlet posterior with ``prior_weight`` pseudo-steps of the logit::

    P(c | v) = (K[v, c] + prior_weight * P_logit(c | v)) / (sum_c K[v, c] + prior_weight)

Where players went often, their choices rule; where nobody went, the goal does. Every
session's choices are explained by the graph it was played on (a publication). The
weights are fitted by maximum likelihood with a ridge penalty; ``horizon``, ``discount``,
the penalty and ``prior_weight`` are chosen by K-fold cross-validation over whole
sessions (:func:`fit_choice_model`). docs/player-models.md gives the reasons and the
measurements. Pure numpy/scipy.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import minimize
from scipy.special import logsumexp

from app.core.crowd_play import PlayCounts
from app.core.player_models import kernel_counts
from app.core.publication import Publication

FEATURE_NAMES = ("goal", "goal_before", "keep")
#: the grid cross-validation searches: steps of the goal value, discount, ridge penalty
#: per step
HORIZONS = (1, 2, 3, 6)
DISCOUNTS = (0.5, 1.0)
PENALTIES = (1e-4, 1e-2)
#: pseudo-steps of the logit prior against eq. 2's kernel counts
PRIOR_WEIGHTS = (0.3, 1.0, 3.0, 10.0, 30.0)
FOLDS = 5


@dataclass(frozen=True)
class ChoiceGraph:
    """What the features are computed from: the graph's edges, scores and lineage."""

    edge_dst: np.ndarray  # (V * N,) destination vertex of every edge
    edge_score: np.ndarray  # (V * N,) score of every edge's clip
    vertex_control: np.ndarray  # (V,) control of the clip that produced each vertex
    vertex_parent: np.ndarray  # (V,) source vertex of that clip; the start is its own
    n_controls: int

    @property
    def n_vertices(self) -> int:
        return int(self.vertex_control.size)

    @classmethod
    def of(
        cls, publication: Publication, vertex_control: np.ndarray, vertex_parent: np.ndarray
    ) -> ChoiceGraph:
        """The publication's edges and scores, with the lineage of the (grown) graph.

        ``vertex_control`` and ``vertex_parent`` may describe a larger graph: vertices are
        only appended, so its first ``publication.n_vertices`` entries are this one's.
        """
        v = publication.n_vertices
        return cls(
            np.asarray(publication.edge_dst, dtype=np.int64),
            np.asarray(publication.edge_score, dtype=np.float64),
            np.asarray(vertex_control[:v], dtype=np.int64),
            np.asarray(vertex_parent[:v], dtype=np.int64),
            publication.n_controls,
        )


@dataclass(frozen=True)
class Kernel:
    """What eq. 2's kernel needs: every vertex's descriptor and control, and its radius."""

    descriptors: np.ndarray  # (V, D), of the graph the model answers for
    vertex_control: np.ndarray  # (V,)
    radius: float

    def counts(self, control_counts: np.ndarray) -> np.ndarray:
        """K: the kernel-weighted counts of ``control_counts`` (V, N) at every vertex."""
        return kernel_counts(self.descriptors, self.vertex_control, control_counts, self.radius)


@dataclass(frozen=True)
class ChoiceModel:
    """Fitted weights and the hyper-parameters cross-validation chose."""

    weights: np.ndarray
    horizon: int
    discount: float
    penalty: float
    prior_weight: float
    #: mean held-out log-likelihood per step of every grid point, for the report
    cv_scores: dict[str, float] = field(default_factory=dict)

    def logit(self, graph: ChoiceGraph) -> np.ndarray:
        """P_logit(c|v) for every vertex of ``graph``: shape (V, N), rows summing to 1."""
        return _softmax(choice_features(graph, self.horizon, self.discount) @ self.weights)

    def probabilities(self, graph: ChoiceGraph, evidence: np.ndarray) -> np.ndarray:
        """P(c|v) for every vertex of ``graph`` given the kernel counts ``evidence`` (V, N)."""
        return _posterior(evidence, self.logit(graph), self.prior_weight)


def goal_values(graph: ChoiceGraph, horizon: int, discount: float) -> np.ndarray:
    """G(v, c), shape (V, N): the expected discounted clip score of ``horizon`` steps that
    take c at v, then controls drawn uniformly at every step.

    ``G_1 = score``; ``G_h(v, c) = score(v, c) + discount * mean_c' G_{h-1}(dst(v, c), c')``.
    Where a choice leads matters, not what a player then does best: a state that keeps
    water near the target under any play scores high.
    """
    if horizon < 1 or not 0.0 <= discount <= 1.0:
        raise ValueError(f"need horizon >= 1 and discount in [0, 1], got {horizon}, {discount}")
    score = np.asarray(graph.edge_score, dtype=np.float64).reshape(-1, graph.n_controls)
    dst = np.asarray(graph.edge_dst, dtype=np.int64).reshape(-1, graph.n_controls)
    value = score
    for _ in range(horizon - 1):
        value = score + discount * value.mean(axis=1)[dst]
    return value


def scaled_goal(goal: np.ndarray) -> np.ndarray:
    """Per vertex, (goal - max) / spread in [-1, 0]; 0 where every choice scores alike
    (spread below 1e-9), so that one logit weight means the same at every vertex."""
    top = goal.max(axis=1, keepdims=True)
    spread = top - goal.min(axis=1, keepdims=True)
    return np.where(spread > 1e-9, (goal - top) / np.maximum(spread, 1e-12), 0.0)


def choice_features(graph: ChoiceGraph, horizon: int, discount: float) -> np.ndarray:
    """The features of every (vertex, control): shape (V, N, 3 + N - 1)."""
    n, v = graph.n_controls, graph.n_vertices
    goal = scaled_goal(goal_values(graph, horizon, discount))
    parent = np.asarray(graph.vertex_parent, dtype=np.int64)
    keep = np.zeros((v, n))
    keep[np.arange(v), np.asarray(graph.vertex_control, dtype=np.int64)] = 1.0
    bias = np.broadcast_to(np.eye(n)[1:].T, (v, n, n - 1))
    return np.concatenate([goal[:, :, None], goal[parent][:, :, None], keep[:, :, None], bias], 2)


@dataclass(frozen=True)
class PlayedGraph:
    """Sessions, summed, and the graph they were played on (a publication: what players
    saw)."""

    graph: ChoiceGraph
    play: PlayCounts


def fit_choice_model(
    played: Sequence[PlayedGraph],
    kernel: Kernel,
    *,
    horizons: Sequence[int] = HORIZONS,
    discounts: Sequence[float] = DISCOUNTS,
    penalties: Sequence[float] = PENALTIES,
    prior_weights: Sequence[float] = PRIOR_WEIGHTS,
    folds: int = FOLDS,
) -> ChoiceModel:
    """The model fitted on all sessions, its hyper-parameters chosen by cross-validation.

    Each session's choices are explained by the features of the graph it was played on:
    a vertex's edges, and so its goal values, change as the graph grows. Vertex indices
    are shared (a graph only appends vertices), so ``kernel`` describes the largest graph
    and the evidence of every fold is pooled by vertex. Sessions are dealt to ``folds``
    folds in turn by their ordinals, numbered across the graphs. First the logit's grid
    is scored by the mean held-out log-likelihood per step of the logit alone, then
    ``prior_weight`` by that of the posterior with the chosen logit; the best of each is
    refitted on every session. Raises ValueError when no session has a step.
    """
    sessions = sum(p.play.sessions for p in played)
    if sessions == 0:
        raise ValueError("no trace has a step: nothing to learn a player model from")
    k = max(2, min(folds, sessions))
    folded = _folded_counts(played, k)  # [graph][fold] -> (V_g, N) counts
    totals = [np.sum(counts, axis=0) for counts in folded]
    steps = float(sum(t.sum() for t in totals))
    scores: dict[str, float] = {}
    best: tuple[float, int, float, float] | None = None
    for horizon in horizons:
        for discount in discounts:
            features = [choice_features(p.graph, horizon, discount) for p in played]
            for penalty in penalties:
                held_out = 0.0
                for i in range(k):
                    train = _stacked(
                        features, [t - c[i] for t, c in zip(totals, folded, strict=True)]
                    )
                    weights = _fit(*train, penalty)
                    held_out += _log_likelihood(
                        *_stacked(features, [c[i] for c in folded]), weights
                    )
                score = held_out / steps
                scores[f"horizon={horizon} discount={discount} penalty={penalty}"] = score
                if best is None or score > best[0]:
                    best = (score, horizon, discount, penalty)
    assert best is not None
    _, horizon, discount, penalty = best
    features = [choice_features(p.graph, horizon, discount) for p in played]
    held_out_posterior = dict.fromkeys(prior_weights, 0.0)
    for i in range(k):
        train_counts = [t - c[i] for t, c in zip(totals, folded, strict=True)]
        weights = _fit(*_stacked(features, train_counts), penalty)
        logits = [_softmax(f @ weights) for f in features]
        evidence = kernel.counts(_pooled(train_counts, kernel.vertex_control.size))
        for prior_weight in prior_weights:
            for logit, counts in zip(logits, folded, strict=True):
                posterior = _posterior(evidence[: logit.shape[0]], logit, prior_weight)
                held_out_posterior[prior_weight] += float(
                    np.sum(counts[i] * np.log(np.maximum(posterior, 1e-300)))
                )
    for prior_weight, total in held_out_posterior.items():
        scores[f"prior_weight={prior_weight}"] = total / steps
    prior_weight = max(prior_weights, key=lambda w: held_out_posterior[w])
    weights = _fit(*_stacked(features, totals), penalty)
    return ChoiceModel(weights, horizon, discount, penalty, prior_weight, scores)


def _folded_counts(played: Sequence[PlayedGraph], k: int) -> list[list[np.ndarray]]:
    """Per graph, per fold, the (V_g, N) control counts of the fold's sessions."""
    return [p.play.fold_counts(k, p.graph.n_vertices, p.graph.n_controls) for p in played]


def _pooled(counts: Sequence[np.ndarray], n_vertices: int) -> np.ndarray:
    """Counts of several graphs summed by vertex, on ``n_vertices`` rows."""
    pooled = np.zeros((n_vertices, counts[0].shape[1]))
    for c in counts:
        pooled[: c.shape[0]] += c
    return pooled


def _posterior(evidence: np.ndarray, logit: np.ndarray, prior_weight: float) -> np.ndarray:
    weighted = evidence + prior_weight * logit
    return weighted / weighted.sum(axis=1, keepdims=True)


def _stacked(
    features: Sequence[np.ndarray], counts: Sequence[np.ndarray]
) -> tuple[np.ndarray, np.ndarray]:
    """The visited rows of every graph, as one (R, N, K) features and (R, N) counts."""
    rows = [c.sum(axis=1) > 0 for c in counts]
    return (
        np.concatenate([f[r] for f, r in zip(features, rows, strict=True)]),
        np.concatenate([c[r] for c, r in zip(counts, rows, strict=True)]).astype(np.float64),
    )


def _fit(features: np.ndarray, counts: np.ndarray, penalty: float) -> np.ndarray:
    """Maximum-likelihood weights (ridge ``penalty`` per step) for visited rows' counts."""
    steps = max(float(counts.sum()), 1.0)
    visits = counts.sum(axis=1)

    def objective(w: np.ndarray) -> tuple[float, np.ndarray]:
        z = features @ w
        lse = logsumexp(z, axis=1)
        p = np.exp(z - lse[:, None])
        nll = float(visits @ lse - np.sum(counts * z)) / steps + 0.5 * penalty * float(w @ w)
        # d nll / dw: per row, (expected - taken) choices times the features, per step
        grad = np.einsum("rn,rnk->k", visits[:, None] * p - counts, features) / steps
        return nll, grad + penalty * w

    # BFGS, not L-BFGS-B: a handful of weights, and L-BFGS-B's BLAS threads cost more to
    # wake than the work (fits 2.5 x slower on two busy cores)
    start = np.zeros(features.shape[2])
    return np.asarray(minimize(objective, start, jac=True, method="BFGS").x)


def _log_likelihood(features: np.ndarray, counts: np.ndarray, weights: np.ndarray) -> float:
    z = features @ weights
    return float(np.sum(counts * (z - logsumexp(z, axis=1)[:, None])))


def _softmax(z: np.ndarray) -> np.ndarray:
    return np.exp(z - logsumexp(z, axis=1, keepdims=True))
