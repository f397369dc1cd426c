"""``srg bench serve``: players at once through the real HTTP path, against ``srg serve``.

A toy graph is grown in a scratch PostgreSQL database (or the configured one), every edge
given an animation of ``CLIP_BYTES`` (random bytes: the server stores, hashes and serves
them as it would a rendered strip), and published. ``srg serve --workers W`` is started on
it as its own process group, and for each number N of players one round runs: N players
at once (asyncio + httpx, a connection each, as N browsers), each of whom registers,
fetches the publication, fetches the animation of every edge its session plays (once
each, as the browser's cache does) and uploads its trace. The traces are played by bots
before the round starts, so the driver spends its time on HTTP, not on choosing moves.
With ``uploads_only`` the players register before the round and the round is their
uploads alone, all at once: what one graph takes of traces, its players' other requests
aside.

Per round: sessions per second (sessions whose every request succeeded, over the round's
wall time), latency percentiles of every request and of each kind, the sessions' own
durations, the errors (a status that is not 2xx, or no answer), the traces stored,
counted in the database afterwards, and whether the play sums, counted after the round
as a reader counts them, equal the stored steps (none lost, none doubled). A request
whose kept-alive connection the server closed as it went out is sent once more, as a
browser sends an idempotent request again, and counted under ``retried`` rather than as
an error.

The driver runs on the same machine as the server and takes CPU from it: the figures are
what one machine holds with its players' clients beside it, a lower bound of what the
server alone holds.
"""

from __future__ import annotations

import asyncio
import os
import signal
import socket
import subprocess
import sys
import tempfile
import time
import uuid
from collections import Counter
from collections.abc import Iterator
from contextlib import contextmanager, nullcontext
from pathlib import Path
from typing import Any

import httpx
import numpy as np
from sqlalchemy.engine import make_url

from app.api.client import publication_from_json
from app.bench.http_players import KINDS, REQUEST_TIMEOUT_S, PlayerSession, play_round
from app.bench.ingest import build_toy_graph
from app.bench.scratch import scratch_database
from app.config import Settings
from app.core.errors import Unavailable
from app.core.players.bots import play_sessions
from app.core.players.kinds import BotKind
from app.db.engines import make_engine
from app.db.sessions import session_factory
from app.store.animations import set_animations
from app.store.artifacts import ArtifactStore
from app.store.play_counts import sums_equal_steps
from app.store.publications import publish
from app.store.traces import stored_play

#: bytes of each edge's animation: a liquid clip's strip is tens of KB (docs/render.md)
CLIP_BYTES = 20_000
#: expansions of the toy graph beyond its initial tree
GRAPH_EXPANSIONS = 8
SERVER_START_TIMEOUT_S = 300.0
SERVER_STOP_TIMEOUT_S = 30.0
ROUND_DEADLINE_S = 900.0


def bench_serve(
    settings: Settings,
    *,
    players: list[int],
    workers: int = 2,
    mean_steps: int = 30,
    seed: int = 0,
    database_url: str = "",
    uploads_only: bool = False,
) -> dict[str, Any]:
    """Run one round per entry of ``players`` against one ``srg serve``; JSON-ready."""
    database = (
        nullcontext(settings.replace(database_url=database_url).database_url)
        if database_url
        else scratch_database(settings.scratch_postgres_url)
    )
    with (
        database as url,
        tempfile.TemporaryDirectory(prefix="srg-bench-serve-") as tmp,
    ):
        artifact_dir = Path(tmp) / "data"
        publication_id, graph, data_url = _published_graph(url, artifact_dir, seed)
        max_steps = settings.api.max_trace_steps
        server = _server(
            url, Path(tmp), artifact_dir, workers, total_players=sum(players), max_steps=max_steps
        )
        with server as base:
            publication = httpx.get(f"{base}{data_url}", timeout=REQUEST_TIMEOUT_S).json()
            rounds = []
            for round_index, count in enumerate(players):
                # a session longer than the server takes is cut, as the web client
                # cuts its uploads
                traces = [
                    trace[:max_steps]
                    for trace in play_sessions(
                        publication_from_json(publication),
                        BotKind.GOAL_DIRECTED,
                        sessions=count,
                        mean_steps=mean_steps,
                        seed=seed + round_index,
                    )
                ]
                stored_before = _stored(url, publication_id)
                sessions, elapsed = asyncio.run(
                    asyncio.wait_for(
                        play_round(base, data_url, publication_id, traces, uploads_only),
                        ROUND_DEADLINE_S,
                    )
                )
                stored = _stored(url, publication_id) - stored_before
                rounds.append(
                    {
                        **_summary(count, sessions, elapsed, stored),
                        "mean_uploaded_steps": round(float(np.mean([len(t) for t in traces])), 1),
                        "sums_equal_steps": _sums_equal_steps(url, publication_id),
                    }
                )
    return {
        "backend": make_url(url).get_backend_name(),
        "database": "configured" if database_url else "scratch",
        "server": f"srg serve --workers {workers}",
        "graph": {**graph, "clip_bytes": CLIP_BYTES},
        "mean_steps": mean_steps,
        "max_steps": max_steps,
        "uploads_only": uploads_only,
        "rounds": rounds,
        "ok": all(
            r["errors"] == 0 and r["stored_traces"] == r["players"] and r["sums_equal_steps"]
            for r in rounds
        ),
    }


