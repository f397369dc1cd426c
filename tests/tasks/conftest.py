"""Fixtures of the runtime tests: a fresh PostgreSQL database, a private Redis, workers.

Each distributed test gets its own redis-server on a free port (so restarting it
disturbs nobody), its own migrated PostgreSQL database and artifact directory, and real
``celery -A app.tasks worker`` processes started with that environment.
"""

from __future__ import annotations

import os
import shutil
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest
from database_helpers import migrate, postgres_base_url, postgres_database
from slow_simulate import SIMULATE_DELAY
from tasks_cluster import ROOT, Cluster, RedisServer, free_port

from app.config import Settings, get_settings
from app.db.engines import dispose_engines
from app.services.graph_cache import graph_cache


@pytest.fixture
def redis_server(tmp_path: Path) -> Iterator[RedisServer]:
    if shutil.which("redis-server") is None:
        pytest.fail("redis-server is not installed: run infra/services.sh")
    server = RedisServer(free_port(), tmp_path)
    server.start()
    yield server
    server.stop()


@pytest.fixture
def postgres_url() -> Iterator[str]:
    yield from postgres_database(postgres_base_url(), migrated=True)


@pytest.fixture
def cluster_env(
    tmp_path: Path, redis_server: RedisServer, postgres_url: str
) -> Iterator[Callable[..., Cluster]]:
    """Make a :class:`Cluster`; keyword arguments are extra Settings fields, but for
    ``simulate_delay``: the seconds its workers' ``srg.simulate`` sleeps first
    (:mod:`slow_simulate`)."""
    made: list[Cluster] = []

    def make(simulate_delay: float = 0.0, **extra: object) -> Cluster:
        fields: dict[str, object] = {
            "broker_url": redis_server.url,
            "result_backend": redis_server.url,
            "database_url": postgres_url,
            "var_dir": tmp_path / "var",
            "artifact_dir": tmp_path / "artifacts",
            "growth_renders": False,
            **extra,
        }
        env = {k: v for k, v in os.environ.items() if not k.startswith("SRG_")}
        env.update({f"SRG_{k.upper()}": str(v) for k, v in fields.items()})
        env["PYTHONPATH"] = f"{ROOT}{os.pathsep}{Path(__file__).parent}"  # slow_simulate
        env[SIMULATE_DELAY] = str(simulate_delay)
        env["FLOWER_UNAUTHENTICATED_API"] = "true"
        logs = tmp_path / "logs"
        logs.mkdir(exist_ok=True)
        cluster = Cluster(env, Settings().replace(**fields), logs)
        made.append(cluster)
        return cluster

    yield make
    for cluster in made:
        cluster.stop_all()


@pytest.fixture(autouse=True)
def _fresh_graph_cache() -> Iterator[None]:
    graph_cache.clear()
    yield
    graph_cache.clear()


@pytest.fixture
def settings(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Iterator[Settings]:
    """Settings (and the app's engine) of a fresh SQLite database, no broker."""
    url = f"sqlite:///{tmp_path / 'srg.sqlite3'}"
    migrate(url)
    for name, value in {
        "SRG_DATABASE_URL": url,
        "SRG_VAR_DIR": str(tmp_path / "var"),
        "SRG_ARTIFACT_DIR": str(tmp_path / "artifacts"),
        "SRG_GROWTH_RENDERS": "false",
        "SRG_BATCH_SIZE": "4",
        "SRG_BROKER_URL": "",
    }.items():
        monkeypatch.setenv(name, value)
    yield get_settings()
    dispose_engines()
