"""Kernel launches that set only the arguments that changed, optionally timestamped.

A substep queues twenty-odd launches of kernels with 20-30 arguments each; setting every
argument on every launch cost more Python time than some of the kernels take, so
:class:`Launcher` remembers what each kernel was last given.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pyopencl as cl
import pyopencl.cltypes as cltypes

from app.kernels.context import ClRuntime
from app.kernels.launch_shapes import work_group


def float4(v: np.ndarray | tuple[float, ...]) -> np.ndarray:
    """The first three values as an OpenCL float4 argument (w = 0)."""
    x = [float(a) for a in v][:3]
    return np.array((x[0], x[1], x[2], 0.0), dtype=cltypes.float4)


class Launcher:
    """The kernels of one built program on a queue of ``runtime``'s context.

    With ``profile``, a queue of its own that timestamps commands, and every kernel
    launch kept with its name in :attr:`launches` (``app.bench.sph_profile`` reads them).
    """

    def __init__(self, runtime: ClRuntime, program: cl.Program, profile: bool = False) -> None:
        self.launches: list[tuple[str, cl.Event]] | None = None
        self.queue = runtime.queue
        if profile:
            props = cl.command_queue_properties.PROFILING_ENABLE
            self.queue = cl.CommandQueue(runtime.context, properties=props)
            self.launches = []
        self.program = program
        self.kernels = {k.function_name: k for k in program.all_kernels()}
        self._bound: dict[str, list[Any]] = {}
        self._scalars: dict[tuple[Any, ...], Any] = {}

    def _run(self, name: str, size: int | tuple[int, int], *args: Any) -> None:
        """Enqueue kernel ``name`` on ``size`` work-items, setting only changed arguments.

        A pair (n, m) launches n x m work-items in groups along the first index only.

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
        shape = size if isinstance(size, tuple) else (size,)
        group = work_group(shape[0])
        local = None if group is None else group + (1,) * (len(shape) - 1)
        event = cl.enqueue_nd_range_kernel(self.queue, kernel, shape, local)
        if self.launches is not None:
            self.launches.append((name, event))

    def _i32(self, v: int) -> np.int32:
        """The same argument object for the same value (see :meth:`_run`)."""
        x = self._scalars.get(("i", v))
        if x is None:
            x = self._scalars[("i", v)] = np.int32(v)
        return x

    def _f32(self, v: float) -> np.float32:
        x = self._scalars.get(("f", v))
        if x is None:
            x = self._scalars[("f", v)] = np.float32(v)
        return x
