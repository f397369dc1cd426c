"""Refiners on a small toy tree, for tests that compare crowd models on one graph."""

from __future__ import annotations

from app.core.graph.clipbank import MemoryClipBank
from app.core.graph.toy import ToyDynamics
from app.core.growth.expansion import initial_tree
from app.core.growth.kinds import Strategy
from app.core.growth.refinement import Refiner, RefinerConfig
from app.core.players.kinds import PlayerModelKind


def toy_refiners(*kinds: PlayerModelKind, strategy: Strategy = Strategy.SR_CROWD) -> list[Refiner]:
    """One refiner per crowd model, all on one toy tree (depth 3, eq. 2's radius 0.5)."""
    dyn = ToyDynamics()
    bank = MemoryClipBank()
    graph = initial_tree(dyn, bank, depth=3, prefilter_k=10)
    return [
        Refiner(graph, bank, dyn, strategy, RefinerConfig(crowd_radius=0.5, player_model=kind))
        for kind in kinds
    ]
