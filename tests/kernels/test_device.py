"""The default OpenCL device is one that compiles for this CPU (docs/runtime.md)."""

from __future__ import annotations

import pyopencl as cl
import pytest

from app.core.errors import Unavailable
from app.kernels.context import compiles, select_device


def test_the_default_device_is_the_first_pocl_cpu_device_that_compiles() -> None:
    pocl_cpus = [
        d
        for p in cl.get_platforms()
        if "portable computing language" in p.name.lower()
        for d in p.get_devices()
        if d.type & cl.device_type.CPU
    ]
    chosen = select_device("")
    assert compiles(chosen)
    assert chosen == next(d for d in pocl_cpus if compiles(d))


def test_a_device_name_that_matches_nothing_is_unavailable() -> None:
    with pytest.raises(Unavailable, match="no OpenCL device matches 'no such device'"):
        select_device("no such device")
