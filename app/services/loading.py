"""The one way a stored graph is loaded: for growth, publishing, prediction and play.

A loaded graph is the graph, its clip bank, its dynamics and the artifact store, at the
database's current revision. Loading 100k edges takes seconds, so each process keeps
the copy it last used (:mod:`app.services.graph_cache`) and one dynamics per scene
(the liquid builds its OpenCL programs once); a Redis cache of clip shapes is shared by
the workers when a Redis URL is configured.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import lru_cache

from sqlalchemy.orm import Session

from app.config import Settings
from app.core.errors import InvalidInput
from app.core.graph.clipbank import ClipBank
from app.core.graph.dynamics import Dynamics
from app.core.graph.graph_entry import GraphEntry
from app.core.graph.state_graph import StateGraph
from app.liquid.devices import LiquidDevices
from app.services.dynamics import make_dynamics, threshold_in_force
from app.services.graph_cache import graph_cache
from app.store.artifacts import ArtifactStore
from app.store.graph_catalogue import graph_entry
from app.store.graph_persistence import load_graph
from app.store.occupancy_cache import RedisShapeCache

#: the cache entries of loaded graphs (one scope: every use case shares the copy)
CACHE_SCOPE = "growth"


class ArtifactDirectoryError(InvalidInput):
    """The artifact directory (SRG_ARTIFACT_DIR, else SRG_VAR_DIR/data) cannot be one."""


@dataclass(frozen=True)
class GraphContext:
    """What every use case of a stored graph derives from it and the settings, built in
    one place (:func:`graph_context`): the graph's entry, its dynamics on the settings'
    devices, and the high-error threshold in force for it."""

    entry: GraphEntry
    dynamics: Dynamics
    threshold: float


@dataclass
class LoadedGraph:
    """A stored graph in memory with what growing it needs."""

    context: GraphContext
    graph: StateGraph
    bank: ClipBank
    artifacts: ArtifactStore

    @property
    def entry(self) -> GraphEntry:
        return self.context.entry

    @property
    def dynamics(self) -> Dynamics:
        return self.context.dynamics


def artifact_store(settings: Settings) -> ArtifactStore:
    """The artifact store of ``settings``; :class:`ArtifactDirectoryError` if a file is in
    the way of its directory (checked before anything is written, not at the first file)."""
    root = settings.resolved_artifact_dir
    existing = next((path for path in (root, *root.parents) if path.exists()), None)
    if existing is not None and not existing.is_dir():
        raise ArtifactDirectoryError(
            f"the artifact directory {root} is not a directory: {existing} is a file "
            "(set SRG_ARTIFACT_DIR or SRG_VAR_DIR)"
        )
    return ArtifactStore(root)


@lru_cache(maxsize=4)
def cached_dynamics(
    name: str, preset: str | None, fluid: str | None, devices: LiquidDevices
) -> Dynamics:
    """One dynamics per scene and process: the liquid builds OpenCL programs once."""
    return make_dynamics(name, preset, fluid, devices=devices)


def graph_dynamics(entry: GraphEntry, settings: Settings) -> Dynamics:
    """The dynamics a stored graph was grown with (its scene names preset and fluid)."""
    devices = LiquidDevices.from_settings(settings)
    scene = entry.scene
    return cached_dynamics(entry.dynamics, scene.preset, scene.fluid, devices)


@lru_cache(maxsize=4)
def _shape_cache(url: str, ttl: int) -> RedisShapeCache:
    return RedisShapeCache.from_url(url, ttl)


def graph_context(entry: GraphEntry, settings: Settings) -> GraphContext:
    """The graph's dynamics and threshold in force, from its entry and the settings."""
    dynamics = graph_dynamics(entry, settings)
    return GraphContext(entry, dynamics, threshold_in_force(settings, dynamics))


def loaded_graph(session: Session, settings: Settings, entry: GraphEntry) -> LoadedGraph:
    """The graph at its current revision: the process's cached copy, or a fresh load.

    The caller owns the returned object until :func:`keep_graph`; on any failure it is
    simply not given back, and the next caller reloads.
    """
    cached = graph_cache.take(session, entry.id, CACHE_SCOPE)
    if isinstance(cached, LoadedGraph):
        cached.context = replace(cached.context, entry=entry)
        return cached
    artifacts = artifact_store(settings)
    context = graph_context(entry, settings)
    graph, bank = load_graph(
        session, entry.id, artifacts, context.dynamics.shape, settings.runtime.clip_cache_mb * 2**20
    )
    if settings.resolved_redis_url:
        cache = _shape_cache(settings.resolved_redis_url, settings.runtime.occupancy_cache_ttl)
        bank.use_shape_cache(cache)
    return LoadedGraph(context, graph, bank, artifacts)


def keep_graph(session: Session, loaded: LoadedGraph) -> None:
    """Give the graph back to the process's cache, at the revision ``session`` sees."""
    graph_cache.put(session, loaded.entry.id, CACHE_SCOPE, loaded)


def open_graph(session: Session, settings: Settings, name: str | int) -> LoadedGraph:
    """The graph by name or id, loaded the one way (cache, Redis shapes)."""
    return loaded_graph(session, settings, graph_entry(session, name))
