"""Where the liquid computes and renders: the OpenCL device and the Mitsuba variant.

The shells read these from :class:`~app.config.Settings` and hand them down to the
liquid (``make_dynamics``, ``srg calibrate``, ``srg validate``, the benchmarks), so that
nothing below the shells looks the settings up itself. Frozen and hashable: a worker
process caches one dynamics per preset, fluid and devices. This module imports neither
PyOpenCL nor Mitsuba, so that code which only names the devices stays light.
"""

from __future__ import annotations

from dataclasses import dataclass

from app.config import Settings


@dataclass(frozen=True)
class LiquidDevices:
    """The device choices of one process; the defaults are the embedded configuration's.

    Attributes
    ----------
    opencl_device : str
        Substring of the OpenCL device's name; ``''`` prefers PoCL's CPU device
        (``app.kernels.context.select_device``).
    render_variant : str
        Mitsuba variant, or ``auto`` (``app.render.mitsuba_scene.pick_variant``).
    llvm_path : str
        libLLVM for Mitsuba's LLVM variant; ``''``: look in the system's library folders.
    simulate_batch : int
        The most clips one launch sequence runs; an expansion's clips (one per control)
        always fit. A GPU runs a dozen in about the time of a few (docs/sph.md, "Clips
        in batches").
    """

    opencl_device: str = ""
    render_variant: str = "auto"
    llvm_path: str = ""
    simulate_batch: int = 1

    @classmethod
    def from_settings(cls, settings: Settings) -> LiquidDevices:
        return cls(
            settings.runtime.opencl_device,
            settings.render.render_variant,
            settings.render.llvm_path,
            settings.runtime.simulate_batch,
        )
