"""``srg bench grow``: distributed growth throughput and the integrating step's cost.

Throughput: a private redis-server, a fresh PostgreSQL database and one
``celery worker --concurrency=W`` (W worker processes) grow a graph (toy, or the liquid
``tiny`` preset with ``--dynamics liquid``) for a few
epochs; expansions per minute of wall time, end to end (plan, simulate, sdf, render,
integrate in order, blend). Integration: a toy graph of E edges is grown in memory
(prefilter 8 to build it fast), saved, and expansions are integrated one transaction
each as a worker does: the first pays the graph load, the next reuse the cached graph.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time
import uuid
from collections import deque
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from sqlalchemy import text
from sqlalchemy.engine import make_url

from app.config import Settings
from app.core.clipbank import MemoryClipBank
from app.core.growth import expand_blend_edge, initial_tree
from app.core.toy import ToyDynamics
from app.db import make_engine, session_factory

ROOT = Path(__file__).resolve().parents[2]
POSTGRES = os.environ.get(
    "SRG_TEST_POSTGRES_URL", "postgresql+psycopg://postgres@127.0.0.1:5432/srg_bench"
)


@contextmanager
def _database() -> Iterator[str]:
    from alembic.config import Config

    from alembic import command

    url = make_url(POSTGRES)
    name = f"srg_bench_{uuid.uuid4().hex[:8]}"
    admin = make_engine(
        url.set(database="postgres").render_as_string(False), isolation_level="AUTOCOMMIT"
    )
    with admin.connect() as connection:
        connection.execute(text(f'CREATE DATABASE "{name}"'))
    created = url.set(database=name).render_as_string(hide_password=False)
    engine = make_engine(created)
    with engine.begin() as connection:
        config = Config(str(ROOT / "alembic.ini"))
        config.attributes["connection"] = connection
        config.attributes["configure_logger"] = False
        command.upgrade(config, "head")
    engine.dispose()
    try:
        yield created
    finally:
        with admin.connect() as connection:
            connection.execute(text(f'DROP DATABASE IF EXISTS "{name}" WITH (FORCE)'))
        admin.dispose()


@contextmanager
def _redis(directory: Path) -> Iterator[str]:
    import socket

    import redis

    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        port = sock.getsockname()[1]
    process = subprocess.Popen(
        ["redis-server", "--port", str(port), "--save", "", "--dir", str(directory)],
        stdout=subprocess.DEVNULL,
    )
    try:
        for _ in range(50):
            try:
                redis.Redis(port=port).ping()
                break
            except redis.RedisError:
                time.sleep(0.1)
        yield f"redis://127.0.0.1:{port}/0"
    finally:
        process.terminate()
        process.wait()


def _throughput(
    workers: int, epochs: int, batch: int, dynamics: str, preset: str | None
) -> dict[str, Any]:
    from app.services.graphs import init_graph
    from app.tasks.celery_app import make_celery

    with tempfile.TemporaryDirectory() as tmp, _redis(Path(tmp)) as broker, _database() as url:
        fields = {
            "broker_url": broker,
            "result_backend": broker,
            "database_url": url,
            "var_dir": Path(tmp) / "var",
            "batch_size": batch,
        }
        settings = Settings(**fields)  # type: ignore[arg-type]
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
    from sqlalchemy import func, select

    from app.models import GrowthEpoch

    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        with sessions() as session:
            finished = session.scalar(
                select(func.count()).where(
                    GrowthEpoch.graph_id == graph_id, GrowthEpoch.status == "finished"
                )
            )
        if finished >= count:
            return
        time.sleep(0.05)
    raise TimeoutError("growth epoch did not finish")


def _integration(edges: int, expansions: int = 8) -> dict[str, Any]:
    from app.services import growth
    from app.services.graph_cache import graph_cache
    from app.store.artifacts import ArtifactStore
    from app.store.graphs import create_graph, save_graph

    dynamics, bank = ToyDynamics(), MemoryClipBank()
    graph = initial_tree(dynamics, bank, prefilter_k=8)
    start = time.perf_counter()
    frontier = deque(int(e) for e in graph.blend_edges())
    while graph.n_edges < edges:  # breadth-first: O(1) per pick, a bushy graph
        expansion = expand_blend_edge(graph, bank, dynamics, frontier.popleft(), prefilter_k=8)
        frontier.extend(expansion.blends)
    build = time.perf_counter() - start
    with tempfile.TemporaryDirectory() as tmp, _database() as url:
        settings = Settings(
            database_url=url,
            var_dir=Path(tmp),
            batch_size=expansions,
            growth_renders=False,
            strategy="max-error",
        )
        sessions = session_factory(make_engine(url))
        with sessions() as session:
            graph_id = create_graph(
                session,
                name="bench",
                dynamics="toy",
                n_controls=3,
                frames_per_clip=10,
                strategy="max-error",
            )
            save_graph(
                session, graph_id, graph, bank, ArtifactStore(settings.resolved_artifact_dir)
            )
            session.commit()
        graph_cache.clear()
        with sessions() as session:
            plan = growth.plan_epoch(session, settings, graph_id)
            session.commit()
        assert plan is not None
        with sessions() as session:
            for position in range(len(plan.expansions)):
                for control in range(3):
                    stage = growth.simulate_step(
                        session, settings, plan.epoch_id, position, control
                    )
                    growth.sdf_step(session, settings, stage, plan.epoch_id, position, control)
            session.commit()
        graph_cache.clear()  # the first integration loads the graph, as a fresh worker does
        times = []
        for position in range(len(plan.expansions)):
            t0 = time.perf_counter()
            with sessions() as session:
                growth.integrate_step(session, settings, plan.epoch_id, position)
                session.commit()
            times.append(time.perf_counter() - t0)
    warm = sorted(times[1:])
    return {
        "edges": graph.n_edges,
        "build_seconds": round(build, 1),
        "first_integration_with_load_s": round(times[0], 3),
        "integration_cached_median_ms": round(1000 * warm[len(warm) // 2], 1),
    }


def bench_grow(
    *,
    epochs: int,
    batch: int,
    worker_counts: list[int],
    sizes: list[int],
    dynamics: str = "toy",
    preset: str | None = None,
) -> dict[str, Any]:
    """Throughput on ``dynamics`` (and ``preset``); integration cost on the toy."""
    return {
        "dynamics": dynamics,
        "preset": preset,
        "cpus": os.cpu_count(),
        "throughput": [_throughput(w, epochs, batch, dynamics, preset) for w in worker_counts],
        "integration": [_integration(e) for e in sizes],
    }
