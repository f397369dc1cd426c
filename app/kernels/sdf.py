"""Zhu and Bridson SDF frames on the OpenCL device (twin: ``app.core.liquid.surface``).

The host bins each frame's particles into cells of edge R (the search radius) with a
stable sort, uploads them and launches one work-item per voxel (``sdf.cl``). Buffers are
sized once per particle count and reused over a clip's frames.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pyopencl as cl

from app.core.liquid.surface import SurfaceGrid
from app.kernels.context import runtime

#: bins of margin around the voxel grid, so particles a little outside the tank (within
#: the solver's wall margin) still sit in their own bin
_BIN_MARGIN = 2


def _vec4(xyz: Sequence[float] | np.ndarray, dtype: type[np.generic]) -> np.ndarray:
    """A by-value float4 / int4 kernel argument (16 bytes, w = 0)."""
    return np.array([*xyz, 0], dtype=dtype)


class SdfKernel:
    """SDF of particle frames on one :class:`SurfaceGrid` on the OpenCL ``device``.

    ``device`` is as in :func:`app.kernels.context.select_device`.
    """

    def __init__(self, grid: SurfaceGrid, device: str = "") -> None:
        rt = runtime(device)
        self.grid = grid
        self.context, self.queue = rt.context, rt.queue
        self.kernel = cl.Kernel(rt.program("sdf.cl"), "zhu_bridson_sdf")
        r = grid.search_radius
        extent = np.asarray(grid.shape) * grid.voxel
        self.bin_origin = np.asarray(grid.origin) - _BIN_MARGIN * r
        self.bin_dims = tuple(int(d) for d in np.ceil(extent / r).astype(int) + 2 * _BIN_MARGIN)
        self.n_voxels = int(np.prod(grid.shape))
        self.phi = np.empty(grid.shape, dtype=np.float32)
        self.phi_buf = cl.Buffer(self.context, cl.mem_flags.WRITE_ONLY, self.phi.nbytes)

    def _binned(self, positions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Particles as float4 sorted by bin, and each bin's start offset."""
        dims = np.asarray(self.bin_dims)
        b = np.floor((positions[:, :3] - self.bin_origin) / self.grid.search_radius).astype(int)
        b = np.clip(b, 0, dims - 1)
        cells = (b[:, 2] * dims[1] + b[:, 1]) * dims[0] + b[:, 0]
        order = np.argsort(cells, kind="stable")
        pos = np.zeros((len(positions), 4), dtype=np.float32)
        pos[:, :3] = positions[order, :3]
        counts = np.bincount(cells, minlength=int(np.prod(dims)))
        start = np.concatenate([[0], np.cumsum(counts)]).astype(np.int32)
        return pos, start

    def frame(self, positions: np.ndarray) -> np.ndarray:
        """(X, Y, Z) float32 SDF of one frame's (n, 3) particle positions."""
        g = self.grid
        pos, start = self._binned(np.asarray(positions, dtype=np.float64))
        mf = cl.mem_flags
        # a zero-particle frame still needs valid (non-empty) buffers
        pos_buf = cl.Buffer(
            self.context,
            mf.READ_ONLY | mf.COPY_HOST_PTR,
            hostbuf=pos if len(pos) else np.zeros(4, np.float32),
        )
        start_buf = cl.Buffer(self.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=start)
        self.kernel(
            self.queue,
            (self.n_voxels,),
            None,
            pos_buf,
            start_buf,
            _vec4(self.bin_origin, np.float32),
            _vec4(self.bin_dims, np.int32),
            _vec4(g.origin, np.float32),
            _vec4(g.shape, np.int32),
            np.float32(g.voxel),
            np.float32(g.search_radius),
            np.float32(g.particle_radius),
            self.phi_buf,
        )
        cl.enqueue_copy(self.queue, self.phi, self.phi_buf)
        return self.phi.copy()

    def frames(self, positions: np.ndarray) -> np.ndarray:
        """(k, X, Y, Z) float32 SDFs of (k, n, 3) particle frames."""
        return np.stack([self.frame(p) for p in positions])
