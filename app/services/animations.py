"""Animation strips: a clip's frames, or eq. 8's blend of an edge, rendered and stored.

The epochs render the strips of what they add; publishing renders whatever is still
missing. Both call these, so a strip is the same whoever renders it. A clip nearly
identical to one already rendered shows that clip's strip instead of a new one
(:mod:`app.core.graph.dedup`, docs/dedup.md).

A strip is a function of its clip, so one whose file rotted or went missing is rendered
again rather than lost: publishing first forgets the graph's strips that fail their hash
(:func:`forget_unreadable_strips`) and renders them with what is missing, and
``srg fsck --repair`` renders one again from what it shows (:func:`rendered_again`).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from functools import partial

import numpy as np
from sqlalchemy.orm import Session

from app.config import Settings
from app.core.graph.dedup import Substitute, animation_owners, find_substitute
from app.core.graph.dynamics import ClipFeatures, Dynamics
from app.core.graph.state_graph import EdgeKind
from app.render.animation import STRIP_MEDIA_TYPE, encode_strip
from app.services.loading import GraphContext, LoadedGraph, graph_dynamics
from app.services.progress import Advance
from app.store.animations import (
    animation_media_type,
    clip_animations,
    drop_animations,
    edges_without_animation,
    graph_animations,
    rendered_clip_features,
    rendered_clips,
    set_animations,
    strip_source,
)
from app.store.artifacts import ArtifactCorrupt, ArtifactNotFound, ArtifactStore
from app.store.graph_catalogue import graph_entry


def reuse_error_limit(settings: Settings, context: GraphContext) -> float:
    """The largest substitution error at which a clip reuses another's strip (0: never)."""
    return settings.render.dedup_error_fraction * context.threshold


ClipColumns = Callable[[int], tuple[int, np.ndarray]]


class AnimationReuse:
    """The strips of a graph's clips, and which of them a new clip may show instead.

    Holds the owners (clips rendered from their own frames) with their controls and
    descriptors, so each search is one vectorised scan plus a few full distances read
    through ``clip_features``.
    """

    def __init__(
        self,
        dynamics: Dynamics,
        max_error: float,
        animations: Mapping[int, str],
        columns: ClipColumns,
        clip_features: Callable[[int], ClipFeatures],
    ) -> None:
        self.dynamics = dynamics
        self.max_error = max_error
        self.animations = dict(animations)
        self._columns = columns
        self._clip_features = clip_features
        self._owners: list[int] = []
        self._controls: list[int] = []
        self._descriptors: list[np.ndarray] = []
        for clip in sorted(animation_owners(self.animations).values()):
            self._add_owner(clip)

    @classmethod
    def of_graph(
        cls, loaded: LoadedGraph, animations: Mapping[int, str], max_error: float
    ) -> AnimationReuse:
        """Over a loaded graph: columns from the graph, features from its bank."""
        graph = loaded.graph

        def columns(clip: int) -> tuple[int, np.ndarray]:
            return graph.clip_control[clip], graph.clip_descriptor[clip]

        return cls(loaded.dynamics, max_error, animations, columns, loaded.bank.features)

    @classmethod
    def of_stored(
        cls,
        session: Session,
        artifacts: ArtifactStore,
        dynamics: Dynamics,
        graph_id: int,
        control: int,
        max_error: float,
    ) -> AnimationReuse:
        """Over the stored clips of ``control`` alone (the only candidates for a clip of
        that control), for a step that need not load the graph."""
        stored = rendered_clips(session, graph_id, control) if max_error > 0.0 else []
        rows = {row.clip: row for row in stored}

        def columns(clip: int) -> tuple[int, np.ndarray]:
            return rows[clip].control, rows[clip].descriptor

        def features(clip: int) -> ClipFeatures:
            return rendered_clip_features(artifacts, rows[clip], dynamics.shape)

        animations = {c: row.animation for c, row in rows.items() if row.animation is not None}
        return cls(dynamics, max_error, animations, columns, features)

    def strip(
        self,
        session: Session,
        artifacts: ArtifactStore,
        features: ClipFeatures,
        frames: Callable[[], np.ndarray],
        clip: int | None = None,
    ) -> tuple[str, Substitute | None]:
        """The strip of a clip: a nearly identical clip's, else its own ``frames`` rendered.

        Returns the digest and the substitute whose strip it is (None: rendered). A
        ``clip`` of the graph is noted, and when rendered may stand in for later clips.
        """
        found = self.substitute(features, before=clip)
        if found is not None:
            digest = self.animations[found.clip]
        else:
            digest = frames_strip(session, artifacts, self.dynamics, frames())
        if clip is not None:
            self.note(clip, digest, rendered=found is None)
        return digest, found

    def substitute(self, features: ClipFeatures, before: int | None = None) -> Substitute | None:
        """The owner clip whose strip can be shown for ``features``' clip, if any.

        Only clips before ``before`` (the clip's own index, when it has one) stand in, so
        the first clip holding a strip is always the one it was rendered from.
        """
        owners = np.asarray(self._owners, dtype=np.int64)
        earlier = np.ones(owners.size, dtype=bool) if before is None else owners < before
        if self.max_error <= 0.0 or not earlier.any():
            return None
        return find_substitute(
            features,
            owners[earlier],
            np.asarray(self._controls)[earlier],
            np.stack(self._descriptors)[earlier],
            self._clip_features,
            self.dynamics,
            self.max_error,
        )

    def note(self, clip: int, digest: str, *, rendered: bool) -> None:
        """Note ``clip``'s strip; one rendered from its own frames may stand in for later clips."""
        self.animations[clip] = digest
        if rendered:
            self._add_owner(clip)

    def _add_owner(self, clip: int) -> None:
        control, descriptor = self._columns(clip)
        self._owners.append(clip)
        self._controls.append(control)
        self._descriptors.append(np.ravel(descriptor))


