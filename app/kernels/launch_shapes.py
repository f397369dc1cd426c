"""How many work-items a launch of the SPH kernels gets, and how they are grouped, per device.

The same kernels run on a CPU (PoCL: two threads, each launch costing microseconds) and on
a GPU (thousands of lanes); what suits one starves or drowns the other, so the shapes are
chosen here, from the device, and the kernels' results do not depend on them.
"""

from __future__ import annotations

import functools

import pyopencl as cl

#: upper bound of the work-group size (see :func:`work_group`)
WORK_GROUP = 64
#: cells per work-item of the cell scan on a GPU (see :func:`scan_block`)
GPU_SCAN_BLOCK = 64


@functools.cache
def work_group(size: int) -> tuple[int] | None:
    """Local size: the largest divisor of ``size`` up to 64 (None, PoCL's choice, if < 8).

    PoCL picks about size / 2 for two cores, and one late thread then holds up the whole
    launch; groups of 32-128 work-items let the two threads balance (measured on small:
    median substep 7.6-8.7 ms against 9.1-9.3 ms).
    """
    for d in range(min(size, WORK_GROUP), 7, -1):
        if size % d == 0:
            return (d,)
    return None


def scan_block(device: cl.Device, n_cells: int) -> int:
    """Cells each work-item of the cell scan walks: all of them on a CPU, where one walk
    costs microseconds and each launch more; :data:`GPU_SCAN_BLOCK` elsewhere, where one
    work-item walking 18k cells (`paper`) takes milliseconds of a 3 ms substep and blocks
    of cells are scanned in parallel in three launches. Both give the same integers."""
    return n_cells if device.type & cl.device_type.CPU else GPU_SCAN_BLOCK


def build_options(device: cl.Device) -> tuple[str, ...]:
    """How ``pcisph.cl`` is built for the device: a GPU's neighbour lists are built one
    candidate a work-item (``-DLANE_BUILD``), its lanes being the work-items, where a
    CPU's take eight candidates a vector; the same lists either way."""
    return () if device.type & cl.device_type.CPU else ("-DLANE_BUILD",)
