"""``srg bench grow``: distributed growth throughput and the integrating step's cost.

Throughput: a private redis-server, a fresh PostgreSQL database and one
``celery worker --concurrency=W`` (W worker processes) grow a graph (toy, or the liquid
``tiny`` preset with ``--dynamics liquid``) for a few
epochs; expansions per minute of wall time, end to end (plan, simulate, sdf, render,
integrate in order, blend). Integration: a toy graph of E edges (or F frames; with
``--integration-only`` a graph of the chosen dynamics) is grown in memory (prefilter 8
to build it fast), saved, one epoch is planned and its clips simulated, and a freshly
spawned process integrates the expansions one transaction each as a worker does: the
first pays the graph load, the next reuse the cached graph. That process's resident
memory after the integrations (it holds the cached graph), less its memory before the
load, is what holding the graph costs the single writer; its peak (ru_maxrss) is
reported too.
"""

from __future__ import annotations

import multiprocessing
import os
import resource
import subprocess
import sys
import tempfile
import time
from collections import deque
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

from app.bench.scratch import scratch_database, scratch_redis
from app.config import Settings
from app.core.graph.clipbank import MemoryClipBank
from app.core.graph.dynamics import Dynamics
from app.core.graph.graph_entry import GraphScene
from app.core.graph.state_graph import EdgeKind, StateGraph
from app.core.growth.expansion import expand_blend_edge, initial_tree
from app.db.engines import make_engine
from app.db.sessions import session_factory
from app.liquid.devices import LiquidDevices
from app.services.scope import Scope
from app.store.epochs import finished_epoch_count

ROOT = Path(__file__).resolve().parents[2]


def _throughput(
    workers: int,
    epochs: int,
    batch: int,
    dynamics: str,
    preset: str | None,
    *,
    settings: Settings,
) -> dict[str, Any]:
    from app.services.creation import init_graph
    from app.tasks.celery_app import make_celery

    with (
        tempfile.TemporaryDirectory() as tmp,
        scratch_redis(Path(tmp)) as broker,
        scratch_database(settings.scratch_postgres_url) as url,
    ):
        fields = {
            "broker_url": broker,
            "result_backend": broker,
            "database_url": url,
            "var_dir": Path(tmp) / "var",
            "batch_size": batch,
        }
        settings = settings.replace(**fields)
        sessions = session_factory(make_engine(url))
        with sessions() as session:
            graph_id = int(
                init_graph(
                    session,
                    settings,
                    name="bench",
                    dynamics=dynamics,
                    preset=preset,
                    strategy="sr-heuristic",
                )["id"]
            )  # type: ignore[call-overload]
            session.commit()
        # the worker is a child process: its configuration is its environment
        env = {k: v for k, v in os.environ.items() if not k.startswith("SRG_")}
        env.update({f"SRG_{k.upper()}": str(v) for k, v in fields.items()})
        celery = str(Path(sys.executable).with_name("celery"))
        worker = subprocess.Popen(
            [celery, "-A", "app.tasks", "worker", f"--concurrency={workers}", "--loglevel=WARNING"],
            cwd=ROOT,
            env=env,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
            start_new_session=True,
        )
        try:
            app = make_celery(settings)
            app.send_task("srg.grow_epoch", args=[graph_id])  # warm-up epoch, not timed
            _wait_epochs(sessions, graph_id, 1)
            start = time.perf_counter()
            for done in range(2, epochs + 2):
                app.send_task("srg.grow_epoch", args=[graph_id])
                _wait_epochs(sessions, graph_id, done)
            seconds = time.perf_counter() - start
        finally:
            os.killpg(worker.pid, 15)
            worker.wait()
    return {
        "worker_processes": workers,
        "expansions": epochs * batch,
        "seconds": round(seconds, 2),
        "expansions_per_minute": round(60 * epochs * batch / seconds, 1),
    }


def _wait_epochs(sessions: Any, graph_id: int, count: int, timeout: float = 600) -> None:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        with sessions() as session:
            if finished_epoch_count(session, graph_id) >= count:
                return
        time.sleep(0.05)
    raise TimeoutError("growth epoch did not finish")


