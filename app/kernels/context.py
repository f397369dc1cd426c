"""OpenCL device, context, queue and program cache.

The device is the first whose name contains the caller's ``device`` string (the shells
pass ``Settings.opencl_device``; ``''`` prefers a PoCL CPU device that can compile for
this CPU: docs/runtime.md, "The OpenCL device"). Contexts are created
lazily and keyed by process id and device, so a Celery worker forked from a parent that
already used OpenCL builds its own context instead of inheriting one that does not
survive ``fork``. Programs are built once per context and source/options.
"""

from __future__ import annotations

import logging
import os
from dataclasses import dataclass, field
from importlib import resources

import pyopencl as cl

from app.core.errors import Unavailable

log = logging.getLogger(__name__)

#: explicit build options: IEEE float32 semantics (no fast-math), for reproducible output
BUILD_OPTIONS = ("-cl-std=CL1.2",)


@dataclass
class ClRuntime:
    """One process's OpenCL context, in-order queue and built programs."""

    device: cl.Device
    context: cl.Context
    queue: cl.CommandQueue
    programs: dict[tuple[str, tuple[str, ...]], cl.Program] = field(default_factory=dict)

    def program(self, source_name: str, options: tuple[str, ...] = ()) -> cl.Program:
        """The program of ``app/kernels/<source_name>``, built on first use.

        ``options`` are added to :data:`BUILD_OPTIONS` (e.g. a ``-D`` to test a variant).
        """
        key = (source_name, options)
        if key not in self.programs:
            source = resources.files("app.kernels").joinpath(source_name).read_text()
            self.programs[key] = cl.Program(self.context, source).build(
                options=[*BUILD_OPTIONS, *options]
            )
        return self.programs[key]


_RUNTIMES: dict[tuple[int, str], ClRuntime] = {}


#: the smallest program that exercises a device's compiler (the probe of :func:`compiles`)
PROBE_SOURCE = "__kernel void probe(__global float *x) { x[get_global_id(0)] += 1.0f; }"

_COMPILES: dict[int, bool] = {}


def compiles(device: cl.Device) -> bool:
    """Whether ``device`` builds :data:`PROBE_SOURCE`; asked once per process and device.

    A PoCL whose LLVM predates the host CPU lists the device and then fails every build
    ("unknown target CPU 'generic'"); the probe lets selection pass over it.
    """
    key = device.int_ptr
    if key not in _COMPILES:
        try:
            cl.Program(cl.Context([device]), PROBE_SOURCE).build(options=list(BUILD_OPTIONS))
            _COMPILES[key] = True
        except cl.Error as error:
            log.warning("OpenCL device %s cannot compile: %s", device.name, error)
            _COMPILES[key] = False
    return _COMPILES[key]


def select_device(name_contains: str) -> cl.Device:
    """First device whose name contains ``name_contains``; '' prefers a PoCL CPU device.

    With ``''`` the first PoCL CPU device that :func:`compiles` wins, then any device that
    does; with none, an :class:`Unavailable` that says what to install.
    """
    devices = [(p, d) for p in cl.get_platforms() for d in p.get_devices()]
    if not devices:
        raise Unavailable("no OpenCL device found")
    if name_contains:
        for _, d in devices:
            if name_contains.lower() in d.name.lower():
                return d
        names = [d.name for _, d in devices]
        raise Unavailable(f"no OpenCL device matches {name_contains!r}; have {names}")
    pocl_cpus = [
        d
        for p, d in devices
        if "portable computing language" in p.name.lower() and d.type & cl.device_type.CPU
    ]
    for d in [*pocl_cpus, *(d for _, d in devices if d not in pocl_cpus)]:
        if compiles(d):
            return d
    names = [f"{d.name} ({p.version})" for p, d in devices]
    raise Unavailable(
        f"no OpenCL device can compile for this CPU (have {names}); "
        "on Debian: apt-get install pocl-opencl-icd"
    )


def describe_device(name_contains: str) -> str:
    """The device :func:`select_device` picks, with its platform's version, or why none:
    what a result's provenance names (``app.reports.provenance``)."""
    try:
        device = select_device(name_contains)
    except (Unavailable, cl.Error) as error:
        return f"none ({error})"
    return f"{device.name} ({device.platform.version.strip()})"


def runtime(device_name: str = "") -> ClRuntime:
    """This process's runtime on ``device_name``, created on first call (and after a fork).

    ``device_name`` is as in :func:`select_device`.
    """
    key = (os.getpid(), device_name)
    if key not in _RUNTIMES:
        device = select_device(device_name)
        log.info(
            "OpenCL device %s on %s (%s)",
            device.name,
            device.platform.name,
            device.platform.version,
        )
        context = cl.Context([device])
        _RUNTIMES[key] = ClRuntime(device, context, cl.CommandQueue(context))
    return _RUNTIMES[key]