def strip_bytes(dynamics: Dynamics, frames: np.ndarray) -> bytes:
    """``frames`` rendered and encoded: the bytes of their strip."""
    return encode_strip(dynamics.render(frames))


def frames_strip(
    session: Session, artifacts: ArtifactStore, dynamics: Dynamics, frames: np.ndarray
) -> str:
    """Render ``frames`` and store the encoded strip; its artifact digest."""
    return artifacts.put_bytes(
        strip_bytes(dynamics, frames), media_type=STRIP_MEDIA_TYPE, session=session
    )


def blend_strip(session: Session, loaded: LoadedGraph, edge: int) -> str:
    """The strip of a BLEND edge: its dead-end clip blended into its target's clip."""
    graph, bank = loaded.graph, loaded.bank
    target_clip = graph.edge_clip[graph.edge_target[edge]]
    frames = loaded.dynamics.blend(bank.frames(graph.edge_clip[edge]), bank.frames(target_clip))
    return frames_strip(session, loaded.artifacts, loaded.dynamics, frames)


def forget_unreadable_strips(session: Session, loaded: LoadedGraph) -> list[str]:
    """Take every strip of the graph whose file is missing or fails its hash off the clips
    and edges showing it, so :func:`render_missing_animations` renders them again; the
    strips taken off.

    Each strip is read and hashed (:meth:`ArtifactStore.get_bytes`, which moves a rotted
    file aside): a byte flipped in place keeps the file's size and time, so only its hash
    tells. A render that gives the same bytes stores them under the same digest, which
    heals the file for older publications too; one that does not gives the graph a new
    digest, and older publications keep the old one (they are frozen).
    """
    unreadable = []
    for digest in sorted(graph_animations(session, loaded.entry.id)):
        try:
            loaded.artifacts.get_bytes(digest)
        except (ArtifactNotFound, ArtifactCorrupt):
            unreadable.append(digest)
    drop_animations(session, loaded.entry.id, unreadable)
    return unreadable


def rendered_again(
    session: Session, settings: Settings, artifacts: ArtifactStore, digest: str
) -> bytes | None:
    """The strip ``digest`` rendered again from what it shows: its owner clip's frames,
    or a BLEND edge's blend (:func:`~app.store.animations.strip_source`); None when no
    clip or edge of a graph shows it any more. The clips' bundles are read verified
    (:class:`~app.store.artifacts.ArtifactCorrupt` if one is not sound)."""
    source = strip_source(session, digest)
    if source is None:
        return None
    dynamics = graph_dynamics(graph_entry(session, source.graph_id), settings)
    frames = artifacts.get_arrays(source.bundle, ("frames",))["frames"]
    if source.blend_into is not None:
        into = artifacts.get_arrays(source.blend_into, ("frames",))["frames"]
        frames = dynamics.blend(frames, into)
    return strip_bytes(dynamics, frames)


def render_missing_animations(
    session: Session, loaded: LoadedGraph, max_reuse_error: float, progress: Advance | None = None
) -> int:
    """Give every edge that has none an animation; return how many edges got one.

    A SIM edge shows its clip (one strip per clip, kept on the clip row: a nearly
    identical clip's within ``max_reuse_error``, else rendered); a BLEND edge shows
    eq. 8's blend of its dead-end clip into its target's clip. SIM edges go in clip
    order, so a strip's owner is the first clip holding it (:mod:`app.core.graph.dedup`).
    """
    graph_id, graph = loaded.entry.id, loaded.graph
    missing = edges_without_animation(session, graph_id, graph.n_controls)
    reuse = AnimationReuse.of_graph(loaded, clip_animations(session, graph_id), max_reuse_error)
    new_clips: dict[int, str] = {}
    edges: dict[int, str] = {}
    for edge in sorted(missing, key=lambda e: (graph.edge_kind[e], graph.edge_clip[e], e)):
        clip = graph.edge_clip[edge]
        if graph.edge_kind[edge] == EdgeKind.BLEND:
            edges[edge] = blend_strip(session, loaded, edge)
        elif clip in reuse.animations:
            edges[edge] = reuse.animations[clip]
        else:
            features, frames = loaded.bank.features(clip), partial(loaded.bank.frames, clip)
            digest, _ = reuse.strip(session, loaded.artifacts, features, frames, clip)
            edges[edge] = new_clips[clip] = digest
        if progress is not None:
            progress(1)
    set_animations(session, graph_id, clips=new_clips, edges=edges)
    return len(edges)


def animation_bytes(
    session: Session, store: ArtifactStore, digest: str
) -> tuple[bytes, str] | None:
    """The bytes, checked against their hash, and media type of a stored animation; None
    when no edge's animation has that digest or its file is gone.

    A file whose bytes no longer match the digest is moved aside by the store, which
    raises :class:`~app.store.artifacts.ArtifactCorrupt`: it is never served under it.
    """
    media_type = animation_media_type(session, digest)
    if media_type is None:
        return None
    try:
        return store.get_bytes(digest), media_type
    except ArtifactNotFound:
        return None