def _grown_graph(
    dynamics: Dynamics, bank: MemoryClipBank, *, edges: int | None, frames: int | None
) -> StateGraph:
    """A graph grown breadth-first in memory to ``edges`` edges or ``frames`` frames.

    Breadth-first is O(1) per pick and gives a bushy graph; prefilter 8 builds it fast
    (the integrations measured afterwards use ``Settings.prefilter_k``).
    """
    graph = initial_tree(dynamics, bank, prefilter_k=8)
    frontier = deque(int(e) for e in graph.blend_edges())

    def small() -> bool:
        return graph.n_edges < edges if edges is not None else graph.size_frames < (frames or 0)

    while small():
        expansion = expand_blend_edge(graph, bank, dynamics, frontier.popleft(), prefilter_k=8)
        frontier.extend(expansion.blends)
    return graph


def _search_candidates(graph: StateGraph, prefilter_k: int) -> int:
    """``dist`` calls of one integration's best-target searches (one per new clip)."""
    kinds = np.asarray(graph.edge_kind)
    controls = graph.edge_arrays()[1]
    sims = np.bincount(controls[kinds == EdgeKind.SIM], minlength=graph.n_controls)
    return int(np.minimum(sims, prefilter_k + 1).sum())


def _resident_kb() -> int:
    """This process's resident memory now (Linux), in KiB."""
    pages = int(Path("/proc/self/statm").read_text().split()[1])
    return pages * os.sysconf("SC_PAGE_SIZE") // 1024


def _integrate_in_fresh_process(
    settings: Settings, epoch_id: int, count: int, dynamics: tuple[str, str | None]
) -> dict[str, Any]:
    """Integrate a planned epoch's expansions in order, as a freshly started worker does.

    Runs in its own (spawned) process so that its resident memory is that of a worker
    holding the loaded graph, not of the bench that built it. The dynamics (and
    the libraries it imports) is made before the "before" reading: a worker has it.
    """
    from app.services import epochs, loading

    loading.cached_dynamics(*dynamics, None, LiquidDevices.from_settings(settings))
    sessions = session_factory(make_engine(settings.database_url or ""))
    rss_before = _resident_kb()
    times = []
    for position in range(count):
        t0 = time.perf_counter()
        with sessions() as session:
            epochs.integrate_step(Scope.of(session, settings), epoch_id, position)
            session.commit()
        times.append(time.perf_counter() - t0)
    return {
        "times": times,
        "rss_before_kb": rss_before,
        "rss_holding_kb": _resident_kb(),
        "rss_peak_kb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss,  # Linux: KiB
    }


def _cached_rates(seconds: np.ndarray) -> dict[str, float | None]:
    """Median and p90 ms and the sustained rate of the integrations after the first."""
    if not len(seconds):  # a batch of 1: only the integration that loaded the graph
        return dict.fromkeys(
            ("integration_cached_median_ms", "integration_cached_p90_ms", "expansions_per_s")
        )
    return {
        "integration_cached_median_ms": round(1000 * float(np.median(seconds)), 1),
        "integration_cached_p90_ms": round(1000 * float(np.percentile(seconds, 90)), 1),
        "expansions_per_s": round(len(seconds) / float(seconds.sum()), 2),
    }


