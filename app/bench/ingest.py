"""``srg bench ingest``: concurrent trace uploads on loopback, every one accounted for.

A toy graph is grown and published in a temporary SQLite database (or the configured
one), the API is served on a free loopback port in a thread, and ``clients`` bot players
upload ``uploads`` traces each, all at once (asyncio + httpx), each upload sent twice
with the same idempotency key. Afterwards the rows are counted: exactly one trace per
first upload, its steps all there, every replay answered 200 with the first upload's
trace id. Bounded: a fixed number of requests, each with a timeout, and an overall
deadline.
"""

from __future__ import annotations

import asyncio
import tempfile
import time
import uuid
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import httpx
import numpy as np
from sqlalchemy.orm import Session

from app.api.app import create_app
from app.api.local_server import serve_in_thread
from app.config import Settings
from app.core.errors import InvalidInput
from app.core.graph.clipbank import MemoryClipBank
from app.core.graph.graph_entry import GraphScene
from app.core.graph.state_graph import StateGraph
from app.core.graph.toy import ToyDynamics
from app.core.growth.expansion import expand_blend_edge, initial_tree
from app.core.players.bots import play_sessions
from app.core.players.kinds import BotKind
from app.db.engines import make_engine
from app.db.sessions import session_factory
from app.models import Base
from app.store.artifacts import ArtifactStore
from app.store.graph_catalogue import create_graph
from app.store.graph_persistence import save_graph
from app.store.publications import load_publication, publish
from app.store.traces import stored_play

REQUEST_TIMEOUT_S = 60.0


@dataclass(frozen=True)
class ToyGraph:
    graph_id: int
    graph: StateGraph
    bank: MemoryClipBank
    dynamics: ToyDynamics


def build_toy_graph(
    session: Session, artifacts: ArtifactStore, *, name: str, expansions: int = 4
) -> ToyGraph:
    """A small toy graph (initial tree plus a few expansions), saved but not published."""
    dynamics = ToyDynamics()
    bank = MemoryClipBank()
    graph = initial_tree(dynamics, bank)
    for _ in range(expansions):
        expand_blend_edge(graph, bank, dynamics, int(graph.blend_edges()[0]))
    graph_id = create_graph(
        session,
        name=name,
        dynamics=dynamics.name,
        n_controls=dynamics.n_controls,
        frames_per_clip=dynamics.frames_per_clip,
        scene=GraphScene(fps=dynamics.fps),
    )
    save_graph(session, graph_id, graph, bank, artifacts)
    return ToyGraph(graph_id, graph, bank, dynamics)


@dataclass(frozen=True)
class _Outcome:
    trace_id: int
    replay_id: int
    first_status: int
    replay_status: int
    latencies: tuple[float, float]


async def _client(
    http: httpx.AsyncClient, publication_id: int, traces: list[np.ndarray]
) -> list[_Outcome]:
    registered = await http.post("/api/players", json={"kind": "bot"})
    registered.raise_for_status()
    headers = {"Authorization": f"Bearer {registered.json()['token']}"}
    outcomes = []
    for trace in traces:
        body = {
            "publication_id": publication_id,
            "idempotency_key": uuid.uuid4().hex,
            "steps": trace.tolist(),
        }
        replies, latencies = [], []
        for _ in range(2):  # the upload, then its replay
            began = time.perf_counter()
            reply = await http.post("/api/traces", json=body, headers=headers)
            latencies.append(time.perf_counter() - began)
            replies.append(reply)
        first, replay = replies
        outcomes.append(
            _Outcome(
                trace_id=first.json().get("trace_id", -1) if first.status_code == 201 else -1,
                replay_id=replay.json().get("trace_id", -2) if replay.status_code == 200 else -2,
                first_status=first.status_code,
                replay_status=replay.status_code,
                latencies=(latencies[0], latencies[1]),
            )
        )
    return outcomes


