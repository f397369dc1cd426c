"""The players of ``srg bench serve``: browsers simulated over HTTP (asyncio + httpx, a
connection each), every request timed and its outcome kept."""

from __future__ import annotations

import asyncio
import ssl
import time
import uuid
from contextlib import AsyncExitStack
from dataclasses import dataclass
from typing import Any

import httpx
import numpy as np

from app.core.players.kinds import PlayerKind

REQUEST_TIMEOUT_S = 120.0
KINDS = ("register", "publication", "clip", "trace")
#: a kept-alive connection the server closed (its idle timeout) as the request went out:
#: a browser sends an idempotent request again on a new connection (the trace upload is
#: one: its idempotency key stores it once), and so does a player here, once
CLOSED_UNDER_IT = (httpx.ReadError, httpx.RemoteProtocolError)
IDEMPOTENT = frozenset(["publication", "clip", "trace"])


@dataclass(frozen=True)
class Request:
    kind: str
    #: the HTTP status, or 0 where no answer came
    status: int
    latency_s: float
    #: why no answer came: httpx's error (ReadTimeout, RemoteProtocolError, ...)
    failure: str = ""
    #: sent again once after its kept-alive connection was closed under it
    retried: bool = False

    @property
    def outcome(self) -> str:
        return self.failure or str(self.status)


@dataclass(frozen=True)
class PlayerSession:
    requests: list[Request]
    duration_s: float

    @property
    def ok(self) -> bool:
        return all(200 <= request.status < 300 for request in self.requests)


async def play_round(
    base: str, data_url: str, publication_id: int, traces: list[np.ndarray], uploads_only: bool
) -> tuple[list[PlayerSession], float]:
    """The players' sessions, and the round's wall time (their uploads', ``uploads_only``).

    Each player has a client of its own, one connection as a browser has: one client
    shared by hundreds of connections spent the driver's CPU finding a free connection in
    its pool, so that the round measured the driver (about 30 uploads a second at 300
    players, the server's processes half idle)."""
    tls = ssl.create_default_context()  # one for all: making one per client costs ms
    async with AsyncExitStack() as stack:
        clients = [
            await stack.enter_async_context(
                httpx.AsyncClient(base_url=base, timeout=REQUEST_TIMEOUT_S, verify=tls)
            )
            for _ in traces
        ]
        if not uploads_only:
            began = time.perf_counter()
            sessions = await asyncio.gather(
                *(
                    _player(http, data_url, publication_id, trace)
                    for http, trace in zip(clients, traces, strict=True)
                )
            )
            return list(sessions), time.perf_counter() - began
        players = [_Player(http) for http in clients]
        tokens = await asyncio.gather(*(player.register() for player in players))
        began = time.perf_counter()
        sessions = await asyncio.gather(
            *(
                player.upload_alone(publication_id, trace, token)
                for player, trace, token in zip(players, traces, tokens, strict=True)
            )
        )
        return list(sessions), time.perf_counter() - began


class _Player:
    """One player's requests, each timed; its session stops at the first that fails."""

    def __init__(self, http: httpx.AsyncClient) -> None:
        self.http = http
        self.requests: list[Request] = []
        self.began = time.perf_counter()

    async def request(
        self, kind: str, method: str, url: str, **kwargs: Any
    ) -> httpx.Response | None:
        start = time.perf_counter()
        for attempt in range(2):
            try:
                response = await self.http.request(method, url, **kwargs)
                break
            except httpx.TransportError as exc:
                closed = isinstance(exc, CLOSED_UNDER_IT) and kind in IDEMPOTENT
                if attempt or not closed:
                    failure = f"{kind} {type(exc).__name__}"
                    self.requests.append(Request(kind, 0, time.perf_counter() - start, failure))
                    return None
        elapsed = time.perf_counter() - start
        self.requests.append(Request(kind, response.status_code, elapsed, retried=attempt > 0))
        return response if response.is_success else None

    async def register(self) -> str | None:
        """A bot player's bearer token, None where registering failed."""
        registered = await self.request("register", "POST", "/api/players", json=_BOT)
        return None if registered is None else str(registered.json()["token"])

    async def upload(self, publication_id: int, trace: np.ndarray, token: str) -> None:
        body = {
            "publication_id": publication_id,
            "idempotency_key": uuid.uuid4().hex,
            "steps": trace.tolist(),
        }
        auth = {"Authorization": f"Bearer {token}"}
        await self.request("trace", "POST", "/api/traces", json=body, headers=auth)

    async def upload_alone(
        self, publication_id: int, trace: np.ndarray, token: str | None
    ) -> PlayerSession:
        """The session of an upload sent on its own (none where registering failed): its
        requests, registering included, and the upload's time."""
        began = time.perf_counter()
        if token is not None:
            await self.upload(publication_id, trace, token)
        return PlayerSession(self.requests, time.perf_counter() - began)

    def session(self) -> PlayerSession:
        return PlayerSession(self.requests, time.perf_counter() - self.began)


_BOT = {"kind": PlayerKind.BOT.value}


async def _player(
    http: httpx.AsyncClient, data_url: str, publication_id: int, trace: np.ndarray
) -> PlayerSession:
    """One player's session, as the browser plays it."""
    player = _Player(http)
    token = await player.register()
    if token is None:
        return player.session()
    published = await player.request("publication", "GET", data_url)
    if published is None:
        return player.session()
    vertices = published.json()["vertices"]
    for vertex, control in dict.fromkeys(map(tuple, trace.tolist())):
        if await player.request("clip", "GET", vertices[vertex][control]["animation"]) is None:
            return player.session()
    await player.upload(publication_id, trace, token)
    return player.session()
