"""The blends a threshold study measures (``docs/threshold.md``).

Which clips are simulated (:func:`study_clips`), which targets each dead end is blended
into (:func:`pick_targets`), and how each blend looks through the game camera next to the
simulated clip it stands in for (:func:`measure_pairs`, one :class:`BlendRecord` each).
Fitting the threshold to these records is ``app.liquid.threshold``'s.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from app.core.graph.dynamics import SimClip
from app.core.liquid.silhouette import (
    SilhouetteProjector,
    silhouette_projector,
    silhouettes,
    tank_camera,
)
from app.core.liquid.surface import dequantise_sdf, liquid_volumes, occupancy
from app.core.liquid.visible_error import VisibilityCriterion, swelling, visible_artifacts
from app.liquid.adapter import LiquidDynamics

#: clips simulated for the study: a depth-2 tree (N + N^2 = 12) and random sequences
DEFAULT_CLIPS = 48
SEQUENCE_LENGTH = 9
#: probability that a random sequence keeps its control from one clip to the next
KEEP_CONTROL = 0.6
#: targets of each dead-end clip: these ranks of dist (0 = best) and these quantiles
TARGET_RANKS = (0, 1, 2)
TARGET_QUANTILES = (0.25, 0.5, 0.75, 1.0)
Say = Callable[[str], None]


def no_progress(message: str) -> None:
    pass


@dataclass(frozen=True)
class BlendRecord:
    """One measured blend: dead-end clip ``dead_end`` blended into clip ``target``."""

    dead_end: int
    target: int
    control: int
    rank: int
    dist: float
    mismatch: float
    swelling: float
    jump: float
    volume_swelling: float
    violations: tuple[str, ...]
    image_difference: float | None = None

    @property
    def wrong(self) -> bool:
        return bool(self.violations)


@dataclass
class MeasuredBlends:
    """The records of a study's blends and what rendering them later needs."""

    records: list[BlendRecord]
    #: each blend's int8 SDF frames, in the order of ``records``
    frames: list[np.ndarray]
    #: each simulated clip's silhouettes through the game camera
    masks: list[np.ndarray]
    projector: SilhouetteProjector


def study_clips(
    dyn: LiquidDynamics, clips: int, seed: int, progress: Say = no_progress
) -> list[SimClip]:
    """``clips`` clips from the settled tank: the depth-2 tree first, then random sequences.

    The tree's clips are those a fresh graph starts with; the sequences (the control
    kept with probability :data:`KEEP_CONTROL`, else drawn uniformly) reach the sloshing
    states that play visits.
    """
    rest = dyn.initial_state()
    n = dyn.n_controls
    out: list[SimClip] = []
    firsts = [dyn.simulate(rest, c) for c in range(n)]
    out += firsts[:clips]
    for first in firsts:
        for c in range(n):
            if len(out) < clips:
                out.append(dyn.simulate(first.end_state, c))
    rng = np.random.default_rng(seed)
    while len(out) < clips:
        state, control = rest, int(rng.integers(n))
        for _ in range(min(SEQUENCE_LENGTH, clips - len(out))):
            if rng.random() >= KEEP_CONTROL:
                control = int(rng.integers(n))
            clip = dyn.simulate(state, control)
            out.append(clip)
            state = clip.end_state
        progress(f"simulated {len(out)}/{clips} clips")
    return out


def pick_targets(dists: np.ndarray, controls: list[int]) -> list[tuple[int, int, int]]:
    """(dead end, target, rank) triples: per clip, targets of its control at several ranks.

    ``dists[i, j]`` is dist(i, j, control of j). A clip is never its own target; ranks
    :data:`TARGET_RANKS` and the :data:`TARGET_QUANTILES` of each clip's ranking are
    taken once each.
    """
    out = []
    for i, control in enumerate(controls):
        others = [j for j, c in enumerate(controls) if c == control and j != i]
        if not others:
            continue
        ranked = sorted(others, key=lambda j: (dists[i, j], j))
        last = len(ranked) - 1
        ranks = set(r for r in TARGET_RANKS if r <= last)
        ranks |= {int(round(q * last)) for q in TARGET_QUANTILES}
        out += [(i, ranked[r], r) for r in sorted(ranks)]
    return out


def measure_pairs(
    dyn: LiquidDynamics,
    sims: list[SimClip],
    dists: np.ndarray,
    pairs: list[tuple[int, int, int]],
    criterion: VisibilityCriterion,
    say: Say = no_progress,
) -> MeasuredBlends:
    """Blend each (dead end, target, rank) of ``pairs`` and measure what a player sees.

    ``dists[i, j]`` is the blend error of dead end ``i`` into ``j``; each blend's
    silhouettes are compared with those of the dead end's own simulated clip, and
    ``criterion`` labels the differences visibly wrong or not.
    """
    controls = [s.control for s in sims]
    grid = dyn.grid
    settings = dyn.render_quality
    projector = silhouette_projector(
        tank_camera(dyn.scene.tank, settings.width, settings.height), grid
    )
    sdf = [dequantise_sdf(grid, s.frames) for s in sims]
    masks = [silhouettes(projector, phi) for phi in sdf]
    volumes = [liquid_volumes(grid, occupancy(grid, phi)) for phi in sdf]

    blends: list[BlendRecord] = []
    blend_frames: list[np.ndarray] = []
    for n, (i, j, rank) in enumerate(pairs):
        frames = dyn.blend(sims[i].frames, sims[j].frames)
        phi = dequantise_sdf(grid, frames)
        artifacts = visible_artifacts(silhouettes(projector, phi), masks[i])
        blends.append(
            BlendRecord(
                dead_end=i,
                target=j,
                control=controls[i],
                rank=rank,
                dist=float(dists[i, j]),
                mismatch=artifacts.mismatch,
                swelling=artifacts.swelling,
                jump=artifacts.jump,
                volume_swelling=swelling(liquid_volumes(grid, occupancy(grid, phi)), volumes[i]),
                violations=criterion.violations(artifacts),
            )
        )
        blend_frames.append(frames)
        if (n + 1) % 50 == 0:
            say(f"measured {n + 1}/{len(pairs)} blends")

    return MeasuredBlends(blends, blend_frames, masks, projector)
