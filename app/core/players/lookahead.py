"""Lookahead values over a published graph: what the aiming bots weigh (``app.core.players.bots``).

Only the bots read them: a player model judged by these bots must not contain their
policy (the import contract on ``app.core.players.crowd_models``, pyproject.toml).
"""

from __future__ import annotations

import numpy as np

#: a vertex whose choices' values spread less than this is flat: every choice alike
FLAT_SPREAD = 1e-9


def lookahead_values(
    edge_dst: np.ndarray, reward: np.ndarray, n_controls: int, horizon: int, discount: float
) -> np.ndarray:
    """Q(v, c), shape (V, N): the edge's reward plus the discounted best value on from its
    destination, ``horizon`` steps in all (dynamic programming, one pass per step).

    ``Q_1 = reward``; ``Q_h(v, c) = reward(v, c) + discount * max_c' Q_{h-1}(dst(v, c), c')``.
    Both arrays are indexed like a publication's edges (``vertex * n_controls + control``).
    """
    if horizon < 1 or not 0.0 <= discount <= 1.0:
        raise ValueError(f"need horizon >= 1 and discount in [0, 1], got {horizon}, {discount}")
    score = np.asarray(reward, dtype=np.float64).reshape(-1, n_controls)
    dst = np.asarray(edge_dst, dtype=np.int64).reshape(-1, n_controls)
    q = score
    for _ in range(horizon - 1):
        q = score + discount * q.max(axis=1)[dst]
    return q


def scaled_per_vertex(q: np.ndarray) -> np.ndarray:
    """Per vertex, (q - max) / spread in [-1, 0]; 0 where the vertex is flat.

    So that a softmax temperature, or a logit weight, means the same at every vertex.
    """
    spread = q.max(axis=1, keepdims=True) - q.min(axis=1, keepdims=True)
    scaled = (q - q.max(axis=1, keepdims=True)) / np.maximum(spread, 1e-12)
    return np.where(spread > FLAT_SPREAD, scaled, 0.0)
