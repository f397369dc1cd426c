"""Synthetic players: they stand in for a crowd where no people play (DESIGN section 6).

Every bot plays a :class:`~app.core.publication.Publication` and returns a trace, rows of
(vertex, control), exactly what a browser uploads. Bots are seeded: the same seed, bot
and publication give the same trace.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import StrEnum

import numpy as np

from app.core.publication import Publication


class BotKind(StrEnum):
    GOAL_DIRECTED = "goal-directed"
    HEURISTIC = "heuristic"
    RANDOM = "random"


@dataclass(frozen=True)
class GoalDirectedBot:
    """Aims at the target: lookahead on clip scores, softmax noise and a reaction delay.

    ``Q_d(v, c) = score(v, c) + discount * max_c' Q_{d-1}(dst(v, c), c')`` over the whole
    publication (dynamic programming, one vectorised pass per level). Values are scaled per
    vertex to [0, 1] before the softmax so that ``temperature`` means the same everywhere;
    a vertex where every choice scores alike gets a uniform choice. The control a bot
    plays was decided ``delay`` steps earlier, as a person reacts late.
    """

    lookahead: int = 4
    discount: float = 0.9
    temperature: float = 0.15
    delay: int = 1

    def policy(self, publication: Publication) -> np.ndarray:
        n = publication.n_controls
        score = publication.edge_score.reshape(-1, n)
        dst = publication.edge_dst.reshape(-1, n)
        value = np.zeros(publication.n_vertices)
        q = score
        for _ in range(self.lookahead):
            q = score + self.discount * value[dst]
            value = q.max(axis=1)
        spread = q.max(axis=1, keepdims=True) - q.min(axis=1, keepdims=True)
        scaled = (q - q.max(axis=1, keepdims=True)) / np.maximum(spread, 1e-12)
        logits = np.where(spread > 1e-9, scaled / self.temperature, 0.0)
        prob = np.exp(logits)
        return prob / prob.sum(axis=1, keepdims=True)


@dataclass(frozen=True)
class HeuristicBot:
    """Plays the bootstrap model: keeps its control with probability ``alpha``."""

    alpha: float = 0.8
    delay: int = 0

    def policy(self, publication: Publication, previous: int) -> np.ndarray:
        prob = np.full(publication.n_controls, (1 - self.alpha) / publication.n_controls)
        prob[previous] += self.alpha
        return prob


def play_session(
    publication: Publication,
    kind: BotKind,
    steps: int,
    rng: np.random.Generator,
    *,
    goal_table: np.ndarray | None = None,
    goal_directed: GoalDirectedBot = GoalDirectedBot(),
    heuristic: HeuristicBot = HeuristicBot(),
) -> np.ndarray:
    """One session of ``steps`` steps from the start vertex: rows of (vertex, control).

    ``goal_table`` is ``goal_directed.policy(publication)``, computed once by the caller
    when many sessions are played on one publication.
    """
    n = publication.n_controls
    trace = np.empty((steps, 2), dtype=np.int64)
    vertex, control = publication.start, 0
    if kind is BotKind.GOAL_DIRECTED and goal_table is None:
        goal_table = goal_directed.policy(publication)
    pending: list[int] = []
    for step in range(steps):
        if kind is BotKind.GOAL_DIRECTED:
            assert goal_table is not None
            pending.append(int(rng.choice(n, p=goal_table[vertex])))
            if len(pending) > goal_directed.delay:
                control = pending.pop(0)
        elif kind is BotKind.HEURISTIC:
            control = int(rng.choice(n, p=heuristic.policy(publication, control)))
        else:
            control = int(rng.integers(n))
        trace[step] = vertex, control
        vertex = publication.destination(vertex, control)
    return trace


def play_sessions(
    publication: Publication,
    kind: BotKind,
    *,
    sessions: int,
    mean_steps: int,
    seed: int,
    goal_directed: GoalDirectedBot = GoalDirectedBot(),
) -> list[np.ndarray]:
    """``sessions`` traces with geometric lengths of mean ``mean_steps`` (at least 2 steps)."""
    rng = np.random.default_rng(seed)
    lengths = np.maximum(rng.geometric(1.0 / mean_steps, size=sessions), 2)
    table = goal_directed.policy(publication) if kind is BotKind.GOAL_DIRECTED else None
    return [
        play_session(publication, kind, int(n), rng, goal_table=table, goal_directed=goal_directed)
        for n in lengths
    ]