def _published_graph(url: str, artifact_dir: Path, seed: int) -> tuple[int, dict[str, int], str]:
    """A toy graph with an animation on every edge, published: its publication's id, its
    size and the path its publication is read at."""
    engine = make_engine(url)
    rng = np.random.default_rng(seed)
    name = f"bench-serve-{uuid.uuid4().hex[:8]}"
    try:
        with session_factory(engine)() as session:
            artifacts = ArtifactStore(artifact_dir)
            toy = build_toy_graph(session, artifacts, name=name, expansions=GRAPH_EXPANSIONS)
            n_edges = toy.graph.n_edges
            clips = [rng.bytes(CLIP_BYTES) for _ in range(n_edges)]
            digests = artifacts.put_many(clips, media_type="image/webp", session=session)
            set_animations(session, toy.graph_id, edges=dict(enumerate(digests)))
            publication_id = publish(session, toy.graph_id, toy.graph)
            session.commit()
    finally:
        engine.dispose()
    size = {"vertices": toy.graph.n_vertices, "edges": n_edges}
    return publication_id, size, f"/api/graphs/{name}/publication"


def _stored(url: str, publication_id: int) -> int:
    engine = make_engine(url)
    try:
        with session_factory(engine)() as session:
            return stored_play(session, publication_id)[0]
    finally:
        engine.dispose()


def _sums_equal_steps(url: str, publication_id: int) -> bool:
    engine = make_engine(url)
    try:
        with session_factory(engine)() as session:
            equal = sums_equal_steps(session, publication_id)
            session.commit()
            return equal
    finally:
        engine.dispose()


@contextmanager
def _server(
    url: str, tmp: Path, artifact_dir: Path, workers: int, *, total_players: int, max_steps: int
) -> Iterator[str]:
    """``srg serve`` on a free loopback port, its own process group, stopped afterwards.

    Every player plays from loopback, so the per-address limits are opened to the load
    (else they would measure themselves), and a trace may be as long as the bench's
    settings allow; every other setting is the default."""
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    env = {key: value for key, value in os.environ.items() if not key.startswith("SRG_")}
    env.update(
        SRG_DATABASE_URL=url,
        SRG_VAR_DIR=str(tmp / "var"),
        SRG_ARTIFACT_DIR=str(artifact_dir),
        SRG_REGISTRATION_RATE=f"{total_players}/minute",
        SRG_ADDRESS_UPLOAD_RATE=f"{total_players}/minute",
        SRG_RATE_LIMIT_STORAGE="memory://",
        SRG_MAX_TRACE_STEPS=str(max_steps),
    )
    srg = str(Path(sys.executable).with_name("srg"))
    command = [srg, "serve", "--workers", str(workers), "--port", str(port)]
    with (tmp / "serve.log").open("wb") as log:
        process = subprocess.Popen(
            command, env=env, stdout=log, stderr=subprocess.STDOUT, start_new_session=True
        )
    base = f"http://127.0.0.1:{port}"
    try:
        _wait_until_healthy(base, process, tmp / "serve.log")
        yield base
    finally:
        os.killpg(process.pid, signal.SIGTERM)
        try:
            process.wait(SERVER_STOP_TIMEOUT_S)
        except subprocess.TimeoutExpired:
            os.killpg(process.pid, signal.SIGKILL)
            process.wait()


def _wait_until_healthy(base: str, process: subprocess.Popen[bytes], log: Path) -> None:
    deadline = time.monotonic() + SERVER_START_TIMEOUT_S
    while time.monotonic() < deadline:
        if process.poll() is not None:
            last = (log.read_text(errors="replace").strip().splitlines() or ["no output"])[-1]
            raise Unavailable(f"srg serve exited with status {process.returncode}: {last}")
        try:
            if httpx.get(f"{base}/api/health", timeout=5).status_code == 200:
                return
        except httpx.TransportError:
            pass
        time.sleep(0.5)
    raise Unavailable(f"srg serve did not answer /api/health in {SERVER_START_TIMEOUT_S:.0f} s")


def _percentiles(seconds: list[float]) -> dict[str, float]:
    if not seconds:
        return {}
    ms = np.array(seconds) * 1000.0
    return {
        "p50": round(float(np.percentile(ms, 50)), 1),
        "p99": round(float(np.percentile(ms, 99)), 1),
        "max": round(float(ms.max()), 1),
    }


def _summary(
    players: int, sessions: list[PlayerSession], elapsed: float, stored: int
) -> dict[str, Any]:
    requests = [request for session in sessions for request in session.requests]
    ok_sessions = sum(session.ok for session in sessions)
    return {
        "players": players,
        "ok_sessions": ok_sessions,
        "requests": len(requests),
        "errors": sum(not 200 <= request.status < 300 for request in requests),
        "retried": sum(request.retried for request in requests),
        # how many requests had each status; a request without an answer is counted
        # under its kind and httpx's error ("clip ReadTimeout")
        "statuses": dict(sorted(Counter(r.outcome for r in requests).items())),
        "stored_traces": stored,
        "elapsed_s": round(elapsed, 2),
        "sessions_per_s": round(ok_sessions / elapsed, 2),
        "uploads_per_s": round(
            sum(r.kind == "trace" and 200 <= r.status < 300 for r in requests) / elapsed, 2
        ),
        "requests_per_s": round(len(requests) / elapsed, 1),
        "latency_ms": {
            "all": _percentiles([r.latency_s for r in requests]),
            **{
                kind: _percentiles([r.latency_s for r in requests if r.kind == kind])
                for kind in KINDS
            },
        },
        "session_ms": _percentiles([session.duration_s for session in sessions]),
    }
