"""The per-clip steps of an epoch: simulate, surface (the liquid's SDF), render.

Simulating and surfacing read and write artifacts only and note the clip on an
``expansion_clips`` row; rendering gives the expansion's dead-end clip its strip. So a
worker can run any of them for any planned clip, and a redelivered step finds its work
done. Simulating needs no database at all
(:func:`simulate_job`), so the eager path computes outside any transaction.
"""

from __future__ import annotations

import hashlib
import logging
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np
from sqlalchemy.orm import Session

from app.core.errors import NotFound
from app.core.graph.dynamics import ClipFeatures, Dynamics, SimClip
from app.core.graph.graph_entry import GraphEntry
from app.services.animations import AnimationReuse, frames_strip, reuse_error_limit
from app.services.loading import graph_context, graph_dynamics
from app.services.scope import Scope
from app.store.animations import clip_features, set_animations, stored_clip
from app.store.array_codec import ARRAYS_MEDIA_TYPE
from app.store.artifacts import ArtifactCorrupt, ArtifactNotFound
from app.store.epochs import expansion_clip, get_epoch, record_clip, stored_clips
from app.store.graph_catalogue import clip_bundle_digest, graph_entry
from app.store.simulated_clips import record_simulated_clip, simulated_clip

log = logging.getLogger(__name__)


@runtime_checkable
class SurfacedDynamics(Protocol):
    """A dynamics whose clips are particles first and surfaces second (the liquid).

    Its two stages run as two steps, so a worker with OpenCL for the SDF need not be the
    one that ran PCISPH; a dynamics without them (the toy) simulates whole clips.
    """

    def simulate_particles(
        self, states: Sequence[np.ndarray], controls: Sequence[int]
    ) -> list[tuple[np.ndarray, np.ndarray]]: ...

    def surface_frames(self, positions: np.ndarray) -> np.ndarray: ...

    @property
    def simulation_identity(self) -> str: ...


@dataclass(frozen=True)
class ClipJob:
    """What simulating one planned clip needs, read from the database beforehand."""

    dynamics: Dynamics
    state: np.ndarray
    control: int


def planned_clip(session: Session, epoch_id: int, position: int) -> tuple[GraphEntry, int]:
    """The graph of the epoch and the dead-end clip its expansion ``position`` starts from."""
    epoch = get_epoch(session, epoch_id)
    entry = graph_entry(session, epoch.graph_id)
    if not 0 <= position < len(epoch.plan):
        raise NotFound(f"epoch {epoch_id} plans no expansion {position}")
    return entry, epoch.plan[position][1]


def clip_job(scope: Scope, epoch_id: int, position: int, control: int) -> ClipJob | str:
    """The start state and dynamics of a planned clip, or its digest once recorded."""
    if (stored := expansion_clip(scope.session, epoch_id, position, control)) is not None:
        return stored  # a redelivery after the clip was recorded
    return _planned_job(scope, epoch_id, position, control)


def _planned_job(scope: Scope, epoch_id: int, position: int, control: int) -> ClipJob:
    entry, dead_end = planned_clip(scope.session, epoch_id, position)
    bundle = clip_bundle_digest(scope.session, entry.id, dead_end)
    if bundle is None:
        raise NotFound(f"graph {entry.id} has no clip {dead_end}")
    state = scope.artifacts.get_arrays(bundle, ("end_state",))["end_state"]
    return ClipJob(graph_dynamics(entry, scope.settings), state, control)


def simulation_key(job: ClipJob) -> str | None:
    """What determines the job's clip, hashed: the dynamics' identity, the control and
    the start state's bytes; None for a dynamics whose clips are not worth remembering
    (the toy simulates faster than a lookup)."""
    if not isinstance(job.dynamics, SurfacedDynamics):
        return None
    digest = hashlib.sha256(job.dynamics.simulation_identity.encode())
    digest.update(np.int64(job.control).tobytes())
    digest.update(np.ascontiguousarray(job.state).tobytes())
    return digest.hexdigest()


def remembered_clip(scope: Scope, job: ClipJob) -> str | None:
    """The clip of an identical simulation done before, registered again in this
    transaction (docs/runtime.md, "Each simulation once"); None: simulate it.

    Its file is read and checked, which also marks it as in use for ``srg gc``; one that
    was collected or fails its hash is a miss.
    """
    key = simulation_key(job) if scope.settings.growth.reuse_simulations else None
    digest = None if key is None else simulated_clip(scope.session, key)
    if digest is None:
        return None
    try:
        data = scope.artifacts.get_bytes(digest)
    except (ArtifactNotFound, ArtifactCorrupt):
        return None
    return scope.artifacts.put_bytes(data, media_type=ARRAYS_MEDIA_TYPE, session=scope.session)


