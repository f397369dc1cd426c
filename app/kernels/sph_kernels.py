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
from app.kernels.launch_shapes import scan_block, work_group

#: neighbour list rows (multiples of 8: the kernels load eight slots at a time, aligned);
#: a row holds 8 neighbours less (room for a whole block of eight candidates), 56 fluid
#: and 48 wall neighbours (a full fluid neighbourhood has about 33 particles, a wall
#: corner about 40 wall particles); overflows are counted, never written out of bounds
MAX_NEIGHBOURS = 64
MAX_WALL_NEIGHBOURS = 56
#: ``check_from`` of a pressure iteration that must run whatever the errors so far
ALWAYS = 2**30

_I32, _F32 = np.int32, np.float32


def _float4(v: np.ndarray | tuple[float, ...]) -> np.ndarray:
    x = [float(a) for a in v][:3]
    return np.array((x[0], x[1], x[2], 0.0), dtype=cltypes.float4)


def to_float4(xyz: np.ndarray) -> np.ndarray:
    """(n, 3) -> (n, 4) float32 with a zero w, the device layout."""
    out = np.zeros((len(xyz), 4), dtype=np.float32)
    out[:, :3] = xyz
    return out


def compaction_table() -> np.ndarray:
    """(256, 8) int32: for each 8-bit lane mask, its set lanes in order, then zeros.

    ``find_neighbours`` permutes a block of eight candidates by the row of its hit mask
    to put the hits first (see ``sph.cl``).
    """
    table = np.zeros((256, 8), dtype=_I32)
    for mask in range(256):
        lanes = [lane for lane in range(8) if mask >> lane & 1]
        table[mask, : len(lanes)] = lanes
    return table


