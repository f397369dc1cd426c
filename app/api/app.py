"""The FastAPI application factory: API routes under ``/api``, the web client at ``/``.

Around the routes: every body bounded (:mod:`app.api.bodylimit`), HEAD answered as GET
on every route (:mod:`app.api.head`), CORS for third-party clients when ``cors_origins``
is set (off by default: the web client is same-origin), and a last ``/api`` route
answering 404 or 405 with ``Allow`` for every method (:class:`~app.api.errors.NoRoute`)
so no API request falls through to the static files. The API's document is browsable at
``/docs`` (Swagger UI) and ``/redoc``, their scripts served from this server.
"""

from __future__ import annotations

import logging
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from importlib.resources import files
from pathlib import Path
from typing import TYPE_CHECKING, Any

from fastapi import FastAPI
from fastapi.middleware.cors import CORSMiddleware
from fastapi.staticfiles import StaticFiles
from fastapi_offline import FastAPIOffline
from starlette.routing import Route

from app.api.bodylimit import BodyLimit
from app.api.cache import FrozenCache
from app.api.encoding import EncodedJson
from app.api.errors import NoRoute, error_responses, install_error_handlers
from app.api.growth_jobs import GrowthJobs
from app.api.head import HeadAsGet
from app.api.ratelimit import RateLimits
from app.api.routes import admin, animations, graphs, health, players, traces
from app.config import Settings, get_settings
from app.core.graph.publication import Publication
from app.db.engines import make_engine
from app.db.sessions import session_factory
from app.services.loading import artifact_store

if TYPE_CHECKING:
    from app.tasks.broker_health import BrokerProbe

log = logging.getLogger(__name__)
STATIC_DIR = Path(str(files("app.api") / "static"))
#: publications kept decoded for trace validation / rendered as JSON for clients
PUBLICATIONS_CACHED = 32
PUBLICATION_JSON_CACHED = 8
#: posters and phone clips cut from stored clips (a few KB each): each is cut once
DERIVED_CACHED = 4096
#: sync routes run on anyio's thread pool (40 threads): one connection each, none waits
POOL_SIZE, POOL_OVERFLOW = 10, 30
#: what third-party clients may send and read across origins
CORS_METHODS = ["GET", "HEAD", "POST"]
CORS_REQUEST_HEADERS = ["Authorization", "Content-Type", "If-None-Match"]
CORS_EXPOSED_HEADERS = ["ETag", "Retry-After"]


def create_app(settings: Settings | None = None) -> FastAPI:
    settings = settings or get_settings()
    engine = make_engine(
        settings.resolved_database_url, pool_size=POOL_SIZE, max_overflow=POOL_OVERFLOW
    )

    @asynccontextmanager
    async def lifespan(_: FastAPI) -> AsyncIterator[None]:
        if not settings.api.admin_routes_on:
            # the one line `srg serve` shows about it; the token itself is never logged
            log.warning("admin routes are off (grow and publish answer 403): set SRG_ADMIN_TOKEN")
        yield
        engine.dispose()

    # /docs and /redoc from files of the fastapi-offline package, not a CDN: they work
    # on a machine without internet
    app = FastAPIOffline(
        title="srg",
        summary="Self-refining games: play API",
        description="Every GET route answers HEAD too: GET's status and headers, no body.",
        # no validator badge: it would send the document's address to swagger.io
        swagger_ui_parameters={"validatorUrl": None},
        lifespan=lifespan,
    )
    app.state.settings = settings
    app.state.session_factory = session_factory(engine)
    app.state.artifacts = artifact_store(settings)
    app.state.rate_limits = RateLimits(settings)
    app.state.publications = FrozenCache[Publication](PUBLICATIONS_CACHED)
    app.state.publication_json = FrozenCache[EncodedJson](PUBLICATION_JSON_CACHED)
    app.state.derived = FrozenCache[bytes](DERIVED_CACHED)
    app.state.growth_jobs = GrowthJobs()
    app.state.broker_probe = _broker_probe(settings)
    app.state.sqlite_integrity = health.SqliteIntegrity(settings)
    install_error_handlers(app)
    # every route reads the database, and BodyLimit reads every request's Content-Length
    any_route_answers = error_responses(
        400, 503, s400="a malformed Content-Length, or one beside a Transfer-Encoding"
    )
    for module in (graphs, animations, players, traces, admin, health):
        app.include_router(module.router, responses=any_route_answers)
    app.router.routes.append(Route("/api/{path:path}", NoRoute(), include_in_schema=False))
    app.mount("/", StaticFiles(directory=STATIC_DIR, html=True), name="client")
    app.add_middleware(HeadAsGet)
    app.add_middleware(
        BodyLimit,
        default=settings.api.max_body_bytes,
        per_path={traces.router.prefix: settings.api.max_trace_bytes},
    )
    origins = [origin.strip() for origin in settings.api.cors_origins.split(",") if origin.strip()]
    if origins:  # added last: outermost, so refusals (413, 429) carry CORS headers too
        app.add_middleware(
            CORSMiddleware,
            allow_origins=origins,
            allow_methods=CORS_METHODS,
            allow_headers=CORS_REQUEST_HEADERS,
            expose_headers=CORS_EXPOSED_HEADERS,
            max_age=600,
        )
    app.openapi = lambda: _declared_errors_only(app)  # type: ignore[method-assign]
    return app


def _broker_probe(settings: Settings) -> BrokerProbe | None:
    """What ``/api/health`` asks of the broker; None without one, and then Celery is
    never imported (a server of the embedded default, or an API-only install)."""
    if settings.eager:
        return None
    from app.tasks.broker_health import BrokerProbe

    return BrokerProbe(settings)


def _declared_errors_only(app: FastAPI) -> dict[str, Any]:
    """The OpenAPI document minus FastAPI's default 422 (``HTTPValidationError``, a body
    the API never sends): where a route can answer 422 it declares the ``ErrorBody`` one."""
    if app.openapi_schema is None:
        document = FastAPI.openapi(app)
        default = {"$ref": "#/components/schemas/HTTPValidationError"}
        for operations in document["paths"].values():
            for operation in operations.values():
                declared = operation["responses"].get("422", {})
                if declared.get("content", {}).get("application/json", {}).get("schema") == default:
                    del operation["responses"]["422"]
        for name in ("HTTPValidationError", "ValidationError"):
            document.get("components", {}).get("schemas", {}).pop(name, None)
        app.openapi_schema = document
    return app.openapi_schema
