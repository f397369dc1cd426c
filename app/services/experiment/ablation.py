"""Why eq. 2 misses: each of its ingredients varied alone, on an experiment's stored play.

For every sr-crowd checkpoint after the first, eq. 2 is learned from the earlier
checkpoints' traces (the grown-graph setting, paper Fig. 9) as built, and then with one
ingredient changed: the eps prior, the kernel radius (in descriptor units, so also pdist's
scale), the P_obs(u) weighting of visited vertices, and the restart rate (set to the
predicted sessions' own mean length: an oracle). Each variant's prediction of the
checkpoint's play is measured like the experiment's (:func:`prediction_figures`).
docs/player-models.md reads the table.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from app.config import Settings
from app.core.evaluation.prediction import PlayedSessions, prediction_figures
from app.core.growth.kinds import Strategy
from app.core.players.crowd_models.eq2 import crowd_player_model
from app.core.players.crowd_play import PlayCounts
from app.core.players.player_models import (
    heuristic_player_model,
    mean_session_length,
    observed_control_counts,
    robust_session_length,
)
from app.db.sessions import transaction
from app.services.experiment.plan import ExperimentPlan, stored_experiment_id
from app.services.loading import open_graph
from app.services.refining import refiner_config
from app.store.experiments import checkpoint_rows
from app.store.publications import load_publication
from app.store.traces import load_traces

#: (label, radius factor, eps or None for the configured one, weight visits, oracle L)
VARIANTS = (
    ("as built", 1.0, None, True, False),
    ("eps = 0", 1.0, 0.0, True, False),
    ("eps = 0.1", 1.0, 0.1, True, False),
    ("eps = 1", 1.0, 1.0, True, False),
    ("radius / 2", 0.5, None, True, False),
    ("radius x 2", 2.0, None, True, False),
    ("radius x 4", 4.0, None, True, False),
    ("P_obs(c|u) unweighted by visits", 1.0, None, False, False),
    ("L of the predicted sessions", 1.0, None, True, True),
)


def eq2_ingredients(settings: Settings, name: str, plan: ExperimentPlan) -> list[dict[str, Any]]:
    """One row per (crowd, seed, checkpoint, variant) of the sr-crowd runs of the
    experiment ``name`` of ``plan``.

    Judges taught no run, so their rows have none; pooled crowds share their seed's run.
    """
    rows: list[dict[str, Any]] = []
    graphs = {
        (crowd.value, run.seeds[0]): plan.run_graph(name, run)
        for run in plan.runs
        if run.strategy is Strategy.SR_CROWD
        for crowd in run.crowds
    }
    with transaction(settings) as session:
        stored = stored_experiment_id(session, name)
        checkpoints = checkpoint_rows(session, stored, strategy=Strategy.SR_CROWD.value)
        for checkpoint in checkpoints:
            earlier = [
                c.publication_id
                for c in checkpoints
                if (c.bot, c.seed) == (checkpoint.bot, checkpoint.seed)
                and c.checkpoint < checkpoint.checkpoint
            ]
            if not earlier or (checkpoint.bot, checkpoint.seed) not in graphs:
                continue
            loaded = open_graph(session, settings, graphs[(checkpoint.bot, checkpoint.seed)])
            config = refiner_config(settings, loaded.dynamics)
            publication = load_publication(session, checkpoint.publication_id)
            played = load_traces(session, [checkpoint.publication_id])
            past = load_traces(session, earlier)
            v, n = publication.n_vertices, publication.n_controls
            control = np.asarray(loaded.graph.vertex_control[:v])
            descriptors = loaded.graph.vertex_descriptors()[:v]
            counts = observed_control_counts(past, v, n).astype(np.float64)
            per_vertex = counts / np.maximum(counts.sum(axis=1, keepdims=True), 1.0)
            fallback = heuristic_player_model(control, n, config.alpha)
            length = robust_session_length(
                past, default=config.default_session_steps, ceiling=config.max_session_steps
            )
            for label, radius, eps, weighted, oracle in VARIANTS:
                model = crowd_player_model(
                    descriptors,
                    control,
                    counts if weighted else per_vertex,
                    config.crowd_radius * radius,
                    config.crowd_eps if eps is None else eps,
                    fallback=fallback,
                )
                steps = mean_session_length(played) if oracle else length
                figures = prediction_figures(
                    publication,
                    model,
                    1.0 / steps,
                    PlayedSessions.of_traces(played, publication),
                    learned_from=PlayCounts.of_traces(past),
                )
                rows.append(
                    {
                        "bot": checkpoint.bot,
                        "seed": checkpoint.seed,
                        "checkpoint_frames": checkpoint.figures["checkpoint_frames"],
                        "variant": label,
                        **figures,
                    }
                )
    return rows
