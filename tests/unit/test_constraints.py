"""requirements/constraints.txt against pyproject.toml and the environment the tests run in.

infra/venv.sh and the Dockerfile install with the constraints file (infra/lock.sh writes
it): a requirement added to pyproject.toml without a pin would install whatever is newest
that day, and an environment off its pins would pass the tests with versions no other
machine gets.
"""

from __future__ import annotations

import re
import tomllib
from importlib import metadata
from pathlib import Path

import pytest
from packaging.requirements import Requirement
from packaging.utils import NormalizedName, canonicalize_name
from packaging.version import Version

ROOT = Path(__file__).resolve().parents[2]
PYPROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
PIN = re.compile(r"^([A-Za-z0-9][A-Za-z0-9._-]*)==(\S+)$")


def pins() -> dict[NormalizedName, Version]:
    lines = (ROOT / "requirements/constraints.txt").read_text(encoding="utf-8").splitlines()
    matches = [PIN.match(line) for line in lines if line and line[0] not in "# "]
    assert all(matches), "every line of requirements/constraints.txt is NAME==VERSION"
    return {canonicalize_name(m[1]): Version(m[2]) for m in matches if m}


def project_requirements() -> list[Requirement]:
    """Every requirement of the project and its extras, the extras naming srg itself left out."""
    project = PYPROJECT["project"]
    extras = project["optional-dependencies"].values()
    texts = [*project["dependencies"], *(text for extra in extras for text in extra)]
    return [r for r in map(Requirement, texts) if canonicalize_name(r.name) != project["name"]]


@pytest.mark.parametrize("requirement", project_requirements(), ids=str)
def test_every_requirement_is_pinned_within_its_range(requirement: Requirement) -> None:
    pinned = pins().get(canonicalize_name(requirement.name))
    assert pinned is not None, f"{requirement.name} has no pin: run infra/lock.sh"
    assert requirement.specifier.contains(pinned, prereleases=True), (
        f"{requirement.name}=={pinned} is outside {requirement.specifier}: run infra/lock.sh"
    )


def test_the_installers_are_pinned_and_the_build_backend_too() -> None:
    pinned = pins()
    assert "pip" in pinned
    (backend,) = map(Requirement, PYPROJECT["build-system"]["requires"])
    assert backend.specifier.contains(pinned[canonicalize_name(backend.name)])


def test_the_environment_is_the_pinned_one() -> None:
    """Every pinned package that is installed here is at its pin (infra/venv.sh installs
    them so; a pin for another Python, such as async-timeout below 3.11.3, is not installed)."""
    installed = {
        canonicalize_name(d.metadata["Name"]): Version(d.version) for d in metadata.distributions()
    }
    off = {
        name: f"{installed[name]} installed, {pin} pinned"
        for name, pin in pins().items()
        if name in installed and installed[name] != pin
    }
    assert not off, f"the environment is off its pins (re-run infra/venv.sh): {off}"
