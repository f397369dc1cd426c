"""Device buffers of one PCISPH scene and one method per kernel launch.

:class:`SphKernels` holds the particle arrays on the device in cell-sorted order and
exposes each stage of a substep (sort, neighbours, non-pressure forces, pressure
prediction, density/pressure update) so that tests can hold every kernel to its NumPy
twin in ``app/core``. :class:`app.kernels.sph.SphSimulator` strings the stages together.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pyopencl as cl
import pyopencl.cltypes as cltypes

from app.core.scene import Scene
from app.core.sph import WALL_MARGIN
from app.core.sph_grid import (
    make_grid,
    pcisph_delta,
    sort_by_cell,
    wall_particles,
    wall_volumes,
)
from app.kernels.context import runtime

#: neighbour list capacities (a full fluid neighbourhood has about 33 particles, a wall
#: corner about 40 wall particles); overflows are counted, never written out of bounds
MAX_NEIGHBOURS = 64
MAX_WALL_NEIGHBOURS = 48

_I32, _F32 = np.int32, np.float32


def _float4(v: np.ndarray | tuple[float, ...]) -> np.ndarray:
    x = [float(a) for a in v][:3]
    return np.array((x[0], x[1], x[2], 0.0), dtype=cltypes.float4)


def to_float4(xyz: np.ndarray) -> np.ndarray:
    """(n, 3) -> (n, 4) float32 with a zero w, the device layout."""
    out = np.zeros((len(xyz), 4), dtype=np.float32)
    out[:, :3] = xyz
    return out


class SphKernels:
    """Particle buffers and kernel launches for one scene on this process's device."""

    def __init__(self, scene: Scene, n_particles: int) -> None:
        rt = runtime()
        self.scene, self.n = scene, n_particles
        self.queue = rt.queue
        self.program = rt.program("sph.cl")
        self.kernels = {k.function_name: k for k in self.program.all_kernels()}
        self.grid = make_grid(scene)
        self.delta = pcisph_delta(scene)

        walls = wall_particles(scene)
        order, wall_start = sort_by_cell(walls, self.grid)
        self.walls = walls[order]
        self.psi = wall_volumes(self.walls, scene)
        margin = WALL_MARGIN * scene.spacing
        self.lo = _float4(np.asarray(scene.tank.lo) + margin)
        self.hi = _float4(np.asarray(scene.tank.hi) - margin)
        h = scene.support
        self.grid_args = (
            _float4(self.grid.origin),
            np.array((*self.grid.dims, 0), dtype=cltypes.int4),
            _F32(1.0 / self.grid.cell_size),
            _F32(h),
            _F32(8.0 / (math.pi * h**3)),
            _F32(scene.particle_mass),
        )

        ctx, n, nc = rt.context, n_particles, self.grid.n_cells
        mf = cl.mem_flags

        def buf(nbytes: int) -> cl.Buffer:
            return cl.Buffer(ctx, mf.READ_WRITE, max(nbytes, 4))

        def const(a: np.ndarray) -> cl.Buffer:
            flags = mf.READ_WRITE | mf.COPY_HOST_PTR
            return cl.Buffer(ctx, flags, hostbuf=np.ascontiguousarray(a))

        self.walls_buf = const(to_float4(self.walls))
        self.psi_buf = const(self.psi)
        self.wall_start = const(wall_start.astype(_I32))
        self.pos, self.vel, self.pos_spare, self.vel_spare = (buf(16 * n) for _ in range(4))
        self.pos_pred, self.vel_pred, self.a_np = (buf(16 * n) for _ in range(3))
        self.p, self.p_spare, self.rho = (buf(4 * n) for _ in range(3))
        self.ids, self.ids_spare, self.cell, self.order = (buf(4 * n) for _ in range(4))
        self.counts = const(np.zeros(nc, dtype=_I32))
        self.start, self.cursor = buf(4 * (nc + 1)), buf(4 * nc)
        self.nb, self.nb_count = buf(4 * n * MAX_NEIGHBOURS), buf(4 * n)
        self.wall_nb, self.wall_nb_count = buf(4 * n * MAX_WALL_NEIGHBOURS), buf(4 * n)
        self.err = buf(4 * max(scene.max_iterations, 1))
        self.overflow = const(np.zeros(1, dtype=_I32))
        self.frame = buf(16 * n)

    def _run(self, name: str, size: int, *args: Any) -> None:
        self.kernels[name](self.queue, (size,), None, *args)

    # -- state in and out ----------------------------------------------------------------
    def load(self, state: np.ndarray) -> None:
        """Positions and velocities of a state (n, 6); pressures to zero; ids = row."""
        cl.enqueue_copy(self.queue, self.pos, to_float4(state[:, 0:3]))
        cl.enqueue_copy(self.queue, self.vel, to_float4(state[:, 3:6]))
        cl.enqueue_copy(self.queue, self.p, np.zeros(self.n, dtype=_F32))
        cl.enqueue_copy(self.queue, self.ids, np.arange(self.n, dtype=_I32))

    def load_pressure(self, p: np.ndarray) -> None:
        """Overwrite the (sorted-order) pressures, e.g. to test a kernel with given ones."""
        cl.enqueue_copy(self.queue, self.p, np.ascontiguousarray(p, dtype=_F32))

    def read(self, buffer: cl.Buffer, dtype: type, width: int = 1) -> np.ndarray:
        """Copy a device buffer of n rows (in sorted order) to the host."""
        shape = (self.n, width) if width > 1 else (self.n,)
        out: np.ndarray = np.empty(shape, dtype=dtype)
        cl.enqueue_copy(self.queue, out, buffer)
        return out

    def enqueue_unsorted(self, buffer: cl.Buffer, out: np.ndarray) -> cl.Event:
        """Copy float4 rows of ``buffer`` into ``out`` (n, 4) in the caller's order."""
        self._run("unsort", self.n, self.ids, buffer, self.frame)
        return cl.enqueue_copy(self.queue, out, self.frame, is_blocking=False)

    # -- stages of a substep -------------------------------------------------------------
    def sort(self) -> None:
        """Counting sort by cell, ties by previous index; permutes pos, vel, p, ids."""
        g = self.grid_args
        nc = self.grid.n_cells
        self._run("count_cells", self.n, self.pos, self.cell, self.counts, g[0], g[2], g[1])
        self._run("scan_cells", 1, self.counts, self.start, self.cursor, _I32(nc))
        self._run("scatter_cells", self.n, self.cell, self.cursor, self.order)
        self._run("sort_cells", nc, self.start, self.order)
        self._run(
            "reorder",
            self.n,
            self.order,
            self.pos,
            self.vel,
            self.p,
            self.ids,
            self.pos_spare,
            self.vel_spare,
            self.p_spare,
            self.ids_spare,
        )
        self.pos, self.pos_spare = self.pos_spare, self.pos
        self.vel, self.vel_spare = self.vel_spare, self.vel
        self.p, self.p_spare = self.p_spare, self.p
        self.ids, self.ids_spare = self.ids_spare, self.ids

    def find_neighbours(self) -> None:
        self._run(
            "find_neighbours",
            self.n,
            self.pos,
            self.start,
            self.walls_buf,
            self.wall_start,
            *self.grid_args,
            _I32(MAX_NEIGHBOURS),
            _I32(MAX_WALL_NEIGHBOURS),
            self.nb,
            self.nb_count,
            self.wall_nb,
            self.wall_nb_count,
            self.overflow,
        )

    def nonpressure_accel(self, gravity: tuple[float, float, float]) -> None:
        s = self.scene
        visc = 10.0 * s.viscosity * s.particle_mass / s.rest_density
        wall_visc = 10.0 * s.wall_viscosity / s.rest_density
        self._run(
            "nonpressure_accel",
            self.n,
            self.pos,
            self.vel,
            self.nb,
            self.nb_count,
            _I32(MAX_NEIGHBOURS),
            self.walls_buf,
            self.psi_buf,
            self.wall_nb,
            self.wall_nb_count,
            _I32(MAX_WALL_NEIGHBOURS),
            *self.grid_args,
            _float4(gravity),
            _F32(visc),
            _F32(wall_visc),
            self.a_np,
        )

    def pressure_predict(self, damping: float = 0.0) -> None:
        s = self.scene
        self._run(
            "pressure_predict",
            self.n,
            self.pos,
            self.vel,
            self.p,
            self.a_np,
            self.nb,
            self.nb_count,
            _I32(MAX_NEIGHBOURS),
            self.walls_buf,
            self.psi_buf,
            self.wall_nb,
            self.wall_nb_count,
            _I32(MAX_WALL_NEIGHBOURS),
            *self.grid_args,
            _F32(1.0 / s.rest_density**2),
            _F32(s.dt),
            _F32(damping),
            self.lo,
            self.hi,
            self.pos_pred,
            self.vel_pred,
        )

    def density_pressure(self, iteration: int) -> None:
        self._run(
            "density_pressure",
            self.n,
            self.pos_pred,
            self.nb,
            self.nb_count,
            _I32(MAX_NEIGHBOURS),
            self.walls_buf,
            self.psi_buf,
            self.wall_nb,
            self.wall_nb_count,
            _I32(MAX_WALL_NEIGHBOURS),
            *self.grid_args,
            _F32(self.scene.rest_density),
            _F32(self.delta),
            self.p,
            self.rho,
            self.err,
            _I32(iteration),
        )

    def reset_errors(self) -> None:
        zero = np.zeros(1, dtype=np.uint32)
        cl.enqueue_fill_buffer(self.queue, self.err, zero, 0, 4 * self.scene.max_iterations)

    def density_error(self, iteration: int) -> float:
        """Max relative compression of ``iteration`` (waits for the queue)."""
        out = np.empty(1, dtype=np.float32)
        cl.enqueue_copy(self.queue, out, self.err, src_offset=4 * iteration)
        return float(out[0])

    def advance(self) -> None:
        """x(t + dt) = x*, v(t + dt) = v*: swap the predicted buffers in."""
        self.pos, self.pos_pred = self.pos_pred, self.pos
        self.vel, self.vel_pred = self.vel_pred, self.vel

    def overflowed(self) -> int:
        """Largest neighbour count that exceeded a list capacity so far (0: none)."""
        out = np.empty(1, dtype=_I32)
        cl.enqueue_copy(self.queue, out, self.overflow)
        return int(out[0])
