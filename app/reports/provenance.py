"""Where a result came from: when, which srg, which host, which command.

A figure is only worth quoting with what produced it: a ratio measured before a fix
reads the same as one measured after, and a timing on two loaded cores the same as one
on an idle machine. So every result srg writes (``srg experiment`` and ``srg demo``'s
``result.json`` and ``report.md``, ``srg validate --result``, the JSON of ``srg bench``)
carries one :class:`Provenance`, made here and nowhere else (studies/README.md).
"""

from __future__ import annotations

import os
import platform
import shlex
import subprocess
import sys
from collections.abc import Mapping
from dataclasses import asdict, dataclass, field, is_dataclass
from datetime import UTC, datetime
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path
from typing import Any

from app.config import GrowthSettings, Settings

#: what a field says when this process cannot find it out (no checkout, no git)
UNKNOWN = "unknown"

#: the checkout that holds ``app/`` when srg runs from one (an installed wheel has none)
_SOURCE_ROOT = Path(__file__).resolve().parents[2]


@dataclass(frozen=True)
class Provenance:
    """The facts a reader needs to reproduce a result or to compare it with another.

    Attributes
    ----------
    date : str
        When the result was written, ISO 8601 in UTC.
    srg_version : str
        The installed distribution's version (``srg --version``).
    commit : str
        The git commit of the checkout srg ran from, ``-dirty`` appended when tracked
        files differed from it; ``unknown`` outside a checkout.
    cpu : str
        The host's CPU model.
    cpu_count : int
        Its logical cores (timings depend on them).
    opencl_device : str
        The OpenCL device the settings select, with its platform's version, or why none.
    command : str
        The command line of the process that wrote the result.
    growth : dict
        The growth settings that were not at their defaults, by their variables
        (``SRG_ALPHA``...): they change every graph grown, and a command line does not
        show them. Empty in results written before it was recorded.
    """

    date: str
    srg_version: str
    commit: str
    cpu: str
    cpu_count: int
    opencl_device: str
    command: str
    growth: dict[str, str] = field(default_factory=dict)

    def markdown(self) -> str:
        """One paragraph for the top of a report."""
        return (
            f"Written {self.date} by srg {self.srg_version} (commit `{self.commit}`) on "
            f"{self.cpu} ({self.cpu_count} cores), OpenCL device {self.opencl_device}: "
            f"`{self.command}`{self._growth_markdown()}."
        )

    def _growth_markdown(self) -> str:
        changed = ", ".join(f"`{name}={value}`" for name, value in sorted(self.growth.items()))
        return f", growth settings off their defaults: {changed}" if changed else ""


def provenance(settings: Settings) -> Provenance:
    """This process's provenance, now; the OpenCL device is the one ``settings`` select."""
    return Provenance(
        date=datetime.now(UTC).isoformat(timespec="seconds"),
        srg_version=_srg_version(),
        commit=source_commit(),
        cpu=cpu_model(),
        cpu_count=os.cpu_count() or 1,
        opencl_device=opencl_device(settings.runtime.opencl_device),
        command=shlex.join([Path(sys.argv[0]).name, *sys.argv[1:]]),
        growth=changed_growth_settings(settings),
    )


def changed_growth_settings(settings: Settings) -> dict[str, str]:
    """The growth settings ``settings`` holds off their defaults, by their variables."""
    default = GrowthSettings.model_construct()
    return {
        f"SRG_{name.upper()}": str(value)
        for name, value in settings.growth
        if value != getattr(default, name)
    }


def with_provenance(result: Any, settings: Settings) -> dict[str, Any]:
    """``result`` (a mapping or a dataclass) as a dict led by its ``provenance``."""
    data: Mapping[str, Any] = (
        asdict(result) if is_dataclass(result) and not isinstance(result, type) else result
    )
    return {"provenance": asdict(provenance(settings)), **data}


def _srg_version() -> str:
    try:
        return version("srg")
    except PackageNotFoundError:  # the package imported from a checkout never installed
        return UNKNOWN


def source_commit() -> str:
    """The commit of the checkout srg runs from (``-dirty`` when tracked files differ).

    Only when ``app/`` itself is that checkout's: an installed wheel inside some other
    repository (a virtual environment in a project) must not report that project's commit.
    """
    try:
        top = _git("rev-parse", "--show-toplevel")
        if Path(top).resolve() != _SOURCE_ROOT:
            return UNKNOWN
        commit = _git("rev-parse", "HEAD")
        modified = subprocess.run(
            ["git", "-C", str(_SOURCE_ROOT), "diff", "--quiet", "HEAD", "--"],
            capture_output=True,
            timeout=30,
        ).returncode
    except (OSError, subprocess.SubprocessError):
        return UNKNOWN
    return f"{commit}-dirty" if modified else commit


def _git(*args: str) -> str:
    """The output of ``git args`` in the source root; raises when git fails."""
    done = subprocess.run(
        ["git", "-C", str(_SOURCE_ROOT), *args],
        capture_output=True,
        text=True,
        timeout=30,
        check=True,
    )
    return done.stdout.strip()


def cpu_model() -> str:
    """The CPU's marketing name where Linux tells it, else what Python's platform knows."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            key, _, value = line.partition(":")
            if key.strip() == "model name" and value.strip():
                return value.strip()
    except OSError:
        pass
    return platform.processor() or platform.machine() or UNKNOWN


def opencl_device(name_contains: str) -> str:
    """The device the liquid would run on here, or why there is none."""
    try:
        from app.kernels.context import describe_device
    except ImportError:  # the 'sim' extra is not installed
        return "none (pyopencl is not installed)"
    return describe_device(name_contains)
