"""The FastAPI application factory: API routes under ``/api``, the web client at ``/``."""

from __future__ import annotations

import logging
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from importlib.resources import files
from pathlib import Path

from fastapi import FastAPI
from fastapi.staticfiles import StaticFiles

from app.api.cache import FrozenCache
from app.api.errors import install_error_handlers
from app.api.growth_jobs import GrowthJobs
from app.api.ratelimit import TokenBucketLimiter
from app.api.routes import admin, animations, graphs, players, traces
from app.config import Settings, get_settings
from app.core.publication import Publication
from app.db import make_engine, session_factory
from app.store.artifacts import ArtifactStore

log = logging.getLogger(__name__)
STATIC_DIR = Path(str(files("app.api") / "static"))
#: publications kept decoded for trace validation / rendered as JSON for clients
PUBLICATIONS_CACHED = 32
PUBLICATION_JSON_CACHED = 8
#: sync routes run on anyio's thread pool (40 threads): one connection each, none waits
POOL_SIZE, POOL_OVERFLOW = 10, 30


def create_app(settings: Settings | None = None) -> FastAPI:
    settings = settings or get_settings()
    engine = make_engine(
        settings.resolved_database_url, pool_size=POOL_SIZE, max_overflow=POOL_OVERFLOW
    )

    @asynccontextmanager
    async def lifespan(_: FastAPI) -> AsyncIterator[None]:
        if not settings.admin_routes_on:
            # the one line `srg serve` shows about it; the token itself is never logged
            log.warning("admin routes are off (grow and publish answer 403): set SRG_ADMIN_TOKEN")
        yield
        engine.dispose()

    app = FastAPI(title="srg", summary="Self-refining games: play API", lifespan=lifespan)
    app.state.settings = settings
    app.state.session_factory = session_factory(engine)
    app.state.artifacts = ArtifactStore(settings.resolved_artifact_dir)
    app.state.limiter = TokenBucketLimiter(settings.uploads_per_minute)
    app.state.publications = FrozenCache[Publication](PUBLICATIONS_CACHED)
    app.state.publication_json = FrozenCache[bytes](PUBLICATION_JSON_CACHED)
    app.state.growth_jobs = GrowthJobs()
    install_error_handlers(app)
    for module in (graphs, animations, players, traces, admin):
        app.include_router(module.router)
    app.mount("/", StaticFiles(directory=STATIC_DIR, html=True), name="client")
    return app
