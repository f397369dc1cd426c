"""Device buffers of one PCISPH scene and one method per kernel launch.

:class:`PcisphKernels` holds the particle arrays on the device in cell-sorted order and
exposes each stage of a substep (sort, neighbours, non-pressure forces, pressure
prediction, density/pressure update) so that tests can hold every kernel to its NumPy
twin in ``app/core``. :class:`app.kernels.pcisph.PcisphSolver` strings the stages together.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import pyopencl as cl
import pyopencl.cltypes as cltypes

from app.core.liquid.pcisph import WALL_MARGIN
from app.core.liquid.scene import Scene
from app.core.liquid.sph_grid import (
    make_grid,
    pcisph_delta,
    sort_by_cell,
    wall_particles,
    wall_volumes,
)
from app.kernels import launch_shapes
from app.kernels.context import runtime
from app.kernels.launcher import Launcher, float4
from app.kernels.sph_layout import (
    MAX_NEIGHBOURS,
    MAX_WALL_NEIGHBOURS,
    compaction_table,
    to_float4,
)

#: the buffers that make a substep's starting state
KEPT = ("pos", "vel", "p", "ids")
#: ``check_from`` of a pressure iteration that must run whatever the errors so far
ALWAYS = 2**30

_I32, _F32 = np.int32, np.float32


class PcisphKernels(Launcher):
    """Particle buffers and kernel launches for one scene on the OpenCL ``device``.

    ``device`` is as in :func:`app.kernels.context.select_device`. The buffers hold up
    to ``batch`` clips of ``n_particles`` each, clip-major (docs/sph.md, "Clips in
    batches"); :meth:`load` says how many the next launches run.
    """

    def __init__(
        self,
        scene: Scene,
        n_particles: int,
        build_options: tuple[str, ...] = (),
        device: str = "",
        profile: bool = False,
        cells_per_scan: int | None = None,
        batch: int = 1,
    ) -> None:
        rt = runtime(device)
        options = (*launch_shapes.build_options(rt.device), *build_options)
        super().__init__(rt, rt.program("pcisph.cl", options), profile)
        self.scene, self.n_clip, self.capacity = scene, n_particles, batch
        #: clips loaded (:meth:`load`) and their rows in all
        self.batch, self.n = 1, n_particles
        self.grid = make_grid(scene)
        self.delta = pcisph_delta(scene)

        walls = wall_particles(scene)
        order, wall_start = sort_by_cell(walls, self.grid)
        self.walls = walls[order]
        self.psi = wall_volumes(self.walls, scene)
        margin = WALL_MARGIN * scene.spacing
        self.lo = float4(np.asarray(scene.tank.lo) + margin)
        self.hi = float4(np.asarray(scene.tank.hi) - margin)
        h = scene.support
        self.grid_args = (
            float4(self.grid.origin),
            np.array((*self.grid.dims, 0), dtype=cltypes.int4),
            _F32(1.0 / self.grid.cell_size),
            _F32(h),
            _F32(8.0 / (math.pi * h**3)),
            _F32(scene.particle_mass),
        )

        ctx, n, nc = rt.context, batch * n_particles, batch * self.grid.n_cells
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
        #: cells a scan work-item walks (else set by :meth:`load`); each block's first slot
        self.cells_per_scan = cells_per_scan
        self.block_first = const(np.zeros(nc, dtype=_I32))  # at most a block per cell
        self.nb, self.nb_count = buf(4 * n * MAX_NEIGHBOURS), buf(4 * n)
        # x(t)-geometry of the pressure loop, written by nonpressure_accel (see pcisph.cl)
        self.pair_scale, self.wall_grad = buf(4 * n * MAX_NEIGHBOURS), buf(16 * n)
        self.wall_nb, self.wall_nb_count = buf(4 * n * MAX_WALL_NEIGHBOURS), buf(4 * n)
        # room for a frame's substeps queued at once, each with every iteration allowed,
        # per clip; and each clip's gravity
        self.err = buf(4 * batch * scene.substeps * max(scene.max_iterations, 1))
        self.gravity = buf(16 * batch)
        #: the gravities in ``gravity`` as given (compared by identity each substep)
        self._gravities: Sequence[tuple[float, float, float]] = ()
        #: the state a frame starts from (:meth:`keep_state`)
        self.kept = {name: buf(16 * rows if name in ("pos", "vel") else 4 * n) for name in KEPT}
        self.overflow = const(np.zeros(1, dtype=_I32))
        self.frame = buf(16 * n)

    # -- state in and out ----------------------------------------------------------------
    def load(self, state: np.ndarray) -> None:
        """Positions and velocities of a state (n, 6), or of a batch of them (b, n, 6),
        one per clip; pressures to zero; ids = row."""
        rows = state.reshape(-1, 6)
        batch = len(rows) // self.n_clip
        if batch * self.n_clip != len(rows) or not 1 <= batch <= self.capacity:
            raise ValueError(
                f"{len(rows)} particle rows are not 1 to {self.capacity} clips of {self.n_clip}"
            )
        self.batch, self.n, self._gravities = batch, len(rows), ()
        cells = batch * self.grid.n_cells
        self._scan = self.cells_per_scan or launch_shapes.scan_block(self.queue.device, cells)
        cl.enqueue_copy(self.queue, self.pos, to_float4(rows[:, 0:3]))
        cl.enqueue_copy(self.queue, self.vel, to_float4(rows[:, 3:6]))
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
    @property
    def per_clip(self) -> tuple[int, int]:
        """The work-items of a kernel that knows each particle's clip: (n_clip, batch)."""
        return self.n_clip, self.batch

    def sort(self) -> None:
        """Counting sort by cell, ties by previous index; permutes pos, vel, p, ids."""
        g = self.grid_args
        nc = self.batch * self.grid.n_cells
        self._run(
            "count_cells",
            self.per_clip,
            self.pos,
            self.cell,
            self.counts,
            g[0],
            g[2],
            g[1],
            self._i32(self.grid.n_cells),
        )
        blocks, block = -(-nc // self._scan), self._i32(self._scan)
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
        self._run(
            "sort_reorder",
            nc,
            self.start,
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
            self.per_clip,
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
            self._i32(self.grid.n_cells),
        )

    @property
    def neighbour_args(self) -> tuple[object, ...]:
        """Both neighbour lists and the walls, as ``NEIGHBOUR_ARGS`` in pcisph.cl takes them."""
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

    def _viscosities(self) -> tuple[float, float]:
        """The fluid and wall factors of the viscous acceleration over one viscous step
        (``scene.viscosity_steps`` of them make a substep)."""
        s = self.scene
        steps = s.viscosity_steps
        visc = 10.0 * s.viscosity * s.particle_mass / s.rest_density
        return visc / steps, 10.0 * s.wall_viscosity / s.rest_density / steps

    def nonpressure_accel(self, gravities: Sequence[tuple[float, float, float]]) -> None:
        """a_np under each loaded clip's gravity, with the last viscous step's share, and
        the pressure loop's geometry."""
        if gravities is not self._gravities:
            if len(gravities) != self.batch:
                raise ValueError(f"{len(gravities)} gravities for {self.batch} clips")
            cl.enqueue_copy(self.queue, self.gravity, np.stack([float4(g) for g in gravities]))
            self._gravities = gravities
        visc, wall_visc = self._viscosities()
        self._run(
            "nonpressure_accel",
            self.per_clip,
            self.pos,
            self.vel,
            *self.neighbour_args,
            *self.grid_args,
            self.gravity,
            self._f32(visc),
            self._f32(wall_visc),
            self.a_np,
            self.pair_scale,
            self.wall_grad,
        )

    def diffuse_velocity(self) -> None:
        """One viscous step of the velocities at x(t) (after :meth:`find_neighbours`)."""
        visc, wall_visc = self._viscosities()
        dt = self.scene.dt
        self._run(
            "diffuse_velocity",
            self.n,
            self.pos,
            self.vel,
            *self.neighbour_args,
            *self.grid_args,
            self._f32(visc * dt),
            self._f32(wall_visc * dt),
            self.vel_spare,
        )
        self.vel, self.vel_spare = self.vel_spare, self.vel

    def pressure_predict(
        self, damping: float = 0.0, iteration: int = -1, check_from: int = ALWAYS
    ) -> None:
        """Predicted x*, v* from the pressures; needs :meth:`nonpressure_accel` first.

        A no-op on the device if ``iteration >= check_from`` and the max compression of
        ``iteration - 1`` is below eta (the loop has converged; see ``pcisph.cl``).
        """
        s = self.scene
        self._run(
            "pressure_predict",
            self.per_clip,
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
            self.per_clip,
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

    def reset_errors(self, count: int) -> None:
        """Zero the errors of the next ``count`` pressure iterations."""
        zero = np.zeros(1, dtype=np.uint32)
        cl.enqueue_fill_buffer(self.queue, self.err, zero, 0, 4 * count * self.batch)

    def density_error(self, iteration: int) -> float:
        """Max relative compression of ``iteration`` over the clips (waits for the queue)."""
        return float(self.density_errors(iteration + 1)[iteration].max())

    def enqueue_density_error(self, iteration: int, out: np.ndarray) -> cl.Event:
        """Start copying each clip's max compression of ``iteration`` into ``out`` (one
        float32 per clip)."""
        offset = 4 * iteration * self.batch
        return cl.enqueue_copy(self.queue, out, self.err, src_offset=offset, is_blocking=False)

    def density_errors(self, count: int) -> np.ndarray:
        """(count, batch) max relative compressions of iterations 0 .. count - 1 per clip
        (0 where skipped; waits)."""
        out = np.empty((count, self.batch), dtype=np.float32)
        cl.enqueue_copy(self.queue, out, self.err)
        return out

    def keep_state(self) -> None:
        """Copy the state a frame starts from (positions, velocities, pressures, ids)."""
        for name in KEPT:
            cl.enqueue_copy(self.queue, self.kept[name], getattr(self, name))

    def restore_state(self) -> None:
        """Put back what :meth:`keep_state` copied."""
        for name in KEPT:
            cl.enqueue_copy(self.queue, getattr(self, name), self.kept[name])

    def advance(self) -> None:
        """x(t + dt) = x*, v(t + dt) = v*: swap the predicted buffers in."""
        self.pos, self.pos_pred = self.pos_pred, self.pos
        self.vel, self.vel_pred = self.vel_pred, self.vel

    def overflowed(self) -> int:
        """Largest neighbour count that exceeded a list capacity so far (0: none)."""
        out = np.empty(1, dtype=_I32)
        cl.enqueue_copy(self.queue, out, self.overflow)
        return int(out[0])
