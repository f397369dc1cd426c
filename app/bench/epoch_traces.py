"""``srg bench epoch-traces``: an epoch's growth time beside N stored trace steps.

Two identical toy graphs (sr-crowd, the ``shrunk`` model) in a fresh PostgreSQL database,
each published twice and played by the same few bot sessions through the upload path
(so both learn a fitted crowd model). One of them also gets N steps, written by the
server (``generate_series``: sessions of ``session_steps`` steps on random vertices and
controls of its publications, half on each), and migration 0010's backfill sums them,
timed. Then ``srg grow --expansions E`` runs on each graph in turn, ``repeats`` times
(both graphs grow alike, so each pair ranks graphs of one size), and ``srg analytics``
once on the played graph. The ratio is the median grow time with N steps over the
median without; the sums make it independent of N (docs/player-models.md).
"""

from __future__ import annotations

import statistics
import tempfile
import time
from functools import partial
from pathlib import Path
from typing import Any

from app.bench.scratch import scratch_database
from app.config import Settings
from app.core.growth.kinds import Strategy
from app.core.growth.refinement import Refiner
from app.core.players.bots import play_sessions
from app.core.players.kinds import BotKind
from app.db.engines import make_engine
from app.db.sessions import session_factory, transaction
from app.services.analytics import played_graph_analytics
from app.services.creation import init_graph
from app.services.dynamics import threshold_in_force
from app.services.growing import grow_graph
from app.services.loading import open_graph
from app.store.graph_persistence import save_graph
from app.store.publications import load_publication, publish
from app.store.synthetic_play import graph_step_count, store_synthetic_steps
from app.store.traces import bot_player, record_trace


def _played_graph(settings: Settings, name: str, sessions: int) -> int:
    """A toy sr-crowd graph published before and after 8 expansions (with the threshold in
    force, as ``srg publish`` does), ``sessions`` bot sessions uploaded on each."""
    with transaction(settings) as session:
        graph_id = int(init_graph(session, settings, name=name, player_model="shrunk")["id"])  # type: ignore[call-overload]
        loaded = open_graph(session, settings, graph_id)
        threshold = threshold_in_force(settings, loaded.dynamics)
        publications = [publish(session, graph_id, loaded.graph, threshold=threshold)]
        Refiner(loaded.graph, loaded.bank, loaded.dynamics, Strategy.SR_HEURISTIC).grow(
            expansions=8
        )
        save_graph(session, graph_id, loaded.graph, loaded.bank, loaded.artifacts)
        publications.append(publish(session, graph_id, loaded.graph, threshold=threshold))
        player = bot_player(session, "bench-bots")
        for publication_id in publications:
            publication = load_publication(session, publication_id)
            traces = play_sessions(
                publication, BotKind.HESITANT, sessions=sessions, mean_steps=40, seed=publication_id
            )
            for i, trace in enumerate(traces):
                record_trace(session, publication_id, player, f"{publication_id}.{i}", trace)
    return graph_id


def _grow_time(settings: Settings, name: str, expansions: int) -> float:
    began = time.perf_counter()
    grow_graph(partial(transaction, settings), settings, name=name, expansions=expansions)
    return time.perf_counter() - began


def bench_epoch_traces(
    *,
    steps: int,
    session_steps: int,
    expansions: int,
    repeats: int,
    sessions: int,
    settings: Settings,
) -> dict[str, Any]:
    with (
        tempfile.TemporaryDirectory() as tmp,
        scratch_database(settings.scratch_postgres_url) as url,
    ):
        settings = settings.replace(
            database_url=url,
            var_dir=Path(tmp) / "var",
            artifact_dir=Path(tmp) / "artifacts",
            growth_renders=False,
        )
        quiet = _played_graph(settings, "quiet", sessions)
        played = _played_graph(settings, "played", sessions)
        stored = store_synthetic_steps(url, played, steps, session_steps)
        times: dict[str, list[float]] = {"quiet": [], "played": []}
        for _ in range(repeats):
            for name in times:
                times[name].append(_grow_time(settings, name, expansions))
        with session_factory(make_engine(url))() as session:
            stored_steps = {
                name: graph_step_count(session, graph_id)
                for name, graph_id in (("quiet", quiet), ("played", played))
            }
            began = time.perf_counter()
            report = played_graph_analytics(session, settings, "played")
            analytics_s = time.perf_counter() - began
        quiet_s, played_s = (statistics.median(times[name]) for name in ("quiet", "played"))
        return {
            "steps_requested": steps,
            "stored_steps": stored_steps,
            "session_steps": session_steps,
            "expansions": expansions,
            "repeats": repeats,
            **stored,
            "grow_s": {name: [round(t, 3) for t in ts] for name, ts in times.items()},
            "grow_median_s": {"quiet": round(quiet_s, 3), "played": round(played_s, 3)},
            "ratio": round(played_s / quiet_s, 3),
            "target_ratio": 1.2,
            "analytics_s": round(analytics_s, 2),
            "analytics_sessions": report["session_lengths"]["sessions"],
        }
