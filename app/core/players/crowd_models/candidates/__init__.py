"""Crowd models on trial: each a selection's candidate, one module, deleted when it loses.

A candidate is one module here defining its class, an estimator of
:class:`~app.core.players.crowd_models.estimator.CrowdModel` whose ``kind`` is the candidate's
name in :class:`~app.core.players.kinds.PlayerModelKind`, and naming it ``CANDIDATE``.
The registry takes every module of this package in, so nothing else lists it; the import
contract that keeps learned models from the bots' policies covers this package, and the
shared checks of tests/unit/test_crowd_models.py run over it like over every product
model. A candidate that wins its selection moves up beside the product's models; one that
loses leaves this package and the enum, its report naming the commit that reproduces it
(docs/player-models.md).
"""

from __future__ import annotations

import importlib
import pkgutil
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from app.core.players.crowd_models.estimator import CrowdModel


def candidate_models() -> list[type[CrowdModel]]:
    """The ``CANDIDATE`` class of every module of this package, by module name."""
    return [
        importlib.import_module(f"{__name__}.{module.name}").CANDIDATE
        for module in sorted(pkgutil.iter_modules(__path__), key=lambda m: m.name)
    ]
