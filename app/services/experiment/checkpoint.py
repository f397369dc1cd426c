"""One checkpoint of a run: publish, predict, let the bots play, measure.

Predict, then observe: STATERANK's prediction comes from the traces of earlier
checkpoints only, then the bots play the publication and their traces are stored in the
same transaction as the checkpoint's row, so that sr-crowd learns from them as it grows
on (docs/experiment.md).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from sqlalchemy.orm import Session

from app.config import Settings
from app.core.evaluation.metrics import (
    evaluate_checkpoint,
    observed_edge_density,
    observed_step_errors,
    per_vertex_bound_edge_probabilities,
)
from app.core.evaluation.prediction import PlayedSessions
from app.core.graph.publication import Publication
from app.core.graph.staterank import predicted_edge_probabilities
from app.core.growth.kinds import Strategy
from app.core.growth.refinement import Refiner
from app.core.players.bots import play_sessions
from app.core.players.crowd_models.kernel import kernel_support, nearest_visited_distance
from app.core.players.player_models import (
    mean_session_length,
    observed_control_counts,
    trace_edges,
)
from app.services.experiment.plan import ExperimentPlan, Run
from app.services.experiment.players import PlayerGroup
from app.services.loading import LoadedGraph, open_graph
from app.services.play import bots_play
from app.services.prediction import fixed_graph_prediction, model_fit
from app.services.publishing import PublishResult, publish_graph
from app.services.refining import refiner_for
from app.services.status import graph_summary
from app.store.publications import load_publication

BOT_PLAYER = "bot-experiment"
#: added to a run's seed for the bots of the fixed-graph setting (checkpoints use 0, 1, ...)
FIXED_GRAPH_SEED = 5_000
#: added to a run's seed, and the checkpoint's index, for a crowd's fresh judges
FRESH_JUDGE_SEED = 7_000
#: an edge the learned model predicts less than this fraction of the heuristic model's
#: play on is one it does not expect players to take (docs/player-models.md)
UNEXPECTED_FRACTION = 0.1


def checkpoint_figures(
    session: Session,
    settings: Settings,
    plan: ExperimentPlan,
    graph: str,
    run: Run,
    index: int,
) -> list[tuple[tuple[int, str], dict[str, Any], dict[str, np.ndarray]]]:
    """Publish, predict, let the bots of each of the run's seeds and player groups play
    (a crowd's traces stored), measure: one checkpoint, as ((seed, label), figures,
    arrays) per pair.

    The prediction is made once, before anyone plays; a run that several seeds or crowds
    play reads no traces, so what one of them stored changes nothing another measures.
    """
    strategy = run.strategy
    published = publish_graph(session, settings, name=graph, render=False)
    loaded = open_graph(session, settings, graph)
    publication = load_publication(session, published.publication_id)
    # predict, then observe: the model and rho come from earlier checkpoints' traces
    refiner = refiner_for(session, settings, loaded, strategy)
    model = refiner.player_model()
    predicted = predicted_edge_probabilities(
        publication.edge_dst, model, publication.start, refiner.restart
    )
    context = _prediction_context(refiner, publication, predicted)
    unexpected = _unexpected_edges(refiner, publication, predicted)
    context["blend_edges"] = graph_summary(session, graph)["blend_edges"]
    context["model_fit"] = model_fit(refiner)
    predicted_on = _Predicted(published, publication, loaded, model, predicted, context, unexpected)
    last = index == len(plan.checkpoints) - 1
    return [
        _crowd_figures(
            session,
            settings,
            plan,
            predicted_on,
            group,
            seed=seed,
            index=index,
            fixed_graph=strategy is Strategy.BASELINE and last and group.stored,
        )
        for seed in run.seeds
        for group in plan.groups(run)
    ]


@dataclass(frozen=True)
class _Predicted:
    """A checkpoint's publication and the strategy's prediction of its play."""

    published: PublishResult
    publication: Publication
    loaded: LoadedGraph
    model: np.ndarray
    predicted: np.ndarray
    context: dict[str, Any]
    #: edges the learned model expects less than UNEXPECTED_FRACTION of the heuristic's
    #: play on (None for a strategy that learns nothing, or before any trace)
    unexpected: np.ndarray | None


def _crowd_figures(
    session: Session,
    settings: Settings,
    plan: ExperimentPlan,
    on: _Predicted,
    group: PlayerGroup,
    *,
    seed: int,
    index: int,
    fixed_graph: bool,
) -> tuple[tuple[int, str], dict[str, Any], dict[str, np.ndarray]]:
    """One seed's bots of one group play the publication and their figures are taken;
    a crowd's traces are stored (a judge's are not)."""
    published, publication, loaded = on.published, on.publication, on.loaded
    model, predicted = on.model, on.predicted
    bot, sessions = group.bot, group.sessions
    bot_seed = seed * 10_000 + (FRESH_JUDGE_SEED if group.fresh else 0) + index
    if group.stored:
        traces = bots_play(
            session,
            published.publication_id,
            publication,
            bot,
            player=BOT_PLAYER,
            key=f"{published.publication_id}.{seed}.{bot.value}",
            sessions=sessions,
            mean_steps=plan.mean_steps,
            seed=bot_seed,
        )
    else:
        traces = play_sessions(
            publication, bot, sessions=sessions, mean_steps=plan.mean_steps, seed=bot_seed
        )
    n = publication.n_controls
    report = evaluate_checkpoint(
        traces,
        publication.edge_err,
        n,
        predicted,
        plan.high_error_threshold or loaded.dynamics.high_error_threshold,
        bound_edge_prob=per_vertex_bound_edge_probabilities(
            observed_control_counts(traces, publication.n_vertices, n),
            mean_session_length(traces),
            publication.edge_dst,
            publication.start,
            fallback=model,
        ),
    )
    figures: dict[str, Any] = {
        "checkpoint_frames": plan.checkpoints[index],
        "size_frames": published.size_frames,
        "vertices": publication.n_vertices,
        "relinked_before_publish": published.relinked,
        "publication_id": published.publication_id,
        "graph_id": loaded.entry.id,
        "mean_score_per_step": publication.mean_score_per_step(traces),
        "observed_session_steps": mean_session_length(traces),
        **on.context,
        **report.to_dict(),
        "observed_mean_error_relative_se": PlayedSessions.of_traces(
            traces, publication
        ).error_relative_se(),
    }
    if on.unexpected is not None:
        figures.update(_unexpected_play(traces, publication, on.unexpected))
    if fixed_graph:
        figures["fixed_graph"] = fixed_graph_prediction(
            settings,
            loaded,
            publication,
            model=plan.player_model,
            bot=bot,
            sessions=plan.fixed_graph_sessions,
            mean_steps=plan.mean_steps,
            seed=seed * 10_000 + FIXED_GRAPH_SEED,
        )
    arrays = {
        "step_errors": observed_step_errors(traces, publication.edge_err, n),
        "predicted_density": predicted,
        "observed_density": observed_edge_density(traces, publication.edge_err.size, n),
        "edge_dst": publication.edge_dst,
        "edge_kind": publication.edge_kind,
        "edge_err": publication.edge_err,
        "vertex_descriptors": loaded.graph.vertex_descriptors().astype(np.float32),
    }
    return (seed, group.label), figures, arrays


def _unexpected_edges(
    refiner: Refiner, publication: Publication, predicted: np.ndarray
) -> np.ndarray | None:
    """Edges whose predicted P(e) under the learned model is below
    :data:`UNEXPECTED_FRACTION` of the heuristic model's (None where nothing is learned)."""
    if not (refiner.strategy.learns_from_traces and refiner.play.sessions):
        return None
    heuristic = predicted_edge_probabilities(
        publication.edge_dst,
        refiner.heuristic_model()[: publication.n_vertices],
        publication.start,
        refiner.restart,
    )
    return np.asarray(predicted < UNEXPECTED_FRACTION * heuristic)