def remember_clip(scope: Scope, job: ClipJob, clip: str) -> None:
    """Note ``clip`` as the simulation of ``job`` for the next identical one."""
    key = simulation_key(job) if scope.settings.growth.reuse_simulations else None
    if key is not None:
        record_simulated_clip(scope.session, key, clip)


def simulate_job(job: ClipJob) -> dict[str, np.ndarray]:
    """The simulated stage of a clip, no database needed (see :func:`simulate_jobs`)."""
    return simulate_jobs([job])[0]


def simulate_jobs(jobs: Sequence[ClipJob]) -> list[dict[str, np.ndarray]]:
    """The simulated stages of clips of one dynamics (an expansion's), no database needed.

    A :class:`SurfacedDynamics` (the liquid) simulates them together, in batches: the
    particle positions of the k frames and the end state, the surface is
    :func:`finish_clip`'s. Any other: each whole clip.
    """
    if not jobs:
        return []
    dynamics = jobs[0].dynamics
    if any(job.dynamics is not dynamics for job in jobs):
        raise ValueError("clips simulated together share one dynamics")
    if isinstance(dynamics, SurfacedDynamics):
        controls = [job.control for job in jobs]
        simulated = dynamics.simulate_particles([job.state for job in jobs], controls)
        return [
            {
                "positions": positions,
                "end_state": end_state,
                "control": np.asarray(control, dtype=np.int64),
            }
            for (positions, end_state), control in zip(simulated, controls, strict=True)
        ]
    sims = dynamics.simulate_many([job.state for job in jobs], [job.control for job in jobs])
    return [clip_arrays(sim, dynamics.features(sim)) for sim in sims]


def finish_clip(dynamics: Dynamics, stage: dict[str, np.ndarray]) -> dict[str, np.ndarray] | None:
    """The clip (surface frames and features) of a simulated stage.

    None when the stage already is the clip (a dynamics that is not surfaced).
    """
    if not isinstance(dynamics, SurfacedDynamics) or "positions" not in stage:
        return None
    frames = dynamics.surface_frames(stage["positions"])
    sim = SimClip(control=int(stage["control"]), frames=frames, end_state=stage["end_state"])
    return clip_arrays(sim, dynamics.features(sim))


def clip_arrays(sim: SimClip, features: ClipFeatures) -> dict[str, np.ndarray]:
    """Everything integrating a clip needs of it, exactly (no float rounding)."""
    return {
        "control": np.asarray(sim.control, dtype=np.int64),
        "frames": np.asarray(sim.frames),
        "end_state": np.asarray(sim.end_state),
        "kinetic": np.asarray(features.kinetic, dtype=np.float64),
        "potential": np.asarray(features.potential, dtype=np.float64),
        "occupancy": np.asarray(features.occupancy),
        "descriptor": np.asarray(features.descriptor),
        "score": np.asarray(features.score, dtype=np.float64),
    }


def clip_from_arrays(arrays: dict[str, np.ndarray]) -> tuple[SimClip, ClipFeatures]:
    """The clip and features that :func:`clip_arrays` stored."""
    control = int(arrays["control"])
    sim = SimClip(control=control, frames=arrays["frames"], end_state=arrays["end_state"])
    features = ClipFeatures(
        control=control,
        kinetic=float(arrays["kinetic"]),
        potential=arrays["potential"],
        occupancy=arrays["occupancy"],
        descriptor=arrays["descriptor"],
        score=float(arrays["score"]),
    )
    return sim, features


def record_finished(
    scope: Scope,
    epoch_id: int,
    position: int,
    control: int,
    job: ClipJob,
    clip: dict[str, np.ndarray],
) -> str:
    """Store and record the finished clip of a planned one, remembered for the next
    identical simulation; its artifact's digest."""
    digest = scope.artifacts.put_arrays(clip, session=scope.session)
    record_clip(scope.session, epoch_id, position, control, digest)
    remember_clip(scope, job, digest)
    return digest


