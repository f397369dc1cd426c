"""How the SPH kernels' data lies on the device: neighbour list rows, float4 rows, and
the lane table of the AVX2 list build (``app/kernels/pcisph.cl``)."""

from __future__ import annotations

import numpy as np

#: neighbour list rows (multiples of 8: the kernels load eight slots at a time, aligned);
#: a row holds 8 neighbours less (room for a whole block of eight candidates), 56 fluid
#: and 48 wall neighbours (a full fluid neighbourhood has about 33 particles, a wall
#: corner about 40 wall particles); overflows are counted, never written out of bounds
MAX_NEIGHBOURS = 64
MAX_WALL_NEIGHBOURS = 56


def to_float4(xyz: np.ndarray) -> np.ndarray:
    """(n, 3) -> (n, 4) float32 with a zero w, the device layout."""
    out = np.zeros((len(xyz), 4), dtype=np.float32)
    out[:, :3] = xyz
    return out


def compaction_table() -> np.ndarray:
    """(256, 8) int32: for each 8-bit lane mask, its set lanes in order, then zeros.

    ``find_neighbours`` permutes a block of eight candidates by the row of its hit mask
    to put the hits first (see ``pcisph.cl``).
    """
    table = np.zeros((256, 8), dtype=np.int32)
    for mask in range(256):
        lanes = [lane for lane in range(8) if mask >> lane & 1]
        table[mask, : len(lanes)] = lanes
    return table
