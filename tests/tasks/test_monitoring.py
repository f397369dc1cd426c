"""What an operator watches: ``/api/health`` counts the workers on a real Redis broker, and
``srg flower`` asks for the password of ``SRG_FLOWER_BASIC_AUTH`` (its /api and /metrics
included)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from collections.abc import Callable, Iterator
from pathlib import Path

import httpx
import pytest
from fastapi.testclient import TestClient
from tasks_cluster import Cluster, RedisServer, free_port, wait_for

from app.api.app import create_app

pytestmark = [pytest.mark.redis]
SRG = str(Path(sys.executable).with_name("srg"))
CREDENTIALS = "ops:s3cret-word,second:other-word"


@pytest.mark.postgres
@pytest.mark.slow
def test_health_says_the_broker_answers_and_counts_the_workers(
    cluster_env: Callable[..., Cluster],
) -> None:
    cluster = cluster_env()
    with TestClient(create_app(cluster.settings)) as client:
        before = client.get("/api/health")
        assert before.status_code == 200
        assert (before.json()["broker"], before.json()["workers"]) == ("ok", 0)
        cluster.start_worker("w1")

        def workers() -> object:
            return client.get("/api/health").json()["workers"]

        wait_for(lambda: workers() == 1, 60, "the worker to answer the health ping", every=1)


def flower_env(tmp_path: Path, redis_server: RedisServer, **extra: str) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if not k.startswith(("SRG_", "FLOWER_"))}
    env.update(SRG_BROKER_URL=redis_server.url, SRG_VAR_DIR=str(tmp_path / "var"), **extra)
    return env


@pytest.fixture
def flower(tmp_path: Path, redis_server: RedisServer) -> Iterator[tuple[str, int]]:
    """``srg flower`` with two users; yields its address and pid."""
    port = free_port()
    env = flower_env(tmp_path, redis_server, SRG_FLOWER_BASIC_AUTH=CREDENTIALS)
    log = (tmp_path / "flower.log").open("wb")
    process = subprocess.Popen(
        [SRG, "flower", "--port", str(port), "--address", "127.0.0.1"],
        env=env,
        stdout=log,
        stderr=subprocess.STDOUT,
        start_new_session=True,
    )
    url = f"http://127.0.0.1:{port}"

    def answers() -> bool:
        try:
            httpx.get(url, timeout=2)
        except httpx.TransportError:
            return False
        return True

    try:
        wait_for(answers, 60, "srg flower to listen")
        yield url, process.pid
    finally:
        os.killpg(process.pid, signal.SIGTERM)
        process.wait(15)


def test_flower_asks_every_page_its_api_and_its_metrics_for_a_password(
    flower: tuple[str, int],
) -> None:
    url, pid = flower
    for path in ("/", "/api/workers", "/metrics"):
        assert httpx.get(url + path, timeout=5).status_code == 401, path
        wrong = httpx.get(url + path, auth=("ops", "guess"), timeout=5)
        assert wrong.status_code == 401, path
        for user, password in (("ops", "s3cret-word"), ("second", "other-word")):
            assert httpx.get(url + path, auth=(user, password), timeout=5).status_code == 200
    # the password reaches Flower through the settings, not a command line `ps` shows
    assert b"s3cret" not in Path(f"/proc/{pid}/cmdline").read_bytes()


def test_a_bad_flower_password_setting_is_one_line(
    tmp_path: Path, redis_server: RedisServer
) -> None:
    env = flower_env(tmp_path, redis_server, SRG_FLOWER_BASIC_AUTH="ops-without-password")
    done = subprocess.run([SRG, "flower"], env=env, capture_output=True, text=True, timeout=60)
    assert done.returncode == 2
    assert done.stderr.startswith("srg: error: SRG_FLOWER_BASIC_AUTH:")
    assert len(done.stderr.splitlines()) == 1
    assert "ops-without-password" not in done.stderr
