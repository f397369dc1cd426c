"""How players reached the error they met, per run and checkpoint after the first.

Reads an experiment's database (SRG_DATABASE_URL, a SQLite file) and artifacts
(SRG_ARTIFACT_DIR) and prints, for every strategy, seed and crowd:

- arrivals: of all the error the checkpoint's players met, the share met on older blends
  the earlier checkpoint's players never took, by how the player came to that blend's
  vertex (the step before: a blend or a simulated clip, leaving a vertex added since
  the earlier checkpoint or an older one; whether the earlier players visited the vertex);
- jumps: the share of play on blends that leave a new vertex for an older one, observed
  and as the strategy's model predicted it (the checkpoint's stored densities);
- large blends (as the report counts them: above half the run's visibility threshold):
  how many, how many the players met, and their share of the error.

    PYTHONPATH=. SRG_DATABASE_URL=sqlite:///RUN/srg.db SRG_ARTIFACT_DIR=RUN/artifacts \
        python docs/results/dip-why/where_error.py

docs/experiment.md, "Where the error lay", quotes its output.
"""

from __future__ import annotations

from collections import Counter

import numpy as np
from sqlalchemy import select

from app.config import get_settings
from app.core.graph.state_graph import EdgeKind
from app.db.sessions import transaction
from app.models.experiment import ExperimentCheckpoint
from app.models.play import Trace, TraceStep
from app.services.experiment.results import LARGE_BLEND
from app.services.loading import artifact_store

ARRAYS = ("edge_kind", "edge_dst", "edge_err", "observed_density", "predicted_density")


def sessions(session, publication_id: int) -> list[np.ndarray]:
    """Every stored session of the publication as (steps, 2) arrays of (vertex, control)."""
    rows = session.execute(
        select(TraceStep.trace_id, TraceStep.vertex, TraceStep.control)
        .join(Trace, Trace.id == TraceStep.trace_id)
        .where(Trace.publication_id == publication_id)
        .order_by(TraceStep.trace_id, TraceStep.step)
    ).all()
    by_trace: dict[int, list[tuple[int, int]]] = {}
    for trace, vertex, control in rows:
        by_trace.setdefault(trace, []).append((vertex, control))
    return [np.array(steps) for steps in by_trace.values()]


def arrivals(steps: list[np.ndarray], arrays: dict, earlier: dict, n: int) -> Counter:
    kind, err = arrays["edge_kind"], arrays["edge_err"]
    n_old = earlier["edge_kind"].size // n
    taken_before = earlier["observed_density"] > 0.0
    visited_before = np.zeros(n_old, dtype=bool)
    visited_before[np.flatnonzero(taken_before) // n] = True
    shares: Counter = Counter()
    total = 0.0
    for session_steps in steps:
        edges = session_steps[:, 0] * n + session_steps[:, 1]
        for i, e in enumerate(edges):
            if kind[e] != EdgeKind.BLEND:
                continue
            total += err[e]
            v = e // n
            if v >= n_old or taken_before[e]:
                continue
            if i == 0:
                how = "from the start"
            else:
                before = edges[i - 1]
                how = ("a blend" if kind[before] == EdgeKind.BLEND else "a clip") + (
                    " from a new vertex" if before // n >= n_old else " from an older vertex"
                )
            how += ", vertex visited before" if visited_before[v] else ", vertex never visited"
            shares[how] += err[e]
    return Counter({how: value / total for how, value in shares.items()})


def describe(session, arrays: dict, earlier: dict, row) -> list[str]:
    """The lines of one checkpoint after a run's first."""
    strategy, seed, bot, _, publication_id, figures, _ = row
    threshold = float(figures["high_error_threshold"])
    kind, dst, err = arrays["edge_kind"], arrays["edge_dst"], arrays["edge_err"]
    observed, predicted = arrays["observed_density"], arrays["predicted_density"]
    n = kind.size // figures["vertices"]
    blend = kind == EdgeKind.BLEND
    jump = (
        blend
        & (np.arange(kind.size) // n >= earlier["edge_kind"].size // n)
        & (dst < earlier["edge_kind"].size // n)
    )
    large = blend & (err > LARGE_BLEND * threshold)
    met = observed * err
    lines = [
        f"{strategy} seed {seed} {bot} at {figures['size_frames']} frames: "
        f"jumps observed {observed[jump].sum():.3f}, predicted {predicted[jump].sum():.3f}; "
        f"large blends {large.sum()} of {blend.sum()}, met {(large & (observed > 0)).sum()}, "
        f"{met[large].sum() / met.sum():.0%} of the error"
    ]
    steps = sessions(session, publication_id)
    for how, share in arrivals(steps, arrays, earlier, n).most_common():
        lines.append(f"    on older blends not taken before, reached by {how}: {share:.0%}")
    return lines


def main() -> None:
    settings = get_settings()
    store = artifact_store(settings)
    order = ("strategy", "seed", "bot", "checkpoint")
    columns = (*order, "publication_id", "figures", "arrays")
    with transaction(settings) as session:
        rows = session.execute(
            select(*(getattr(ExperimentCheckpoint, c) for c in columns)).order_by(
                *(getattr(ExperimentCheckpoint, c) for c in order)
            )
        ).all()
        earlier: dict | None = None
        for i, row in enumerate(rows):
            arrays = store.get_arrays(row.arrays, ARRAYS)
            if earlier is not None and rows[i - 1][:3] == row[:3]:
                print("\n".join(describe(session, arrays, earlier, row)))
            earlier = arrays


if __name__ == "__main__":
    main()
