"""A study's pre-registered plan file, bound to the experiment that runs under it: its
digest is stored with the plan, and a resume refuses the file once it changed
(docs/experiment.md, "Pre-registration")."""

from __future__ import annotations

import hashlib
from pathlib import Path

from app.core.errors import InvalidInput
from app.services.experiment.plan import ExperimentPlan


def preregistration_of(path: Path) -> tuple[str, str]:
    """``(path, sha256)`` of a pre-registered plan file (what a resume compares)."""
    try:
        data = path.read_bytes()
    except OSError as error:
        raise InvalidInput(f"--preregistration {path}: {error.strerror}") from None
    return str(path), hashlib.sha256(data).hexdigest()


def check_preregistration(plan: ExperimentPlan) -> None:
    """Refuse to resume under a pre-registered plan that is missing or was edited: a
    plan is never changed once its first run started; a change of course is written
    beside it as a deviation (docs/experiment.md, "Pre-registration")."""
    if plan.preregistration is None:
        return
    path, digest = plan.preregistration
    if not Path(path).is_file():
        raise InvalidInput(f"the pre-registered plan {path} is missing: resume where it is")
    if preregistration_of(Path(path))[1] != digest:
        raise InvalidInput(
            f"the pre-registered plan {path} changed since the experiment started: restore it "
            "and write the change as a deviation beside it"
        )
