"""Request and response bodies of the HTTP API.

Integers are JSON Schema's: a number with no fractional part (``211.0`` is 211;
``211.5``, ``true`` and ``"211"`` are not integers), bounded to the 32-bit range of the
database columns, so a hostile number is a 422, never a driver error. Idempotency keys
are limited to URL-safe characters: they are stored as text on SQLite and PostgreSQL
alike (PostgreSQL rejects NUL characters in text).
"""

from __future__ import annotations

from datetime import datetime
from typing import Annotated, Literal

from pydantic import BaseModel, BeforeValidator, ConfigDict, Field, StrictInt

from app.core.players.kinds import PlayerKind

INT32_MAX = 2**31 - 1


def _integral_float_as_int(value: object) -> object:
    """211.0 as 211: JSON Schema's ``integer`` takes it, pydantic's strict int would not
    (and its lax int takes ``true`` and ``"211"`` too, which JSON Schema does not)."""
    if isinstance(value, float) and value.is_integer():
        return int(value)
    return value


#: last in ``Annotated``, so that it runs before the bounds and the document keeps them
AS_JSON_INTEGER = BeforeValidator(_integral_float_as_int)
Index = Annotated[StrictInt, Field(ge=0, le=INT32_MAX), AS_JSON_INTEGER]
Id = Annotated[StrictInt, Field(ge=1, le=INT32_MAX), AS_JSON_INTEGER]
IdempotencyKey = Annotated[str, Field(min_length=1, max_length=128, pattern=r"^[A-Za-z0-9_.:-]+$")]


class TraceUpload(BaseModel):
    model_config = ConfigDict(extra="forbid")

    publication_id: Id
    idempotency_key: IdempotencyKey
    #: rows of (vertex, control): the edge taken at each step, in play order
    steps: Annotated[list[tuple[Index, Index]], Field(min_length=1)]


class TraceStored(BaseModel):
    trace_id: int
    publication_id: int
    n_steps: int
    #: False when this upload replayed an idempotency key already stored
    created: bool


class PlayerRequest(BaseModel):
    model_config = ConfigDict(extra="forbid")

    #: who plays: the web client registers a person, bots say "bot" (analytics tell them apart)
    kind: PlayerKind = PlayerKind.PERSON


class PlayerCreated(BaseModel):
    player_id: int
    name: str
    kind: PlayerKind
    #: the bearer token for trace uploads; only its hash is stored, so keep it
    token: str


class GraphSummary(BaseModel):
    name: str
    dynamics: str
    n_controls: int
    frames_per_clip: int
    #: the latest publication's number (1, 2, ... per graph: the publication's own
    #: ``number``, as ``srg status`` shows it; not its ``publication_id``); null before one
    latest_publication: int | None
    #: the latest publication has animations to show; false for one made for bots
    #: without them (`srg demo`'s baseline), which the web client does not offer
    animated: bool


class EdgeOut(BaseModel):
    dst: int
    kind: Literal["sim", "blend"]
    err: float
    score: float
    #: URL of the animation strip, or null where the edge has none (the web client holds
    #: the last frame shown for the clip's time)
    animation: str | None
    #: URL of the strip's first frame as a still image (null with the animation)
    poster: str | None


class PublicationListed(BaseModel):
    """One stored version of a graph: enough to pick one to play, by size or by age."""

    #: GET /api/graphs/{name}/publications/{publication_id} serves it
    publication_id: int
    #: 1, 2, ... per graph, in publication order
    number: int
    created_at: datetime
    #: simulated frames in the graph when this version was published
    size_frames: int
    n_vertices: int
    n_edges: int


class PublicationOut(BaseModel):
    graph: str
    publication_id: int
    number: int
    start: int
    n_controls: int
    frames_per_clip: int
    fps: float
    #: simulated frames in the graph when this version was published
    size_frames: int
    #: fraction of the publication's edges that are blends (0 to 1)
    blend_share: float
    #: mean error (eq. 3's dist) of its blend edges; 0 without blends
    mean_blend_error: float
    n_vertices: int
    #: vertices[v][c]: the edge from vertex v under control c
    vertices: list[list[EdgeOut]]


class AdminResult(BaseModel):
    graph: str
    result: dict[str, object]


class GrowRequest(BaseModel):
    model_config = ConfigDict(extra="forbid")

    expansions: Annotated[StrictInt, Field(ge=1, le=10_000), AS_JSON_INTEGER] = 4


class GrowQueued(BaseModel):
    """A grow request accepted (202): the growth runs elsewhere; follow it at ``poll``."""

    graph: str
    expansions: int
    #: "workers": one Celery ``grow_epoch`` of that many expansions; "server": a background
    #: job of this server, in epochs of ``SRG_BATCH_SIZE``
    runs_on: Literal["workers", "server"]
    #: the request's id: the poll's ``growth`` tells what became of it
    request: int
    #: the graph's latest epoch number when the growth was queued: its epochs come after
    after_epoch: int
    #: GET it (admin token) for the epochs after ``after_epoch``
    poll: str


class EpochOut(BaseModel):
    id: int
    number: int
    strategy: str
    #: running, finished or failed
    status: str
    #: expansions in the epoch's plan
    planned: int
    #: expansions done, set when the epoch finishes
    expansions: int
    relinks: int
    size_frames: int
    started_at: datetime
    finished_at: datetime | None


class GrowthOut(BaseModel):
    """The graph's latest accepted growth request and how it ended."""

    request: int
    expansions: int
    runs_on: Literal["workers", "server"]
    state: Literal["queued", "running", "finished", "failed"]
    #: why it failed, in one line; null otherwise
    reason: str | None


class GraphEpochs(BaseModel):
    graph: str
    #: an epoch of the graph is running, or this server is growing the graph
    running: bool
    #: the latest growth the admin route accepted for the graph; null if none
    growth: GrowthOut | None
    #: oldest first, at most 100 (ask again with ``after`` the last number)
    epochs: list[EpochOut]


class FieldError(BaseModel):
    #: where in the request: e.g. ["body", "steps", 3, 1] as strings
    loc: list[str]
    msg: str


class ErrorBody(BaseModel):
    """Every error the API answers (4xx and 5xx): a message, and details where there are any.

    ``details`` is a list of :class:`FieldError` for a 422 of the request's shape, an
    object for the others that carry figures (413 ``max_bytes`` or ``max_steps``; 429
    ``retry_after_seconds``; 409 ``poll``; 422 of a trace: the ``step`` that failed and
    why), else null.
    """

    error: str
    details: list[FieldError] | dict[str, object] | None


class Health(BaseModel):
    status: Literal["ok"]
    #: the database dialect answering ``SELECT 1``: sqlite or postgresql
    database: str
    #: "shared": rate limit windows in Redis, shared by every server process (and it
    #: answers); "per-process": in this process's memory
    rate_limits: Literal["shared", "per-process"]
    #: the Celery broker (SRG_BROKER_URL): "ok" when it takes a connection within a
    #: second; "not configured": none set, tasks run in this process
    broker: Literal["ok", "unreachable", "not configured"]
    #: Celery workers that answered a ping within half a second; null when the broker
    #: was not asked (none configured, or unreachable)
    workers: int | None
