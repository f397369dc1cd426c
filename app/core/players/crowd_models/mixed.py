"""``mixed``: ``shrunk``, ranked for players the traces have not seen
(docs/player-models.md, "`mixed`").

``shrunk`` ranks for the crowd that left the traces; a player unlike it meets the graph
sr-crowd grew for someone else, and no trace can say how many future players are like
that. So ``mixed`` ranks for a population of which a fixed share
(:data:`UNSEEN_SHARE`, one half) plays as the heuristic model
predicts and the rest as ``shrunk`` predicts (app.core.growth.strategies.mixed_weights).
P(c|v) and every prediction stay ``shrunk``'s.
"""

from __future__ import annotations

from dataclasses import replace
from typing import ClassVar

from app.core.players.crowd_models.estimator import CrowdGraph, CrowdPlay
from app.core.players.crowd_models.shrunk import FittedShrunk, Shrunk
from app.core.players.kinds import PlayerModelKind

#: the share of the population ``mixed`` ranks for as heuristic players: players the
#: traces have not seen. Fixed beforehand as half (docs/player-models.md, "`mixed`");
#: ``mixed-error`` chooses it per world instead (app.core.players.crowd_models.mixed_error), from
#: this one until its players have met error on two publications
UNSEEN_SHARE = 0.5


class Mixed:
    """``shrunk``'s P(c|v), half the ranking's population heuristic players."""

    kind: ClassVar[PlayerModelKind] = PlayerModelKind.MIXED
    reads_publications: ClassVar[bool] = False

    def fit(self, graph: CrowdGraph, play: CrowdPlay) -> FittedShrunk:
        return replace(Shrunk().fit(graph, play), unseen_share=UNSEEN_SHARE)
