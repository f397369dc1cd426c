"""Bots that play over HTTP, through exactly the path a browser takes.

Register a bot player, download the latest publication, rebuild a core
:class:`~app.core.graph.publication.Publication` from its JSON, play seeded bot sessions on it
and upload each trace under a fresh idempotency key (a network retry of the same upload
reuses its key, so the server stores it once).
"""

from __future__ import annotations

import uuid
from typing import Any

import httpx
import numpy as np
from tenacity import (
    RetryCallState,
    Retrying,
    retry_if_exception_type,
    retry_if_result,
    stop_after_attempt,
)

from app.core.errors import SrgError
from app.core.graph.publication import Publication
from app.core.graph.state_graph import EdgeKind
from app.core.players.bots import play_sessions
from app.core.players.kinds import BotKind, PlayerKind

#: attempts per upload on transport errors and 429 (idempotent, so retrying is safe)
UPLOAD_ATTEMPTS = 3
TIMEOUT_S = 30.0


class ServerError(SrgError):
    """The server refused a request; the message carries its status and JSON error."""


def publication_from_json(data: dict[str, Any]) -> Publication:
    """The core publication described by ``GET /api/graphs/{name}/publication``."""
    edges = [edge for vertex in data["vertices"] for edge in vertex]
    return Publication(
        n_controls=int(data["n_controls"]),
        start=int(data["start"]),
        edge_dst=np.array([e["dst"] for e in edges], dtype=np.int64),
        edge_kind=np.array(
            [EdgeKind.SIM if e["kind"] == "sim" else EdgeKind.BLEND for e in edges], dtype=np.int8
        ),
        edge_err=np.array([e["err"] for e in edges], dtype=np.float64),
        edge_score=np.array([e["score"] for e in edges], dtype=np.float64),
    )


def play_over_http(
    base_url: str,
    graph: str,
    kind: BotKind | str,
    sessions: int,
    mean_steps: int,
    seed: int,
) -> dict[str, Any]:
    """Play ``sessions`` bot sessions on the graph's latest publication as a bot player;
    return counts and the seed."""
    kind = BotKind(kind)
    with httpx.Client(base_url=base_url, timeout=TIMEOUT_S) as http:
        registered = http.post("/api/players", json={"kind": PlayerKind.BOT.value})
        token = _checked(registered)["token"]
        http.headers["Authorization"] = f"Bearer {token}"
        data = _checked(http.get(f"/api/graphs/{graph}/publication"))
        publication = publication_from_json(data)
        traces = play_sessions(
            publication, kind, sessions=sessions, mean_steps=mean_steps, seed=seed
        )
        created = replayed = 0
        for trace in traces:
            body = {
                "publication_id": data["publication_id"],
                "idempotency_key": uuid.uuid4().hex,
                "steps": trace.tolist(),
            }
            if _upload(http, body).status_code == 201:
                created += 1
            else:
                replayed += 1
    return {
        "graph": graph,
        "publication_id": data["publication_id"],
        "kind": str(kind),
        "seed": seed,
        "sessions": len(traces),
        "steps": int(sum(len(t) for t in traces)),
        "created": created,
        "replayed": replayed,
    }


def _upload(http: httpx.Client, body: dict[str, Any]) -> httpx.Response:
    """POST one trace; a transport error or a 429 is retried (after Retry-After)."""
    retrying = Retrying(
        stop=stop_after_attempt(UPLOAD_ATTEMPTS),
        wait=_retry_after,
        retry=retry_if_exception_type(httpx.TransportError)
        | retry_if_result(lambda response: response.status_code == 429),
        retry_error_callback=_last_outcome,
    )
    response: httpx.Response = retrying(http.post, "/api/traces", json=body)
    _checked(response)
    return response


def _last_outcome(state: RetryCallState) -> Any:
    """Out of attempts: the last response (a 429, for :func:`_checked`), or its error."""
    assert state.outcome is not None
    return state.outcome.result()


def _retry_after(state: RetryCallState) -> float:
    """A 429's Retry-After; a transport error is retried at once."""
    outcome = state.outcome
    if outcome is None or outcome.failed:
        return 0.0
    return float(outcome.result().headers.get("Retry-After", "1"))


def _checked(response: httpx.Response) -> Any:
    """The JSON body; a :class:`ServerError` carrying the server's error message otherwise."""
    if response.is_success:
        return response.json()
    try:
        message = response.json().get("error", response.text)
    except ValueError:
        message = response.text
    request = response.request
    raise ServerError(f"{request.method} {request.url.path}: {response.status_code} {message}")
