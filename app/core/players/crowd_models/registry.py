"""Which class each crowd model kind is: the one place a kind meets its code.

Refiner, the services and the tests ask here; what sets a model apart is said by its
class (:mod:`app.core.players.crowd_models.estimator`), so adding a model is adding its module.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping

from app.core.players.crowd_models.candidates import candidate_models
from app.core.players.crowd_models.eq2 import Eq2
from app.core.players.crowd_models.estimator import CrowdModel
from app.core.players.crowd_models.mixed import Mixed
from app.core.players.crowd_models.mixed_error import MixedError
from app.core.players.crowd_models.shrunk import Shrunk
from app.core.players.kinds import PlayerModelKind

#: the models the product offers: the paper's eq. 2, and those a selection kept
#: (docs/player-models.md): ``mixed-error``, the default, and what it builds on
PRODUCT_MODELS: tuple[type[CrowdModel], ...] = (Eq2, Shrunk, Mixed, MixedError)


def by_kind(models: Iterable[type[CrowdModel]]) -> dict[PlayerModelKind, type[CrowdModel]]:
    """``models`` keyed by their kind; ValueError when two claim one kind."""
    found: dict[PlayerModelKind, type[CrowdModel]] = {}
    for model in models:
        if model.kind in found:
            claimed = found[model.kind].__name__
            raise ValueError(f"{claimed} and {model.__name__} are both {model.kind}")
        found[model.kind] = model
    return found


#: every registered crowd model, the candidates' too
CROWD_MODELS: Mapping[PlayerModelKind, type[CrowdModel]] = by_kind(
    [*PRODUCT_MODELS, *candidate_models()]
)


def crowd_model(kind: PlayerModelKind) -> CrowdModel:
    """The crowd model of ``kind``, ready to fit."""
    return CROWD_MODELS[kind]()
