"""Which (radius, prior weight) of `shrunk` predicts the next publication's players?

Run from the repository with the experiment's settings (SRG_DATABASE_URL and the rest):
    python docs/results/sel-gd20k-mixed-tiny/forward.py EXPERIMENT LATEST SEED [SEED ...]
For each seed's sr-crowd graph: learnt from the sessions of publications 1..LATEST-1,
the 5-fold choice (what growth used), the choice scored on publication LATEST-1's
sessions under the model of the ones before it (forward), and the best; each with its
log-likelihood per step of publication LATEST's sessions (the players to come).
"""

import sys

import numpy as np
from app.core.shrunk_model import (
    PRIOR_WEIGHTS,
    RADIUS_SCALES,
    fit_shrunk_model,
    shrunk_player_model,
)

from app.config import Settings
from app.core.players.crowd_play import PlayCounts
from app.core.players.player_models import heuristic_player_model
from app.db.sessions import transaction
from app.services.loading import open_graph
from app.store.play_counts import publication_play_counts


def seed_line(settings: Settings, name: str, latest: int, seed: str) -> str:
    with transaction(settings) as session:
        loaded = open_graph(session, settings, f"{name}.sr-crowd.{seed}")
        pubs = publication_play_counts(session, loaded.entry.id)
    graph = loaded.graph
    n_vertices, n_controls = graph.n_vertices, graph.n_controls
    control, descriptors = np.asarray(graph.vertex_control), graph.vertex_descriptors()
    prior = heuristic_player_model(control, n_controls, settings.growth.alpha)
    base = settings.growth.crowd_radius or loaded.dynamics.crowd_radius
    counts = [play.control_counts(n_vertices, n_controls).astype(float) for _, play in pubs]
    learnt, earlier = sum(counts[: latest - 1]), sum(counts[: latest - 2])
    held, future = counts[latest - 2], counts[latest - 1]

    def loglik(model: np.ndarray, steps: np.ndarray) -> float:
        return float(np.sum(steps * np.log(np.maximum(model, 1e-300))) / steps.sum())

    def model(key: tuple[float, float], evidence: np.ndarray) -> np.ndarray:
        radius = base * key[0]
        return shrunk_player_model(descriptors, control, evidence, radius, key[1], prior=prior)

    keys = [(s, m) for s in RADIUS_SCALES for m in PRIOR_WEIGHTS]
    future_ll = {key: loglik(model(key, learnt), future) for key in keys}
    forward = max(keys, key=lambda key: loglik(model(key, earlier), held))
    play = PlayCounts.merged([p for _, p in pubs[: latest - 1]])
    fit = fit_shrunk_model(descriptors, control, play, prior, base)
    fold = (fit.radius / base, fit.prior_weight)
    best = max(keys, key=lambda key: future_ll[key])
    return (
        f"seed {seed}: 5-fold {fold} {loglik(model(fold, learnt), future):.3f} | "
        f"forward {forward} {future_ll[forward]:.3f} | best {best} {future_ll[best]:.3f} | "
        f"heuristic {loglik(prior, future):.3f}"
    )


if __name__ == "__main__":
    for seed in sys.argv[3:]:
        print(seed_line(Settings(), sys.argv[1], int(sys.argv[2]), seed))