def simulate_step(scope: Scope, epoch_id: int, position: int, control: int) -> str:
    """Simulate one clip of a planned expansion; return its stage artifact's digest
    (the finished clip's when an identical simulation was done before).

    With ``SRG_SIMULATE_BATCH`` above 1 the clip runs in one launch sequence with the
    epoch's other missing clips, which are finished and recorded here, so that their
    own steps find them done (docs/runtime.md, "Clips together on a worker").
    """
    session = scope.session
    job = clip_job(scope, epoch_id, position, control)
    if isinstance(job, str):
        return job
    if (remembered := remembered_clip(scope, job)) is not None:
        return remembered
    companions = _companions(scope, epoch_id, position, control, job)
    stages = simulate_jobs([job, *companions.values()])
    finished = [finish_clip(job.dynamics, stage) or stage for stage in stages[1:]]
    for (p, c), companion, clip in zip(companions, companions.values(), finished, strict=True):
        record_finished(scope, epoch_id, p, c, companion, clip)
    if companions:
        log.info(
            "epoch %d: clip %d/%d simulated together with %d more of the epoch",
            epoch_id, position, control, len(companions),
        )  # fmt: skip
    return scope.artifacts.put_arrays(stages[0], session=session)


def _companions(
    scope: Scope, epoch_id: int, position: int, control: int, job: ClipJob
) -> dict[tuple[int, int], ClipJob]:
    """Up to ``SRG_SIMULATE_BATCH - 1`` other clips of the epoch not yet recorded, to
    simulate with (position, control)'s: its expansion's first, then the plan's next
    expansions, wrapping round (the earlier ones' own steps were sent first). A clip
    remembered from an earlier simulation is left to its own step, which reuses it.
    Only a surfaced dynamics runs clips together."""
    session, settings = scope.session, scope.settings
    room = settings.runtime.simulate_batch - 1
    if room <= 0 or not isinstance(job.dynamics, SurfacedDynamics):
        return {}
    plan_length = len(get_epoch(session, epoch_id).plan)
    n_controls = job.dynamics.n_controls
    recorded = stored_clips(session, epoch_id)
    order = sorted(
        ((p, c) for p in range(plan_length) for c in range(n_controls)),
        key=lambda clip: ((clip[0] - position) % plan_length, clip[1]),
    )
    companions: dict[tuple[int, int], ClipJob] = {}
    for p, c in order:
        if len(companions) == room:
            break
        if (p, c) == (position, control) or (p, c) in recorded:
            continue
        companion = _planned_job(scope, epoch_id, p, c)
        key = simulation_key(companion) if settings.growth.reuse_simulations else None
        if key is None or simulated_clip(session, key) is None:
            companions[p, c] = companion
    return companions


def sdf_step(scope: Scope, stage: str, epoch_id: int, position: int, control: int) -> str:
    """Turn a simulated stage into a clip and record it; return the clip artifact."""
    session, artifacts = scope.session, scope.artifacts
    stored = expansion_clip(session, epoch_id, position, control)
    if stored is not None:
        return stored
    job = _planned_job(scope, epoch_id, position, control)
    clip = finish_clip(job.dynamics, artifacts.get_arrays(stage))
    digest = stage if clip is None else artifacts.put_arrays(clip, session=session)
    record_clip(session, epoch_id, position, control, digest)
    if clip is not None:
        remember_clip(scope, job, digest)
    return digest


def render_step(scope: Scope, clip: str, epoch_id: int, position: int, control: int) -> str:
    """Give the clip that expansion ``position`` makes a simulation its strip (once);
    return ``clip``, the recorded new clip, as it came.

    A new clip ends on a blend edge, which shows eq. 8's blend, not the clip: its own strip
    is first shown when that edge is expanded. So an expansion renders one strip, its
    dead-end clip's, in the pipeline of control 0 (docs/runtime.md, "Strips"): a nearly
    identical earlier clip's when there is one (:mod:`app.core.graph.dedup`), else its frames
    rendered.
    """
    session, settings, artifacts = scope.session, scope.settings, scope.artifacts
    if expansion_clip(session, epoch_id, position, control) is None:
        raise NotFound(f"epoch {epoch_id} has no clip {control} of expansion {position}")
    if control != 0:
        return clip
    entry, dead_end = planned_clip(session, epoch_id, position)
    stored = stored_clip(session, entry.id, dead_end)
    if stored.animation is not None:
        return clip
    context = graph_context(entry, settings)
    dynamics = context.dynamics
    frames = artifacts.get_arrays(stored.bundle, ("frames",))["frames"]
    features = clip_features(stored, dynamics.shape(frames))
    limit = reuse_error_limit(settings, context)
    reuse = AnimationReuse.of_stored(session, artifacts, dynamics, entry.id, stored.control, limit)
    found = reuse.substitute(features, before=dead_end)
    strip = (
        frames_strip(session, artifacts, dynamics, frames)
        if found is None
        else reuse.animations[found.clip]
    )
    set_animations(session, entry.id, clips={dead_end: strip})
    return clip
