"""Liquid states on a lattice: quantised positions and velocities in Morton order.

A stored end state is the state a continuation starts from, so the liquid snaps its end
states onto this lattice before it returns them: the bytes the store writes give back
exactly the state in memory, and a run continued from the store is the run continued
from memory. The steps are powers of two (2^-e metres, 2^-e m/s), so every lattice value
is exact in float32 and the store can tell, losslessly and without knowing the scene,
that an array lies on such a lattice (``app.store.array_codec``).

The steps (docs/liquid.md, "Bytes"):

- positions: the coarsest power of two no larger than ``dx / 200``; rounding moves a
  particle by at most half a step per axis, which changes the SPH density of a splashing
  ``small`` state by at most about 0.35 % of rho0 (0.09 % rms), a third of the 1 % that
  PCISPH's pressure solve tolerates at every substep;
- velocities: 2^-8 m/s (3.9 mm/s); the error of at most 2 mm/s is 0.1 % of the free-fall
  speed over the tank's height, a few per cent of the residual speeds of a settled tank,
  and moves a particle by a few micrometres per substep, under a position step.

Particles are put in Morton (Z-curve) order of their quantised positions: neighbours in
space become neighbours in the array, which makes the row-to-row differences the store
codes small, and the order is a function of the state alone, so snapping twice is
snapping once.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

#: the position step is the coarsest power of two no larger than the spacing over this
POSITION_STEPS_PER_SPACING = 200
#: velocities are multiples of 2^-VELOCITY_EXPONENT m/s
VELOCITY_EXPONENT = 8
#: bits per axis of a Morton code (63 bits in all)
MORTON_BITS = 21


@dataclass(frozen=True)
class ParticleLattice:
    """Steps 2^-position_exponent (m) and 2^-velocity_exponent (m/s) of a stored state."""

    position_exponent: int
    velocity_exponent: int = VELOCITY_EXPONENT

    @property
    def position_step(self) -> float:
        return math.ldexp(1.0, -self.position_exponent)

    @property
    def velocity_step(self) -> float:
        return math.ldexp(1.0, -self.velocity_exponent)


def particle_lattice(spacing: float) -> ParticleLattice:
    """The lattice of a scene whose particle spacing is ``spacing`` (m)."""
    if spacing <= 0:
        raise ValueError(f"spacing must be positive, got {spacing}")
    return ParticleLattice(math.ceil(-math.log2(spacing / POSITION_STEPS_PER_SPACING)))


def _spread_bits(x: np.ndarray) -> np.ndarray:
    """The low 21 bits of ``x`` with two zero bits after each (the Morton interleave)."""
    x = x.astype(np.uint64) & np.uint64(0x1FFFFF)
    for shift, mask in (
        (32, 0x1F00000000FFFF),
        (16, 0x1F0000FF0000FF),
        (8, 0x100F00F00F00F00F),
        (4, 0x10C30C30C30C30C3),
        (2, 0x1249249249249249),
    ):
        x = (x | (x << np.uint64(shift))) & np.uint64(mask)
    return x


def morton_codes(cells: np.ndarray) -> np.ndarray:
    """Z-curve codes (uint64) of (n, 3) non-negative integer cells below 2^21 per axis."""
    cells = np.asarray(cells)
    if cells.size and (cells.min() < 0 or cells.max() >= 1 << MORTON_BITS):
        raise ValueError(f"Morton cells must lie in [0, 2^{MORTON_BITS})")
    return (
        _spread_bits(cells[:, 0])
        | (_spread_bits(cells[:, 1]) << np.uint64(1))
        | (_spread_bits(cells[:, 2]) << np.uint64(2))
    )


def _compact_bits(x: np.ndarray) -> np.ndarray:
    """Every third bit of ``x`` from bit 0, packed into the low 21 bits (undoes the spread)."""
    x = x & np.uint64(0x1249249249249249)
    for shift, mask in (
        (2, 0x10C30C30C30C30C3),
        (4, 0x100F00F00F00F00F),
        (8, 0x1F0000FF0000FF),
        (16, 0x1F00000000FFFF),
        (32, 0x1FFFFF),
    ):
        x = (x | (x >> np.uint64(shift))) & np.uint64(mask)
    return x


def morton_cells(codes: np.ndarray) -> np.ndarray:
    """The (n, 3) int64 cells of uint64 Z-curve codes: the inverse of :func:`morton_codes`."""
    codes = np.asarray(codes, dtype=np.uint64)
    axes = [_compact_bits(codes >> np.uint64(axis)) for axis in range(3)]
    return np.stack(axes, axis=1).astype(np.int64)


def snap_state(state: np.ndarray, lattice: ParticleLattice) -> np.ndarray:
    """The (n, 6) float32 state on ``lattice``, its particles in Morton order.

    Positions are rounded to multiples of the position step (the tank's lower corner is
    the origin, so its cells are non-negative), velocities to multiples of the velocity
    step. Idempotent: a snapped state snaps to itself, bit for bit.
    """
    state = np.asarray(state, dtype=np.float32)
    # + 0.0 turns -0.0 into 0.0: one zero, so the stored bytes can be integers
    positions = np.rint(np.ldexp(state[:, :3].astype(np.float64), lattice.position_exponent))
    positions += 0.0
    velocities = np.rint(np.ldexp(state[:, 3:6].astype(np.float64), lattice.velocity_exponent))
    velocities += 0.0
    order = np.argsort(morton_codes(np.maximum(positions, 0).astype(np.int64)), kind="stable")
    snapped = np.empty_like(state)
    snapped[:, :3] = np.ldexp(positions[order], -lattice.position_exponent)
    snapped[:, 3:6] = np.ldexp(velocities[order], -lattice.velocity_exponent)
    return snapped
