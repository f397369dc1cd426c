"""Does counting stale steps less predict the next publication's players better?

Run from the repository with the experiment's settings (SRG_DATABASE_URL and the rest):
    python docs/results/sel-gd20k-mixed-fresh-tiny/fresh.py EXPERIMENT SEED [SEED ...]
For each seed's sr-crowd graph and each publication P from the third on: learnt from the
sessions of the publications before P, the discount and depth `mixed-fresh` chose (on the
last of them), and the log-likelihood per step of P's sessions under `mixed` (every step
in full), under `mixed-fresh` (changes counted against P, the graph those players saw)
and under the heuristic model. Recomputed on the graph as it is now (its descriptors),
not as it was when growth chose.
"""

import sys

import numpy as np
from app.core.fresh_evidence import weighted_counts

from app.config import Settings
from app.core.growth.refinement import Refiner
from app.core.growth.strategies import Strategy
from app.core.players.player_models import PlayerModelKind
from app.db.sessions import transaction
from app.services.loading import open_graph
from app.services.refining import refiner_config
from app.store.play_counts import publication_play_counts
from app.store.publications import load_publication


def loglik(model: np.ndarray, steps: np.ndarray) -> float:
    return float(np.sum(steps * np.log(np.maximum(model, 1e-300))) / steps.sum())


def seed_lines(settings: Settings, name: str, seed: str) -> list[str]:
    with transaction(settings) as session:
        loaded = open_graph(session, settings, f"{name}.sr-crowd.{seed}")
        played = [
            (load_publication(session, pid), play)
            for pid, play in publication_play_counts(session, loaded.entry.id)
        ]
    graph = loaded.graph
    config = refiner_config(settings, loaded.dynamics, PlayerModelKind.MIXED_FRESH)
    lines = []
    for latest in range(2, len(played)):
        refiner = Refiner(graph, loaded.bank, loaded.dynamics, Strategy.SR_CROWD, config)
        for publication, play in played[:latest]:
            refiner.learn_counts(play, publication)
        fit = refiner.fresh_fit()
        seen, future = played[latest]
        steps = future.control_counts(graph.n_vertices, graph.n_controls)
        mixed = refiner.shrunk_model(refiner.play.control_counts(graph.n_vertices, graph.n_controls))
        fresh = refiner.shrunk_model(
            weighted_counts(played[:latest], seen, graph.n_vertices, fit.discount, fit.depth)
        )
        lines.append(
            f"seed {seed}, publication {latest + 1} ({seen.n_vertices} vertices): chose "
            f"discount {fit.discount:g}, depth {fit.depth} | mixed {loglik(mixed, steps):.3f} | "
            f"mixed-fresh {loglik(fresh, steps):.3f} | "
            f"heuristic {loglik(refiner.heuristic_model(), steps):.3f}"
        )
    return lines


if __name__ == "__main__":
    for seed in sys.argv[2:]:
        print("\n".join(seed_lines(Settings(), sys.argv[1], seed)))
