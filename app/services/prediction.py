"""How well a player model predicts play, on stored graphs (docs/player-models.md).

Two uses: the experiment's fixed-graph setting (paper Fig. 8: one publication, one crowd
of bots split in halves, a model learned from one half predicting the other), and
``srg analytics``, which tells an operator how well the graph's model predicted the play
of its latest publication from the play of the earlier ones (paper Fig. 9's setting, on
real players' traces).
"""

from __future__ import annotations

from typing import Any

from sqlalchemy.orm import Session

from app.config import Settings
from app.core.evaluation.prediction import (
    PlayedSessions,
    prediction_figures,
    split_half_correlation,
)
from app.core.graph.publication import Publication
from app.core.growth.kinds import Strategy
from app.core.growth.refinement import Refiner
from app.core.players.bots import play_sessions
from app.core.players.kinds import BotKind, PlayerModelKind, PlayerSelection, parse_player_model
from app.services.loading import LoadedGraph, open_graph
from app.services.refining import learn_play, refiner_config
from app.store.play_counts import played_sessions
from app.store.publications import load_publication
from app.store.traces import played_publications


def crowd_refiner(settings: Settings, loaded: LoadedGraph, model: PlayerModelKind) -> Refiner:
    """A refiner of the graph that learns the crowd model ``model``, whatever its strategy."""
    config = refiner_config(settings, loaded.dynamics, model)
    return Refiner(loaded.graph, loaded.bank, loaded.dynamics, Strategy.SR_CROWD, config)


def model_fit(refiner: Refiner) -> dict[str, Any] | None:
    """What the fit chose for the learned model, with every candidate's score (None
    before any trace, and for eq. 2, which chooses nothing): the shrunk models' radius
    and prior weight, ``mixed-error``'s share of heuristic players."""
    if not refiner.play.sessions:
        return None
    return refiner.crowd_model().figures()


def fixed_graph_prediction(
    settings: Settings,
    loaded: LoadedGraph,
    publication: Publication,
    *,
    model: PlayerModelKind,
    bot: BotKind,
    sessions: int,
    mean_steps: int,
    seed: int,
) -> dict[str, Any]:
    """Fig. 8's setting: ``2 x sessions`` bot sessions on ``publication``, learn from one
    half, predict the other (none of them stored: they measure, they do not grow)."""
    traces = play_sessions(
        publication, bot, sessions=2 * sessions, mean_steps=mean_steps, seed=seed
    )
    learn, held_out = traces[0::2], traces[1::2]
    refiner = crowd_refiner(settings, loaded, model)
    refiner.learn(learn, publication)
    figures: dict[str, Any] = prediction_figures(
        publication,
        refiner.player_model(),
        refiner.restart,
        PlayedSessions.of_traces(held_out, publication),
        learned_from=refiner.play,
    )
    figures["observed_split_half_correlation"] = split_half_correlation(
        learn, held_out, publication
    )
    figures["sessions_per_half"] = sessions
    figures["model_fit"] = model_fit(refiner)
    return figures


def latest_play_prediction(
    session: Session,
    settings: Settings,
    name: str | int,
    model: str | None = None,
    players: PlayerSelection = PlayerSelection.ALL,
) -> dict[str, Any] | None:
    """How well the graph's crowd model, learned from every publication's play but the
    latest one's, predicts the latest one's; None before ``players`` played two
    publications. Only their sessions teach the model and are predicted.

    It reads the sums kept as traces were accepted, never the steps, so it answers as
    fast after millions of sessions as after a few (docs/analytics.md). The sessions
    learnt keep their ordinals in the graph, so their folds are those growth deals.
    """
    loaded = open_graph(session, settings, name)
    played = played_publications(session, loaded.entry.id, players)
    if len(played) < 2:
        return None
    chosen = parse_player_model(model or loaded.entry.player_model)
    refiner = crowd_refiner(settings, loaded, chosen)
    learn_play(session, refiner, loaded.entry.id, players, before=played[-1])
    latest, predicted = (
        load_publication(session, played[-1]),
        played_sessions(session, played[-1], players),
    )
    figures: dict[str, Any] = prediction_figures(
        latest,
        refiner.player_model(on=latest),
        refiner.restart,
        predicted,
        learned_from=refiner.play,
    )
    figures["player_model"] = chosen.value
    figures["publications_learned_from"] = len(played) - 1
    figures["sessions_learned_from"] = refiner.play.sessions
    figures["sessions_predicted"] = predicted.counts.sessions
    figures["model_fit"] = model_fit(refiner)
    return figures
