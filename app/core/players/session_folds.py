"""Held-out log-likelihood of sessions' controls: how the learned player models choose
their hyper-parameters (docs/player-models.md).

Whole sessions are dealt to folds in turn, by the order they were accepted in (their
ordinals, :mod:`app.core.players.crowd_play`); each fold's controls are scored by the model
learned from the other folds' control counts. Pure numpy.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from app.core.players.crowd_play import PlayCounts

FOLDS = 5
#: a learned model: the (V, N) control counts of the sessions it learns from in, P(c|v) out
LearnedModel = Callable[[np.ndarray], np.ndarray]


@dataclass(frozen=True)
class SessionFolds:
    """The control counts of each fold of the sessions, and of all of them."""

    fold_counts: tuple[np.ndarray, ...]
    total: np.ndarray

    @classmethod
    def of(
        cls, play: PlayCounts, n_vertices: int, n_controls: int, folds: int = FOLDS
    ) -> SessionFolds:
        """Deal the sessions to ``folds`` folds (at least 2, at most one per session).
        Raises ValueError when no trace has a step."""
        if play.sessions == 0:
            raise ValueError("no trace has a step: nothing to cross-validate on")
        n_folds = max(2, min(folds, play.sessions))
        counts = tuple(play.fold_counts(n_folds, n_vertices, n_controls))
        return cls(counts, np.sum(counts, axis=0))

    def score(self, learned: LearnedModel) -> float:
        """Mean log-likelihood per step of every fold under the model of the others."""
        total_ll = sum(
            _log_likelihood(learned(self.total - fold), fold) for fold in self.fold_counts
        )
        return total_ll / float(self.total.sum())


def _log_likelihood(model: np.ndarray, counts: np.ndarray) -> float:
    return float(np.sum(counts * np.log(np.maximum(model, 1e-300))))
