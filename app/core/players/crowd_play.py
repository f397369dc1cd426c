"""What the crowd models read from played sessions, summed (docs/player-models.md,
"What growth reads of the traces").

Every learned player model reads sessions through three figures only: how often each
control was taken at each vertex, the same counts split into cross-validation folds of
whole sessions, and the median session length (for the restart rate). :class:`PlayCounts`
holds exactly these, summed, so that what an epoch reads is bounded by the size of the
graph, not by how much it has been played; the store keeps the same sums in the database
as traces are accepted (:mod:`app.store.play_counts`).

A session's fold follows from its ordinal, its place (0, 1, ...) among the sessions
learnt, in the order they were accepted: :class:`~app.core.players.session_folds.SessionFolds`
deals sessions to ``k`` folds in turn, session ``i`` to fold ``i % k``. The counts are
summed per bucket ``i % FOLD_BUCKETS``; FOLD_BUCKETS is a multiple of every fold count
from 2 to 6, so every session of bucket ``b`` lies in fold ``b % k``. Pure numpy.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np

from app.core.players.player_models import Trace, trace_edges

#: buckets of sessions' ordinals: 60 is the least common multiple of 2, 3, 4, 5 and 6
FOLD_BUCKETS = 60


def _int_array(values: Iterable[int] | np.ndarray) -> np.ndarray:
    return np.asarray(values, dtype=np.int64).reshape(-1)


@dataclass(frozen=True)
class PlayCounts:
    """Steps summed per (bucket, vertex, control), and sessions per length.

    Rows need not be unique: two rows of one key add up (sums of several sources are
    their rows together, :meth:`merged`). ``lengths`` and ``sessions_of_length`` are a
    histogram of session lengths in steps; sessions without a step are not sessions.
    """

    bucket: np.ndarray
    vertex: np.ndarray
    control: np.ndarray
    steps: np.ndarray
    lengths: np.ndarray
    sessions_of_length: np.ndarray

    def __post_init__(self) -> None:
        for name in ("bucket", "vertex", "control", "steps", "lengths", "sessions_of_length"):
            object.__setattr__(self, name, _int_array(getattr(self, name)))
        if not (self.bucket.size == self.vertex.size == self.control.size == self.steps.size):
            raise ValueError("bucket, vertex, control and steps must have one length")
        if self.lengths.size != self.sessions_of_length.size:
            raise ValueError("lengths and sessions_of_length must have one length")
        if self.bucket.size and not (self.bucket.min() >= 0 and self.bucket.max() < FOLD_BUCKETS):
            raise ValueError(f"buckets must lie in 0..{FOLD_BUCKETS - 1}")
        if (
            (self.steps < 0).any()
            or (self.sessions_of_length < 0).any()
            or (self.lengths < 1).any()
        ):
            raise ValueError("step and session counts must be non-negative, lengths positive")

    @classmethod
    def none(cls) -> PlayCounts:
        """No session at all."""
        return cls(*([np.empty(0, dtype=np.int64)] * 6))

    @classmethod
    def of_traces(cls, traces: Iterable[Trace], first: int = 0) -> PlayCounts:
        """The sums of ``traces``, whose non-empty sessions are numbered from ``first`` on
        (the sessions learnt before them)."""
        sessions = [np.asarray(t, dtype=np.int64).reshape(-1, 2) for t in traces if len(t) > 0]
        if not sessions:
            return cls.none()
        if first < 0:
            raise ValueError(f"the first session's ordinal must be non-negative, got {first}")
        steps = np.concatenate(sessions)
        sizes = np.array([len(s) for s in sessions], dtype=np.int64)
        bucket = np.repeat((first + np.arange(len(sessions))) % FOLD_BUCKETS, sizes)
        lengths, sessions_of_length = np.unique(sizes, return_counts=True)
        return cls(
            bucket, steps[:, 0], steps[:, 1], np.ones(len(steps)), lengths, sessions_of_length
        )

    @classmethod
    def merged(cls, parts: Sequence[PlayCounts]) -> PlayCounts:
        """The sums of every part together."""
        if not parts:
            return cls.none()
        fields = ("bucket", "vertex", "control", "steps", "lengths", "sessions_of_length")
        return cls(*(np.concatenate([getattr(p, name) for p in parts]) for name in fields))

    @property
    def sessions(self) -> int:
        return int(self.sessions_of_length.sum())

    def control_counts(self, n_vertices: int, n_controls: int) -> np.ndarray:
        """How often each control was taken at each vertex, int64 (V, N): what
        :func:`~app.core.players.player_models.observed_control_counts` gives of the sessions.

        Raises ValueError if a step names a vertex or control outside the graph.
        """
        return self._counts(np.ones(self.bucket.size, dtype=bool), n_vertices, n_controls)

    def fold_counts(self, n_folds: int, n_vertices: int, n_controls: int) -> list[np.ndarray]:
        """The control counts of each of ``n_folds`` folds, sessions dealt in turn by
        ordinal. Raises ValueError unless ``n_folds`` divides :data:`FOLD_BUCKETS`."""
        if n_folds < 1 or FOLD_BUCKETS % n_folds:
            raise ValueError(f"{n_folds} folds do not divide {FOLD_BUCKETS} buckets")
        fold = self.bucket % n_folds
        return [self._counts(fold == i, n_vertices, n_controls) for i in range(n_folds)]

    def median_length(self) -> float | None:
        """The median session length, as ``np.median`` of every session's length gives it
        (the mean of the two middle ones for an even count); None without a session."""
        n = self.sessions
        if n == 0:
            return None
        order = np.argsort(self.lengths, kind="stable")
        lengths, cumulative = self.lengths[order], np.cumsum(self.sessions_of_length[order])
        low, high = (
            lengths[np.searchsorted(cumulative, k, side="right")] for k in ((n - 1) // 2, n // 2)
        )
        return (float(low) + float(high)) / 2.0

    def _counts(self, rows: np.ndarray, n_vertices: int, n_controls: int) -> np.ndarray:
        steps = np.stack([self.vertex[rows], self.control[rows]], axis=1)
        edges = trace_edges([steps], n_vertices, n_controls)
        summed = np.bincount(edges, weights=self.steps[rows], minlength=n_vertices * n_controls)
        return summed.astype(np.int64).reshape(n_vertices, n_controls)
