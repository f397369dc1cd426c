"""Animations of nearly identical clips stored once (the paper's section 8).

Growth simulates many clips that look alike: water settled under one tilt, or sloshing
the same way from nearly the same state. Before a clip's animation is rendered, the
clips of the graph whose animations are already stored are searched for one that shows
the same thing, and its animation is reused.

The search is two-staged, like the best-target search of growth: the occupancy
descriptors (eq. 7, kept in memory by the graph) pick the few nearest clips of the same
control, and eq. 3's full distance decides. Showing clip ``b`` in place of clip ``a`` is
neither a blend of ``a`` into ``b`` nor the reverse, so the substitution error is the
larger of the two directions, and a substitute is accepted only when that error is at
most ``max_error`` (a fraction of the high-error threshold, docs/dedup.md).

Only clips that own their animation (rendered from their own frames) stand in for
others, so substitutions never chain: every reused animation is within ``max_error`` of
the clip it was rendered from. A clip only ever shows an earlier clip's animation, so a
graph's first clip holding an animation is its owner (:func:`animation_owners`).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np

from app.core.graph.dynamics import ClipFeatures, Dynamics

#: descriptor neighbours whose full distance (eq. 3) is measured
CANDIDATES = 4


@dataclass(frozen=True)
class Substitute:
    """A rendered clip whose animation can be shown for another clip."""

    clip: int
    #: eq. 3 between the two clips, the larger of both directions
    error: float
    #: eq. 7: L2 between the two clips' occupancy descriptors
    descriptor_distance: float


def substitution_error(dynamics: Dynamics, a: ClipFeatures, b: ClipFeatures) -> float:
    """The error of showing clip ``b``'s animation for clip ``a``: eq. 3 both ways, the larger."""
    return max(dynamics.dist(a, b, a.control), dynamics.dist(b, a, b.control))


def animation_owners(clip_animations: Mapping[int, str]) -> dict[str, int]:
    """The clip each animation was rendered from: the first clip holding it."""
    owners: dict[str, int] = {}
    for clip in sorted(clip_animations):
        owners.setdefault(clip_animations[clip], clip)
    return owners


def find_substitute(
    features: ClipFeatures,
    owners: np.ndarray,
    owner_controls: np.ndarray,
    owner_descriptors: np.ndarray,
    owner_features: Callable[[int], ClipFeatures],
    dynamics: Dynamics,
    max_error: float,
    candidates: int = CANDIDATES,
) -> Substitute | None:
    """The owner clip that can stand in for ``features``' clip, or None.

    Parameters
    ----------
    features : ClipFeatures
        The clip about to be rendered.
    owners, owner_controls, owner_descriptors : ndarray
        Clips that own an animation, their controls and their descriptors (one row each).
    owner_features : callable
        The full features (occupancy included) of an owner clip, read only for the
        ``candidates`` nearest by descriptor.
    max_error : float
        The largest substitution error accepted; 0 or less disables substitution.

    Returns
    -------
    Substitute or None
        Of the ``candidates`` same-control owners nearest by descriptor, the one with the
        smallest substitution error, if that error is at most ``max_error``.
    """
    if max_error <= 0.0 or len(owners) == 0:
        return None
    same = np.flatnonzero(np.asarray(owner_controls) == features.control)
    if same.size == 0:
        return None
    descriptor = np.asarray(features.descriptor, dtype=np.float64).ravel()
    rows = np.asarray(owner_descriptors, dtype=np.float64)[same].reshape(same.size, -1)
    distances = np.linalg.norm(rows - descriptor, axis=1)
    nearest = np.argsort(distances, kind="stable")[:candidates]
    best: Substitute | None = None
    for i in nearest:
        clip = int(owners[same[i]])
        error = substitution_error(dynamics, features, owner_features(clip))
        if error <= max_error and (best is None or error < best.error):
            best = Substitute(clip, float(error), float(distances[i]))
    return best
