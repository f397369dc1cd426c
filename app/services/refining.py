"""A stored graph's refiner: its strategy, the settings' constants and the crowd's traces.

Growth ranks with it, prediction and the experiment read its player model; all build it
here, so a graph is refined the same way wherever it is.
"""

from __future__ import annotations

import numpy as np
from sqlalchemy.orm import Session

from app.config import Settings
from app.core.graph.dynamics import Dynamics
from app.core.growth.kinds import Strategy, parse_strategy
from app.core.growth.refinement import Refiner, RefinerConfig
from app.core.growth.strategies import EdgeWeights
from app.core.players.crowd_models.registry import CROWD_MODELS
from app.core.players.kinds import PlayerModelKind, PlayerSelection, parse_player_model
from app.services.loading import LoadedGraph
from app.store.epochs import latest_warm_start
from app.store.play_counts import graph_play_counts, publication_play_counts
from app.store.publications import load_publication


def refiner_config(
    settings: Settings, dynamics: Dynamics, player_model: PlayerModelKind = PlayerModelKind.EQ2
) -> RefinerConfig:
    return RefinerConfig(
        alpha=settings.growth.alpha,
        crowd_radius=settings.growth.crowd_radius or dynamics.crowd_radius,
        crowd_eps=settings.growth.crowd_eps,
        default_session_steps=settings.growth.restart_steps,
        max_session_steps=settings.growth.max_session_steps,
        prefilter_k=settings.growth.prefilter_k,
        batch_size=settings.growth.batch_size,
        player_model=player_model,
    )


def refiner_for(
    session: Session, settings: Settings, loaded: LoadedGraph, strategy: Strategy | None = None
) -> Refiner:
    """The graph's refiner, with the crowd's play when its strategy learns from it: the
    sums kept as traces were accepted, never the steps, so that what this reads does not
    grow with how much the graph was played."""
    strategy = strategy or parse_strategy(loaded.entry.strategy)
    refiner = Refiner(
        loaded.graph,
        loaded.bank,
        loaded.dynamics,
        strategy,
        refiner_config(settings, loaded.dynamics, parse_player_model(loaded.entry.player_model)),
    )
    if strategy.learns_from_traces:
        learn_play(session, refiner, loaded.entry.id)
    return refiner


def learn_play(
    session: Session,
    refiner: Refiner,
    graph_id: int,
    players: PlayerSelection = PlayerSelection.ALL,
    *,
    before: int | None = None,
) -> None:
    """Teach ``refiner`` the sums of the sessions ``players`` played on the graph's
    publications (those older than publication ``before`` only, when given): per
    publication, oldest first and each with it, for a crowd model that reads the graph
    its players saw (``reads_publications``: ``mixed-error`` reads its errors); one sum
    over them for the others."""
    if CROWD_MODELS[refiner.config.player_model].reads_publications:
        for publication_id, play in publication_play_counts(
            session, graph_id, players, before=before
        ):
            refiner.learn_counts(play, load_publication(session, publication_id))
    else:
        refiner.learn_counts(graph_play_counts(session, graph_id, players, before=before))


def rank_stored(session: Session, loaded: LoadedGraph, refiner: Refiner) -> EdgeWeights:
    """Edge weights under the refiner's strategy, STATERANK warm-started from the pi the
    graph's last ranking stored (when it still fits the graph)."""
    return refiner.weights(warm_start=_warm_start(session, loaded))


def _warm_start(session: Session, loaded: LoadedGraph) -> np.ndarray | None:
    digest = latest_warm_start(session, loaded.entry.id)
    if digest is None:
        return None
    pi = loaded.artifacts.get_arrays(digest, ("pi",))["pi"]
    return pi if pi.size <= loaded.graph.n_vertices else None
