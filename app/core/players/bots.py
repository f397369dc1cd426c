"""Synthetic players: they stand in for a crowd where no people play (docs/design.md, "Play").

Every bot plays a :class:`~app.core.graph.publication.Publication` and returns a trace, rows of
(vertex, control), exactly what a browser uploads. Bots are seeded: the same seed, bot
and publication give the same trace.

Three of them aim with one computation, :func:`lookahead_policy`, a softmax over
lookahead values of a per-edge reward: the goal-directed bot chases the clip score, the
hesitant one chases it late, noisily and letting go of the tank, and the avoider chases
the opposite (water kept away from the target). They play unlike one another, so a player
model can be tested against crowds it was not tuned on.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from app.core.graph.publication import Publication
from app.core.players.kinds import BotKind
from app.core.players.lookahead import lookahead_values, scaled_per_vertex

#: the control that leaves the tank level (toy and liquid alike: the tilts are 1 and 2)
LEVEL_CONTROL = 0


def lookahead_policy(
    publication: Publication,
    reward: np.ndarray,
    *,
    lookahead: int,
    discount: float,
    temperature: float,
) -> np.ndarray:
    """Choice probabilities per vertex, shape (n_vertices, n_controls), from a per-edge reward.

    ``Q_d(v, c) = reward(v, c) + discount * max_c' Q_{d-1}(dst(v, c), c')`` over the whole
    publication (dynamic programming, one vectorised pass per level, ``d = lookahead``).
    Values are scaled per vertex to [0, 1] before the softmax so that ``temperature`` means
    the same everywhere; a vertex where every choice scores alike gets a uniform choice.
    ``reward`` is indexed like the publication's edges (``vertex * n_controls + control``).
    """
    q = lookahead_values(publication.edge_dst, reward, publication.n_controls, lookahead, discount)
    prob = np.exp(scaled_per_vertex(q) / temperature)
    return prob / prob.sum(axis=1, keepdims=True)


@dataclass(frozen=True)
class _PlanningBot:
    """What the bots that plan share: :func:`lookahead_policy` of some clip values, with
    softmax noise, played ``delay`` steps after it was decided (a person reacts late)."""

    lookahead: int = 4
    discount: float = 0.9
    temperature: float = 0.15
    delay: int = 1

    def _aim(self, publication: Publication, values: np.ndarray) -> np.ndarray:
        return lookahead_policy(
            publication,
            values,
            lookahead=self.lookahead,
            discount=self.discount,
            temperature=self.temperature,
        )


@dataclass(frozen=True)
class GoalDirectedBot(_PlanningBot):
    """Aims at the target: plans on the clip scores."""

    def policy(self, publication: Publication) -> np.ndarray:
        return self._aim(publication, publication.edge_score)


@dataclass(frozen=True)
class HesitantBot(_PlanningBot):
    """Means to reach the target but reacts late, wavers and often lets the tank go level.

    The goal-directed choice with a higher ``temperature`` (noisier), played ``delay``
    steps after it was decided (a slow reaction); at each step, with probability
    ``level_rate``, the player lets go instead and the tank goes level
    (:data:`LEVEL_CONTROL`), whatever the state. With ``level_rate = 0`` and a low
    temperature it plays the goal-directed decisions, ``delay`` steps late.
    """

    temperature: float = 0.5
    delay: int = 3
    level_rate: float = 0.4

    def policy(self, publication: Publication) -> np.ndarray:
        prob = (1.0 - self.level_rate) * self._aim(publication, publication.edge_score)
        prob[:, LEVEL_CONTROL] += self.level_rate
        return prob


@dataclass(frozen=True)
class AvoiderBot(_PlanningBot):
    """Chases another goal: keeps the water away from the target.

    It plans on the negated clip scores, so it steers towards clips that leave the target
    window dry. A crowd of avoiders visits the part of the graph goal-directed players
    leave alone.
    """

    delay: int = 2

    def policy(self, publication: Publication) -> np.ndarray:
        return self._aim(publication, -publication.edge_score)


@dataclass(frozen=True)
class HeuristicBot:
    """Plays the bootstrap model: keeps its control with probability ``alpha``."""

    alpha: float = 0.8
    delay: int = 0

    def policy(self, publication: Publication, previous: int) -> np.ndarray:
        prob = np.full(publication.n_controls, (1 - self.alpha) / publication.n_controls)
        prob[previous] += self.alpha
        return prob


#: the bots that play from a per-vertex table of choice probabilities, with a delay
TableBot = GoalDirectedBot | HesitantBot | AvoiderBot


def table_bot(
    kind: BotKind,
    goal_directed: GoalDirectedBot,
    hesitant: HesitantBot,
    avoider: AvoiderBot,
) -> TableBot | None:
    """The bot of ``kind`` if it plays from a table, else None."""
    bots: dict[BotKind, TableBot] = {
        BotKind.GOAL_DIRECTED: goal_directed,
        BotKind.HESITANT: hesitant,
        BotKind.AVOIDER: avoider,
    }
    return bots.get(kind)


def play_session(
    publication: Publication,
    kind: BotKind,
    steps: int,
    rng: np.random.Generator,
    *,
    table: np.ndarray | None = None,
    goal_directed: GoalDirectedBot = GoalDirectedBot(),
    heuristic: HeuristicBot = HeuristicBot(),
    hesitant: HesitantBot = HesitantBot(),
    avoider: AvoiderBot = AvoiderBot(),
) -> np.ndarray:
    """One session of ``steps`` steps from the start vertex: rows of (vertex, control).

    ``table`` is the policy of the bot of ``kind`` (goal-directed, hesitant or avoider),
    computed once by the caller when many sessions are played on one publication. Those
    bots decide at every step and play the decision ``delay`` steps later; until the
    first decision arrives the tank stays level.
    """
    n = publication.n_controls
    trace = np.empty((steps, 2), dtype=np.int64)
    vertex, control = publication.start, LEVEL_CONTROL
    bot = table_bot(kind, goal_directed, hesitant, avoider)
    if bot is not None and table is None:
        table = bot.policy(publication)
    pending: list[int] = []
    for step in range(steps):
        if bot is not None:
            assert table is not None
            pending.append(int(rng.choice(n, p=table[vertex])))
            if len(pending) > bot.delay:
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
    hesitant: HesitantBot = HesitantBot(),
    avoider: AvoiderBot = AvoiderBot(),
) -> list[np.ndarray]:
    """``sessions`` traces with geometric lengths of mean ``mean_steps`` (at least 2 steps)."""
    rng = np.random.default_rng(seed)
    lengths = np.maximum(rng.geometric(1.0 / mean_steps, size=sessions), 2)
    bot = table_bot(kind, goal_directed, hesitant, avoider)
    table = bot.policy(publication) if bot is not None else None
    return [
        play_session(
            publication,
            kind,
            int(n),
            rng,
            table=table,
            goal_directed=goal_directed,
            hesitant=hesitant,
            avoider=avoider,
        )
        for n in lengths
    ]