async def _load(
    base_url: str, publication_id: int, per_client: list[list[np.ndarray]]
) -> list[_Outcome]:
    limits = httpx.Limits(max_connections=len(per_client), max_keepalive_connections=None)
    async with httpx.AsyncClient(
        base_url=base_url, timeout=REQUEST_TIMEOUT_S, limits=limits
    ) as http:
        results = await asyncio.gather(
            *(_client(http, publication_id, traces) for traces in per_client)
        )
    return [outcome for client in results for outcome in client]


def bench_ingest(
    *,
    clients: int = 200,
    uploads: int = 2,
    mean_steps: int = 90,
    seed: int = 0,
    database_url: str = "",
    deadline_s: float = 300.0,
) -> dict[str, Any]:
    """Run the load and return counts, throughput and latency percentiles (JSON-ready)."""
    if clients < 1 or uploads < 1:
        raise InvalidInput("--clients and --uploads must be at least 1")
    with tempfile.TemporaryDirectory(prefix="srg-bench-ingest-") as tmp:
        url = database_url or f"sqlite:///{Path(tmp) / 'bench.sqlite3'}"
        settings = Settings(database_url=url, artifact_dir=Path(tmp) / "data").replace(
            uploads_per_minute=max(60, 2 * uploads),
            # every client plays from loopback: the per-address limits would measure themselves
            registration_rate=f"{clients}/minute",
            address_upload_rate=f"{4 * clients * uploads}/minute",
            rate_limit_storage="memory://",
        )
        engine = make_engine(url)
        try:
            if not database_url:
                Base.metadata.create_all(engine)
            with session_factory(engine)() as session:
                toy = build_toy_graph(
                    session,
                    ArtifactStore(settings.resolved_artifact_dir),
                    name=f"bench-ingest-{uuid.uuid4().hex[:8]}",
                )
                publication_id = publish(session, toy.graph_id, toy.graph)
                publication = load_publication(session, publication_id)
                session.commit()
            traces = play_sessions(
                publication,
                BotKind.HEURISTIC,
                sessions=clients * uploads,
                mean_steps=mean_steps,
                seed=seed,
            )
            per_client = [traces[i * uploads : (i + 1) * uploads] for i in range(clients)]
            with serve_in_thread(create_app(settings)) as base_url:
                began = time.perf_counter()
                outcomes = asyncio.run(
                    asyncio.wait_for(_load(base_url, publication_id, per_client), deadline_s)
                )
                elapsed = time.perf_counter() - began
            with session_factory(engine)() as session:
                stored_traces, stored_steps = stored_play(session, publication_id)
        finally:
            engine.dispose()
    return _summary(
        clients, outcomes, traces, elapsed, (stored_traces, stored_steps), url, database_url
    )


def _summary(
    clients: int,
    outcomes: list[_Outcome],
    traces: list[np.ndarray],
    elapsed: float,
    stored: tuple[int, int],
    url: str,
    configured_url: str,
) -> dict[str, Any]:
    latencies = np.array([t for o in outcomes for t in o.latencies]) * 1000.0
    created = sum(o.first_status == 201 for o in outcomes)
    replays_matched = sum(o.replay_status == 200 and o.replay_id == o.trace_id for o in outcomes)
    expected_steps = int(sum(len(t) for t in traces))
    stored_traces, stored_steps = stored
    ids = {o.trace_id for o in outcomes if o.first_status == 201}
    return {
        "database": "configured" if configured_url else "temporary sqlite",
        "backend": url.split(":", 1)[0],
        "clients": clients,
        "uploads": len(outcomes),
        "requests": 2 * len(outcomes),
        "created_201": created,
        "replays_200_same_id": replays_matched,
        "distinct_trace_ids": len(ids),
        "stored_traces": stored_traces,
        "stored_steps": stored_steps,
        "expected_steps": expected_steps,
        "ok": created == len(outcomes) == replays_matched == len(ids) == stored_traces
        and stored_steps == expected_steps,
        "elapsed_s": round(elapsed, 3),
        "uploads_per_s": round(2 * len(outcomes) / elapsed, 1),
        "latency_ms": {
            "p50": round(float(np.percentile(latencies, 50)), 2),
            "p99": round(float(np.percentile(latencies, 99)), 2),
            "max": round(float(latencies.max()), 2),
        },
    }