def _unexpected_play(
    traces: list[np.ndarray], publication: Publication, unexpected: np.ndarray
) -> dict[str, float]:
    """The share of the crowd's steps on edges the learned model did not expect, and
    the share of the error they met there: where a confident model goes wrong."""
    edges = trace_edges(traces, publication.n_vertices, publication.n_controls)
    errors = publication.edge_err[edges]
    on_unexpected = unexpected[edges]
    total = float(errors.sum())
    return {
        "unexpected_step_share": float(on_unexpected.mean()) if edges.size else 0.0,
        "unexpected_error_share": float(errors[on_unexpected].sum() / total) if total else 0.0,
    }


def _prediction_context(
    refiner: Refiner, publication: Publication, predicted: np.ndarray
) -> dict[str, Any]:
    """What the prediction rests on: its session length and, for the crowd model, how
    much predicted play falls on vertices no earlier trace visited and on vertices that
    eq. 2's kernel does not reach (their controls are the eps prior's group average)."""
    context: dict[str, Any] = {
        "predicted_session_steps": 1.0 / refiner.restart,
        "predicted_mass_unvisited": None,
        "predicted_mass_prior_only": None,
        "median_distance_unvisited_to_visited": None,
    }
    if not (refiner.strategy.learns_from_traces and refiner.play.sessions):
        return context
    graph, n = refiner.graph, publication.n_controls
    visited = refiner.play.control_counts(publication.n_vertices, n).sum(axis=1) > 0
    supported = kernel_support(
        graph.vertex_descriptors(),
        np.asarray(graph.vertex_control),
        visited,
        refiner.config.crowd_radius,
    )
    vertex_mass = predicted.reshape(-1, n).sum(axis=1)
    context["predicted_mass_unvisited"] = float(vertex_mass[~visited].sum())
    context["predicted_mass_prior_only"] = float(vertex_mass[~supported].sum())
    # how far eq. 2's kernel would have to reach (its radius: crowd_radius)
    reach = nearest_visited_distance(
        graph.vertex_descriptors()[: publication.n_vertices],
        np.asarray(graph.vertex_control)[: publication.n_vertices],
        visited,
    )
    unvisited = reach[~visited]
    context["median_distance_unvisited_to_visited"] = (
        float(np.median(unvisited)) if unvisited.size and np.isfinite(unvisited).all() else None
    )
    return context
