"""One checkpoint of a run: publish, predict, let the bots play, measure.

Predict, then observe: STATERANK's prediction comes from the traces of earlier
checkpoints only, then the bots play the publication and their traces are stored in the
same transaction as the checkpoint's row, so that sr-crowd learns from them as it grows
on (docs/experiment.md).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from sqlalchemy.orm import Session

from app.config import Settings
from app.core.bots import play_sessions
from app.core.metrics import (
    evaluate_checkpoint,
    observed_edge_density,
    observed_step_errors,
    per_vertex_bound_edge_probabilities,
    predicted_edge_probabilities,
)
from app.core.player_models import kernel_support, mean_session_length, observed_control_counts
from app.core.prediction import observed_error_relative_se
from app.core.publication import Publication
from app.core.refinement import Refiner
from app.core.strategies import Strategy
from app.services.experiment.plan import ExperimentPlan
from app.services.loading import open_graph
from app.services.prediction import fixed_graph_prediction, model_fit
from app.services.publishing import publish_graph
from app.services.refining import refiner_for
from app.services.status import graph_summary
from app.store.publications import load_publication
from app.store.traces import bot_player, record_trace

BOT_PLAYER = "bot-experiment"
#: added to a run's seed for the bots of the fixed-graph setting (checkpoints use 0, 1, ...)
FIXED_GRAPH_SEED = 5_000


def checkpoint_figures(
    session: Session,
    settings: Settings,
    plan: ExperimentPlan,
    graph: str,
    strategy: Strategy,
    seed: int,
    index: int,
) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """Publish, predict, let the bots play (traces stored), measure: one checkpoint."""
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
    traces = play_sessions(
        publication,
        plan.bot,
        sessions=plan.sessions,
        mean_steps=plan.mean_steps,
        seed=seed * 10_000 + index,
    )
    n = publication.n_controls
    report = evaluate_checkpoint(
        traces,
        publication.edge_err,
        n,
        predicted,
        plan.high_error_threshold or loaded.dynamics.high_error_threshold,
        bound_edge_prob=per_vertex_bound_edge_probabilities(
            traces, publication.edge_dst, publication.start, fallback=model
        ),
    )
    player_id = bot_player(session, BOT_PLAYER)
    key = f"{graph}.{index}"
    for number, trace in enumerate(traces):
        record_trace(
            session,
            published.publication_id,
            player_id,
            f"{key}.{number}",
            trace,
            publication=publication,
        )
    steps = np.concatenate(traces)
    summary = graph_summary(session, graph)
    figures: dict[str, Any] = {
        "checkpoint_frames": plan.checkpoints[index],
        "size_frames": published.size_frames,
        "vertices": publication.n_vertices,
        "blend_edges": summary["blend_edges"],
        "relinked_before_publish": published.relinked,
        "publication_id": published.publication_id,
        "graph_id": summary["id"],
        "mean_score_per_step": float(publication.edge_score[steps[:, 0] * n + steps[:, 1]].mean()),
        "observed_session_steps": mean_session_length(traces),
        **context,
        **report.to_dict(),
        "model_fit": model_fit(refiner),
        "observed_mean_error_relative_se": observed_error_relative_se(
            traces, publication.edge_err, n
        ),
    }
    if strategy is Strategy.BASELINE and index == len(plan.checkpoints) - 1:
        figures["fixed_graph"] = fixed_graph_prediction(
            settings,
            loaded,
            publication,
            model=plan.player_model,
            bot=plan.bot,
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
    return figures, arrays


def _prediction_context(
    refiner: Refiner, publication: Publication, predicted: np.ndarray
) -> dict[str, float | None]:
    """What the prediction rests on: its session length and, for the crowd model, how
    much predicted play falls on vertices no earlier trace visited and on vertices that
    eq. 2's kernel does not reach (their controls are the eps prior's group average)."""
    context: dict[str, float | None] = {
        "predicted_session_steps": 1.0 / refiner.restart,
        "predicted_mass_unvisited": None,
        "predicted_mass_prior_only": None,
    }
    if not (refiner.strategy.learns_from_traces and refiner.traces):
        return context
    graph, n = refiner.graph, publication.n_controls
    visited = observed_control_counts(refiner.traces, publication.n_vertices, n).sum(axis=1) > 0
    supported = kernel_support(
        graph.vertex_descriptors(),
        np.asarray(graph.vertex_control),
        visited,
        refiner.config.crowd_radius,
    )
    vertex_mass = predicted.reshape(-1, n).sum(axis=1)
    context["predicted_mass_unvisited"] = float(vertex_mass[~visited].sum())
    context["predicted_mass_prior_only"] = float(vertex_mass[~supported].sum())
    return context