def _integration(
    settings: Settings,
    *,
    edges: int | None = None,
    frames: int | None = None,
    expansions: int = 8,
    dynamics_name: str = "toy",
    preset: str | None = None,
) -> dict[str, Any]:
    """Integrating steps on a graph of ``edges`` edges (or ``frames`` frames), on PostgreSQL.

    One epoch of ``expansions`` is planned and its clips simulated here; a fresh process
    then integrates them one transaction each: the first pays the graph load, the next
    reuse the cached graph (the steady state of the single writer).
    """
    from app.services import clips, epochs, loading
    from app.store.artifacts import ArtifactStore
    from app.store.graph_catalogue import create_graph
    from app.store.graph_persistence import save_graph

    devices = LiquidDevices.from_settings(settings)
    dynamics = loading.cached_dynamics(dynamics_name, preset, None, devices)
    bank = MemoryClipBank()
    start = time.perf_counter()
    graph = _grown_graph(dynamics, bank, edges=edges, frames=frames)
    build = time.perf_counter() - start
    with (
        tempfile.TemporaryDirectory() as tmp,
        scratch_database(settings.scratch_postgres_url) as url,
    ):
        settings = settings.replace(
            database_url=url, var_dir=Path(tmp), batch_size=expansions, growth_renders=False
        )
        candidates = _search_candidates(graph, settings.growth.prefilter_k)
        sessions = session_factory(make_engine(url))
        with sessions() as session:
            graph_id = create_graph(
                session,
                name="bench",
                dynamics=dynamics_name,
                n_controls=dynamics.n_controls,
                frames_per_clip=dynamics.frames_per_clip,
                scene=GraphScene(fps=dynamics.fps, preset=preset),
                strategy="max-error",
            )
            save_graph(
                session, graph_id, graph, bank, ArtifactStore(settings.resolved_artifact_dir)
            )
            session.commit()
        size = {"frames": graph.size_frames, "edges": graph.n_edges, "clips": graph.n_clips}
        del graph, bank
        with sessions() as session:
            plan = epochs.plan_epoch(Scope.of(session, settings), graph_id)
            session.commit()
        assert plan is not None
        with sessions() as session:
            for position in range(len(plan.expansions)):
                for control in range(dynamics.n_controls):
                    stage = clips.simulate_step(
                        Scope.of(session, settings), plan.epoch_id, position, control
                    )
                    clips.sdf_step(
                        Scope.of(session, settings), stage, plan.epoch_id, position, control
                    )
            session.commit()
        spawn = multiprocessing.get_context("spawn")
        with ProcessPoolExecutor(max_workers=1, mp_context=spawn) as pool:
            run = pool.submit(
                _integrate_in_fresh_process,
                settings,
                plan.epoch_id,
                len(plan.expansions),
                (dynamics_name, preset),
            ).result()
    times = run["times"]
    warm = np.asarray(times[1:])
    holding_mb = (run["rss_holding_kb"] - run["rss_before_kb"]) / 1024
    return {
        **size,
        "build_seconds": round(build, 1),
        "expansions": len(times),
        "best_target_candidates": candidates,
        "first_integration_with_load_s": round(times[0], 3),
        **_cached_rates(warm),
        "integrating_process_peak_rss_mb": round(run["rss_peak_kb"] / 1024, 1),
        "integrating_process_rss_before_load_mb": round(run["rss_before_kb"] / 1024, 1),
        "integrating_process_rss_holding_graph_mb": round(run["rss_holding_kb"] / 1024, 1),
        "resident_mb_per_1k_frames": round(holding_mb / (size["frames"] / 1000), 3),
    }


def bench_grow(
    *,
    settings: Settings,
    epochs: int,
    batch: int,
    worker_counts: list[int],
    sizes: list[int],
    dynamics: str = "toy",
    preset: str | None = None,
    frames: list[int] | None = None,
    integration_only: bool = False,
) -> dict[str, Any]:
    """Throughput on ``dynamics`` (and ``preset``); integration cost by graph size.

    ``settings`` are the caller's: the scratch databases go to its ``scratch_postgres_url``
    server, and every run's own settings are these with the run's database, broker and
    sizes.

    The integration runs on graphs of ``sizes`` edges, or of ``frames`` frames when
    given (``batch`` expansions each). It is measured on the toy, except with
    ``integration_only``: then no throughput runs and the integration uses ``dynamics``.
    """
    on = (dynamics, preset) if integration_only else ("toy", None)
    integration = [
        _integration(
            settings,
            edges=size if frames is None else None,
            frames=size if frames is not None else None,
            expansions=batch,
            dynamics_name=on[0],
            preset=on[1],
        )
        for size in (frames if frames is not None else sizes)
    ]
    return {
        "dynamics": dynamics,
        "preset": preset,
        "cpus": os.cpu_count(),
        "throughput": []
        if integration_only
        else [
            _throughput(w, epochs, batch, dynamics, preset, settings=settings)
            for w in worker_counts
        ],
        "integration_dynamics": on[0],
        "integration": integration,
    }
