"""The seam every crowd model fits, in the manner of scikit-learn's estimators
(docs/player-models.md, "The crowd models").

A crowd model learns P(c|v), the control a player takes at each vertex, from played
sessions. :meth:`CrowdModel.fit` chooses what the sessions say (a kernel radius, a prior
weight, a share of heuristic players) and returns a :class:`FittedCrowdModel`, which
answers P(c|v) for the graph as it is when asked: growth adds vertices after a fit, and
the fitted choice holds for them too until new sessions are learnt. What sets one model
apart for its callers is a class attribute, read where it matters, never a list of kinds
kept elsewhere. :mod:`app.core.players.crowd_models.registry` maps a kind to its class.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, ClassVar, Protocol

import numpy as np

from app.core.graph.publication import Publication
from app.core.players.crowd_play import PlayCounts
from app.core.players.kinds import PlayerModelKind


@dataclass(frozen=True)
class CrowdGraph:
    """What a crowd model answers for: every vertex as eq. 2's kernel sees it (its shape
    descriptor and the control that produced it), the heuristic model P_h a learned model
    falls back on or shrinks toward, and eq. 2's kernel radius and prior weight eps."""

    descriptors: np.ndarray  # (V, D)
    vertex_control: np.ndarray  # (V,)
    heuristic: np.ndarray  # (V, N)
    radius: float
    eps: float

    @property
    def n_vertices(self) -> int:
        return int(self.heuristic.shape[0])

    @property
    def n_controls(self) -> int:
        return int(self.heuristic.shape[1])


@dataclass(frozen=True)
class CrowdPlay:
    """What a crowd model learns from: the sessions summed per publication they were
    played on, oldest first (the publication None where the caller did not load it, as
    for a model that does not read publications), and STATERANK's restart rate 1/L."""

    played: Sequence[tuple[Publication | None, PlayCounts]]
    restart: float

    @property
    def all(self) -> PlayCounts:
        """Every session, summed."""
        return PlayCounts.merged([play for _, play in self.played])

    def counts(self, graph: CrowdGraph) -> np.ndarray:
        """The (V, N) control counts of every session on ``graph``'s vertices."""
        return self.all.control_counts(graph.n_vertices, graph.n_controls)

    def published(self) -> list[tuple[Publication, PlayCounts]]:
        """The sessions with their publications, oldest first; ValueError when some were
        learnt without theirs."""
        if any(publication is None for publication, _ in self.played):
            raise ValueError("this crowd model needs every session's publication")
        return [(publication, play) for publication, play in self.played if publication is not None]


class FittedCrowdModel(Protocol):
    """A crowd model fitted to sessions: P(c|v) on a graph, and what the fit chose."""

    @property
    def unseen_share(self) -> float | None:
        """The share of heuristic players the ranking's population holds (growth mixes
        their STATERANK weights with the crowd's, app.core.growth.strategies.mixed_weights);
        None where growth ranks for the crowd alone."""
        ...

    def player_model(self, graph: CrowdGraph) -> np.ndarray:
        """P(c|v) for every vertex of ``graph``, shape (V, N), rows summing to one."""
        ...

    def figures(self) -> dict[str, Any] | None:
        """What the fit chose, with every candidate's score (each checkpoint's and
        ``srg analytics``' ``model_fit``); None for a model that chooses nothing."""
        ...


class CrowdModel(Protocol):
    """A crowd model sr-crowd can learn: its kind, what it reads, and its fit."""

    #: the name it is chosen by (``SRG_PLAYER_MODEL``, ``--player-model``)
    kind: ClassVar[PlayerModelKind]
    #: whether it learns each publication's sessions apart, with the publication they
    #: were played on (what its players saw); otherwise one sum of every session
    reads_publications: ClassVar[bool]

    def fit(self, graph: CrowdGraph, play: CrowdPlay) -> FittedCrowdModel:
        """Choose, from ``play``, what the model needs to answer on ``graph``."""
        ...
