"""The liquid's clip metrics and blend (paper section 5, eq. 3-8) on voxel fields.

All functions are pure: they take occupancy / SDF arrays and :class:`ClipFeatures` and
return numbers or new arrays. Occupancy may be float fractions or the stored uint8
quantisation; SDFs float metres (``app.core.liquid.surface`` converts stored int8 ones).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from app.core.graph.dynamics import ClipFeatures
from app.core.liquid.surface import OCCUPANCY_LEVELS, dequantise_occupancy

#: eq. 8's limit on the union's blend weight (the paper's l)
BLEND_OVERLAP = 0.1


@dataclass(frozen=True)
class LiquidMetricParams:
    """Constants of eq. 3-6.

    Attributes
    ----------
    rest_kinetic : float
        T0 (J): kinetic energy of the visually settled tank.
    energy_weight : float
        w_e (m^3 / J): calibrated so shape and energy terms match on nearly-at-rest
        clips (:func:`fit_energy_weight`).
    voxel_volume : float
        m^3 per voxel of the occupancy grids.
    c_gain, c_loss : float
        Energy penalty factors, ``c_gain >> c_loss``: creating energy looks wrong,
        losing a little looks like damping.
    """

    rest_kinetic: float
    energy_weight: float
    voxel_volume: float
    c_gain: float = 10.0
    c_loss: float = 1.0


def shape_distance(occ_a: np.ndarray, occ_b: np.ndarray, voxel_volume: float) -> float:
    """Eq. 4: volume (m^3) of the symmetric difference summed over the frames.

    With fractional occupancy the symmetric difference of a voxel is ``|a - b|`` of its
    volume (exact when one of the two is empty or full).
    """
    if occ_a.shape != occ_b.shape:
        raise ValueError(f"occupancy shapes differ: {occ_a.shape} vs {occ_b.shape}")
    if occ_a.dtype == np.uint8 and occ_b.dtype == np.uint8:
        # exact integer sum of the stored levels, scaled once; |a - b| as max - min stays
        # in uint8 (a third of the int16 path's time: it runs ~100 times a blend)
        diff = (np.maximum(occ_a, occ_b) - np.minimum(occ_a, occ_b)).sum(dtype=np.int64)
        return float(diff) / OCCUPANCY_LEVELS * voxel_volume
    a, b = dequantise_occupancy(occ_a), dequantise_occupancy(occ_b)
    return float(np.abs(a - b).sum(dtype=np.float64)) * voxel_volume


def energy_distance(
    e_src: float, e_dst: float, rest_kinetic: float, c_gain: float = 10.0, c_loss: float = 1.0
) -> float:
    """Eq. 5: ``gamma |E_src - E_dst|``, the energy error of blending src into dst.

    Blending into a clip with more energy (by more than T0) creates energy and costs
    ``c_gain``; a loss, or a gain within T0 (visually indistinguishable), costs
    ``c_loss``. (The paper's case split reads on ``|dE|`` alone; with its stated intent,
    "strongly penalizes blending an animation with low energy into an animation with
    high energy", the sign is what decides, as in the toy.)
    """
    gain = e_dst - e_src
    return (c_gain if gain > rest_kinetic else c_loss) * abs(gain)


def energy_normalisation(
    kinetic_a: float, kinetic_b: float, same_control: bool, rest_kinetic: float
) -> float:
    """Eq. 6: 0 for two settled clips of one control, else ``1 / sqrt(T_avg + T0)``."""
    t_avg = 0.5 * (kinetic_a + kinetic_b)
    if t_avg < rest_kinetic and same_control:
        return 0.0
    return 1.0 / math.sqrt(t_avg + rest_kinetic)


def clip_distance(a: ClipFeatures, b: ClipFeatures, control: int, p: LiquidMetricParams) -> float:
    """Eq. 3: ``norm_e (dist_s + w_e dist_e)`` of showing clip ``a`` blended into ``b``."""
    norm = energy_normalisation(a.kinetic, b.kinetic, a.control == b.control, p.rest_kinetic)
    if norm == 0.0:
        return 0.0
    shape = shape_distance(a.occupancy, b.occupancy, p.voxel_volume)
    energy = energy_distance(
        a.energy(control), b.energy(control), p.rest_kinetic, p.c_gain, p.c_loss
    )
    return norm * (shape + p.energy_weight * energy)


def descriptor_distance(a: ClipFeatures, b: ClipFeatures) -> float:
    """Eq. 7: L2 distance of the 6^3 descriptors."""
    return float(np.linalg.norm(np.asarray(a.descriptor) - np.asarray(b.descriptor)))


def blend_weights(k: int, overlap: float = BLEND_OVERLAP) -> tuple[np.ndarray, ...]:
    """Eq. 8's (w_s, w_d, w_union), each (k,), for t = 0 .. 1 over k frames."""
    t = np.linspace(0.0, 1.0, k)
    w_s = np.clip((1 + overlap - 2 * t) / (1 + overlap), 0.0, 1.0)
    w_d = np.clip((2 * t + overlap - 1) / (1 + overlap), 0.0, 1.0)
    return w_s, w_d, 1.0 - w_s - w_d


def blend_sdf(src: np.ndarray, dst: np.ndarray, overlap: float = BLEND_OVERLAP) -> np.ndarray:
    """Eq. 8 on (k, X, Y, Z) float SDFs: source, destination and their union min(s, d).

    Frame 0 is the source's, frame k-1 the destination's; in between the union carries
    thin features (droplets, sheets) across instead of letting them fade and pop.
    """
    if src.shape != dst.shape:
        raise ValueError(f"blend of different shapes: {src.shape} vs {dst.shape}")
    w_s, w_d, w_u = (w.reshape(-1, *([1] * (src.ndim - 1))) for w in blend_weights(len(src)))
    return (w_s * src + w_d * dst + w_u * np.minimum(src, dst)).astype(np.float32)


def fit_energy_weight(shape_distances: np.ndarray, energy_distances: np.ndarray) -> float:
    """w_e with ``dist_s ~ w_e dist_e`` over pairs of nearly-at-rest clips (section 5.1).

    The least-squares slope through the origin, ``sum(s e) / sum(e^2)``: pairs with larger
    energy differences, where the energy term matters, weigh most.

    Raises
    ------
    ValueError
        If every energy distance is zero (nothing to fit).
    """
    s = np.asarray(shape_distances, dtype=np.float64)
    e = np.asarray(energy_distances, dtype=np.float64)
    denominator = float(np.sum(e * e))
    if denominator <= 0.0:
        raise ValueError("w_e needs pairs with different energies")
    return float(np.sum(s * e)) / denominator
