"""Every product crowd model grows the toy exactly as it did when its figures were reported.

The stored results (studies/) were grown by these models; a refactor of the models,
their seam or the refiner that moves one bit of what they grow moves those figures too.
So a toy sr-crowd graph is grown under each kept kind, three publications played by
goal-directed bots and learnt (each with its publication, as growth learns them), and a
digest of what came out is compared with the one recorded before the crowd models became
estimators (commit d10dfb4): the grown graph, the last P(c|v) and the last ranking's weights.
Bit for bit, as the experiment's comparable figures are: a digest of rounded figures would
let a small move through.
"""

from __future__ import annotations

import hashlib

import numpy as np
import pytest

from app.core.graph.clipbank import MemoryClipBank
from app.core.graph.toy import ToyDynamics
from app.core.growth.expansion import initial_tree
from app.core.growth.kinds import Strategy
from app.core.growth.refinement import Refiner, RefinerConfig
from app.core.players.bots import play_sessions
from app.core.players.kinds import BotKind, PlayerModelKind

#: sha256 of :func:`grown`'s arrays per kind, recorded at commit d10dfb4
PINNED = {
    PlayerModelKind.EQ2: "9e5ed164ef94bf60151e207faacca32dd83a6ebc4c4ae182df8098630b5194ce",
    PlayerModelKind.SHRUNK: "2898161e353e324406b975d38902ded161a52409ce46ad63d776060b072973d8",
    PlayerModelKind.MIXED: "02ae6e3e6de99f5df2e0d373423e2ead10aa22ce5031f3294f5b3138417c532e",
    PlayerModelKind.MIXED_ERROR: "d3e4daa7f8cb2645809f96930bc113d1040472f07179335f588434e7d7dc5c55",
}


def grown(kind: PlayerModelKind) -> list[np.ndarray]:
    """Three rounds of publish, play (10 goal-directed sessions), learn, grow 8 blends;
    then the graph's edges, their errors, P(c|v) and the ranking's weights."""
    dynamics = ToyDynamics()
    bank = MemoryClipBank()
    graph = initial_tree(dynamics, bank, depth=3, prefilter_k=10)
    config = RefinerConfig(crowd_radius=0.5, prefilter_k=10, player_model=kind)
    refiner = Refiner(graph, bank, dynamics, Strategy.SR_CROWD, config)
    for round_ in range(3):
        publication = refiner.publish()[0]
        traces = play_sessions(
            publication, BotKind.GOAL_DIRECTED, sessions=10, mean_steps=20, seed=round_
        )
        refiner.learn(traces, publication)
        refiner.grow(expansions=8)
    return [
        np.asarray(graph.edge_dst, dtype=np.int64),
        np.asarray(graph.edge_err, dtype=np.float64),
        refiner.player_model(),
        refiner.weights().weights,
    ]


def digest(arrays: list[np.ndarray]) -> str:
    sha = hashlib.sha256()
    for array in arrays:
        sha.update(str(array.shape).encode())
        sha.update(np.ascontiguousarray(array).tobytes())
    return sha.hexdigest()


@pytest.mark.parametrize("kind", list(PINNED))
def test_a_kept_model_grows_the_toy_as_it_did(kind: PlayerModelKind) -> None:
    assert digest(grown(kind)) == PINNED[kind]