class SphKernels:
    """Particle buffers and kernel launches for one scene on the OpenCL ``device``.

    ``device`` is as in :func:`app.kernels.context.select_device`.
    """

    def __init__(
        self,
        scene: Scene,
        n_particles: int,
        build_options: tuple[str, ...] = (),
        device: str = "",
        profile: bool = False,
        cells_per_scan: int | None = None,
    ) -> None:
        rt = runtime(device)
        self.scene, self.n = scene, n_particles
        #: with ``profile``, a queue of its own that timestamps commands, and every
        #: kernel launch kept with its name (``app.bench.sph_profile`` reads them)
        self.launches: list[tuple[str, cl.Event]] | None = None
        self.queue = rt.queue
        if profile:
            props = cl.command_queue_properties.PROFILING_ENABLE
            self.queue = cl.CommandQueue(rt.context, properties=props)
            self.launches = []
        self.program = rt.program("sph.cl", build_options)
        self.kernels = {k.function_name: k for k in self.program.all_kernels()}
        self._bound: dict[str, list[Any]] = {}
        self._scalars: dict[tuple[Any, ...], Any] = {}
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

        # the neighbour scan reads particle rows in blocks of eight, up to seven past the
        # end: every buffer of positions it scans has eight rows of slack
        self.walls_buf = const(np.concatenate([to_float4(self.walls), np.zeros((8, 4), _F32)]))
        self.psi_buf = const(self.psi)
        self.wall_start = const(wall_start.astype(_I32))
        self.compaction = const(compaction_table())
        # positions swap roles (sorted, spare, predicted): slack in all three
        rows = n + 8
        self.pos, self.vel, self.pos_spare, self.vel_spare = (buf(16 * rows) for _ in range(4))
        self.pos_pred, self.vel_pred, self.a_np = (buf(16 * rows) for _ in range(3))
        self.p, self.p_spare, self.rho = (buf(4 * n) for _ in range(3))
        self.ids, self.ids_spare, self.cell, self.order = (buf(4 * n) for _ in range(4))
        self.counts = const(np.zeros(nc, dtype=_I32))
        self.start, self.cursor = buf(4 * (nc + 1)), buf(4 * nc)
        #: cells per work-item of the scan (``cells_per_scan``, else the device's
        #: :func:`scan_block`), and each block's first slot
        self.scan_block = cells_per_scan or scan_block(rt.device, nc)
        self.scan_blocks = -(-nc // self.scan_block)
        self.block_first = const(np.zeros(self.scan_blocks, dtype=_I32))
        self.nb, self.nb_count = buf(4 * n * MAX_NEIGHBOURS), buf(4 * n)
        # x(t)-geometry of the pressure loop, written by nonpressure_accel (see sph.cl)
        self.pair_scale, self.wall_grad = buf(4 * n * MAX_NEIGHBOURS), buf(16 * n)
        self.wall_nb, self.wall_nb_count = buf(4 * n * MAX_WALL_NEIGHBOURS), buf(4 * n)
        self.err = buf(4 * max(scene.max_iterations, 1))
        self.overflow = const(np.zeros(1, dtype=_I32))
        self.frame = buf(16 * n)

    def _run(self, name: str, size: int, *args: Any) -> None:
        """Enqueue kernel ``name`` on ``size`` work-items, setting only changed arguments.

        pyopencl's ``kernel(queue, ...)`` converts and sets every argument on every call,
        about 170 us of Python for these 20-30 argument kernels, which competes with the
        device's two threads for the two cores; an argument that is the same object as
        last time (a buffer, a cached constant) is not set again.
        """
        kernel = self.kernels[name]
        bound = self._bound.get(name)
        if bound is None:
            bound = self._bound[name] = [None] * len(args)
        for index, arg in enumerate(args):
            if bound[index] is not arg:
                kernel.set_arg(index, arg)
                bound[index] = arg
        event = cl.enqueue_nd_range_kernel(self.queue, kernel, (size,), work_group(size))
        if self.launches is not None:
            self.launches.append((name, event))

    def _i32(self, v: int) -> np.int32:
        """The same argument object for the same value (see :meth:`_run`)."""
        x = self._scalars.get(("i", v))
        if x is None:
            x = self._scalars[("i", v)] = _I32(v)
        return x

    def _f32(self, v: float) -> np.float32:
        x = self._scalars.get(("f", v))
        if x is None:
            x = self._scalars[("f", v)] = _F32(v)
        return x

    def _f4(self, v: tuple[float, float, float]) -> np.ndarray:
        x = self._scalars.get(("f4", *v))
        if x is None:
            x = self._scalars[("f4", *v)] = _float4(v)
        return x

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
        blocks, block = self.scan_blocks, self._i32(self.scan_block)
        if blocks > 1:
            self._run("block_totals", blocks, self.counts, self.block_first, self._i32(nc), block)
            self._run("scan_block_totals", 1, self.block_first, self._i32(blocks))
        self._run(
            "scan_cells",
            blocks,
            self.counts,
            self.start,
            self.cursor,
            self.block_first,
            self._i32(nc),
            block,
        )
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
            self.compaction,
            self._i32(MAX_NEIGHBOURS),
            self._i32(MAX_WALL_NEIGHBOURS),
            self.nb,
            self.nb_count,
            self.wall_nb,
            self.wall_nb_count,
            self.overflow,
        )

    @property
    def neighbour_args(self) -> tuple[object, ...]:
        """Both neighbour lists and the walls, as ``NEIGHBOUR_ARGS`` in sph.cl takes them."""
        return (
            self.nb,
            self.nb_count,
            self._i32(MAX_NEIGHBOURS),
            self.walls_buf,
            self.psi_buf,
            self.wall_nb,
            self.wall_nb_count,
            self._i32(MAX_WALL_NEIGHBOURS),
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
            *self.neighbour_args,
            *self.grid_args,
            self._f4(gravity),
            self._f32(visc),
            self._f32(wall_visc),
            self.a_np,
            self.pair_scale,
            self.wall_grad,
        )

    def pressure_predict(
        self, damping: float = 0.0, iteration: int = -1, check_from: int = ALWAYS
    ) -> None:
        """Predicted x*, v* from the pressures; needs :meth:`nonpressure_accel` first.

        A no-op on the device if ``iteration >= check_from`` and the max compression of
        ``iteration - 1`` is below eta (the loop has converged; see ``sph.cl``).
        """
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
            self._i32(MAX_NEIGHBOURS),
            self.pair_scale,
            self.wall_grad,
            self._f32(s.particle_mass),
            self._f32(1.0 / s.rest_density**2),
            self._f32(s.dt),
            self._f32(damping),
            self.lo,
            self.hi,
            self.pos_pred,
            self.vel_pred,
            self.err,
            self._i32(iteration),
            self._i32(check_from),
            self._f32(s.eta),
        )

    def density_pressure(self, iteration: int, check_from: int = ALWAYS) -> None:
        """Density at x*, pressure update, max compression into ``err[iteration]``.

        Skipped on the device like :meth:`pressure_predict`.
        """
        self._run(
            "density_pressure",
            self.n,
            self.pos_pred,
            *self.neighbour_args,
            *self.grid_args,
            self._f32(self.scene.rest_density),
            self._f32(self.delta),
            self.p,
            self.rho,
            self.err,
            self._i32(iteration),
            self._i32(check_from),
            self._f32(self.scene.eta),
        )

    def reset_errors(self) -> None:
        zero = np.zeros(1, dtype=np.uint32)
        cl.enqueue_fill_buffer(self.queue, self.err, zero, 0, 4 * self.scene.max_iterations)

    def density_error(self, iteration: int) -> float:
        """Max relative compression of ``iteration`` (waits for the queue)."""
        return float(self.density_errors(iteration + 1)[iteration])

    def enqueue_density_error(self, iteration: int, out: np.ndarray) -> cl.Event:
        """Start copying the max compression of ``iteration`` into ``out`` (one float32)."""
        return cl.enqueue_copy(
            self.queue, out, self.err, src_offset=4 * iteration, is_blocking=False
        )

    def density_errors(self, count: int) -> np.ndarray:
        """Max relative compressions of iterations 0 .. count - 1 (0 where skipped; waits)."""
        out = np.empty(count, dtype=np.float32)
        cl.enqueue_copy(self.queue, out, self.err)
        return out

    def advance(self) -> None:
        """x(t + dt) = x*, v(t + dt) = v*: swap the predicted buffers in."""
        self.pos, self.pos_pred = self.pos_pred, self.pos
        self.vel, self.vel_pred = self.vel_pred, self.vel

    def overflowed(self) -> int:
        """Largest neighbour count that exceeded a list capacity so far (0: none)."""
        out = np.empty(1, dtype=_I32)
        cl.enqueue_copy(self.queue, out, self.overflow)
        return int(out[0])
