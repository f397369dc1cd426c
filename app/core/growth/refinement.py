"""The self-refining loop on one graph: rank, pick, relink lazily, expand; learn; publish.

:class:`Refiner` is the one growth driver. The eager CLI, the experiment and the Celery
``grow_epoch`` all call it; only where clips are simulated differs (in-process here,
fanned out to workers there, through :func:`app.core.growth.expansion.integrate_expansion`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from app.core.graph.clipbank import ClipBank
from app.core.graph.dynamics import Dynamics
from app.core.graph.publication import Publication, freeze
from app.core.graph.state_graph import StateGraph
from app.core.graph.staterank import STATERANK_MAX_ITER, edge_probabilities, staterank
from app.core.growth.expansion import (
    EpochOutcome,
    Expansion,
    GrowthBudget,
    expand_blend_edge,
    relink_all,
    relink_blend_edge,
    select_for_expansion,
)
from app.core.growth.kinds import Strategy
from app.core.growth.strategies import EdgeWeights, edge_weights, mixed_weights
from app.core.players.crowd_models.estimator import CrowdGraph, CrowdPlay, FittedCrowdModel
from app.core.players.crowd_models.registry import crowd_model
from app.core.players.crowd_play import PlayCounts
from app.core.players.kinds import PlayerModelKind
from app.core.players.player_models import heuristic_player_model, session_length_of_median

Trace = np.ndarray


@dataclass(frozen=True)
class RefinerConfig:
    alpha: float = 0.8
    crowd_radius: float = 0.15
    crowd_eps: float = 1e-3
    default_session_steps: float = 90.0
    #: ceiling of the session length L (floor of the restart rate 1/L): bounds STATERANK's
    #: iterations, about L ln(1/tol) from a cold start, whatever traces were uploaded
    max_session_steps: float = 900.0
    staterank_max_iter: int = STATERANK_MAX_ITER
    prefilter_k: int = 100
    batch_size: int = 4
    #: the crowd model sr-crowd learns (app.core.players.crowd_models.registry)
    player_model: PlayerModelKind = PlayerModelKind.EQ2


@dataclass
class Refiner:
    graph: StateGraph
    bank: ClipBank
    dynamics: Dynamics
    strategy: Strategy
    config: RefinerConfig = RefinerConfig()
    #: the sessions learnt from, summed per publication they were played on
    played: list[tuple[Publication | None, PlayCounts]] = field(default_factory=list)
    _pi: np.ndarray | None = None
    #: the crowd model fitted to ``played`` (None until asked, and again once more is learnt)
    _fitted: FittedCrowdModel | None = None
    _heuristic_pi: np.ndarray | None = None

    @property
    def play(self) -> PlayCounts:
        """Every session learnt from, summed."""
        return PlayCounts.merged([play for _, play in self.played])

    @property
    def _learnt(self) -> bool:
        """Whether the player model is learnt from traces (sr-crowd once it has some)."""
        return self.strategy.learns_from_traces and any(p.sessions for _, p in self.played)

    # ---- player model and ranking -------------------------------------------------
    def heuristic_model(self) -> np.ndarray:
        return heuristic_player_model(
            np.asarray(self.graph.vertex_control), self.graph.n_controls, self.config.alpha
        )

    def player_model(self, on: Publication | None = None) -> np.ndarray:
        """P(c|v) for every vertex: the crowd model once sr-crowd has traces, else P_h.

        ``on`` is a publication of this graph to answer for (its vertices are the graph's
        first ones); default: the graph now.
        """
        vertices = self.graph.n_vertices if on is None else on.n_vertices
        if not self._learnt:
            return self.heuristic_model()[:vertices]
        return self.crowd_model().player_model(self.crowd_graph())[:vertices]

    def crowd_graph(self) -> CrowdGraph:
        """The graph now, as a crowd model answers for it."""
        return CrowdGraph(
            self.graph.vertex_descriptors(),
            np.asarray(self.graph.vertex_control),
            self.heuristic_model(),
            self.config.crowd_radius,
            self.config.crowd_eps,
        )

    def crowd_model(self) -> FittedCrowdModel:
        """The configured crowd model fitted to the sessions learnt so far (fitted once,
        on the graph as it is then, until more are learnt)."""
        if self._fitted is None:
            self._fitted = crowd_model(self.config.player_model).fit(
                self.crowd_graph(), CrowdPlay(tuple(self.played), self.restart)
            )
        return self._fitted

    @property
    def restart(self) -> float:
        """rho = 1/L with L the robust session length of the traces (or the default)."""
        steps = session_length_of_median(
            self.play.median_length(),
            default=self.config.default_session_steps,
            ceiling=self.config.max_session_steps,
        )
        return 1.0 / steps

    def weights(self, warm_start: np.ndarray | None = None) -> EdgeWeights:
        """The strategy's edge weights, STATERANK started from ``warm_start`` (a stored
        pi), else from this refiner's last; for a crowd model that ranks for heuristic
        players too, once it has traces, the crowd's and the heuristic model's mixed
        (:func:`mixed_weights`, ``unseen_share``)."""
        restart = self.restart
        result = edge_weights(
            self.strategy,
            self.graph,
            self.player_model(),
            restart=restart,
            warm_start=self._pi if warm_start is None else warm_start,
            max_iter=self.config.staterank_max_iter,
        )
        if result.rank is not None:
            self._pi = result.rank.pi
        share = self.crowd_model().unseen_share if self._learnt else None
        if share is None:
            return result
        heuristic = edge_weights(
            self.strategy,
            self.graph,
            self.heuristic_model(),
            restart=restart,
            warm_start=self._heuristic_pi,
            max_iter=self.config.staterank_max_iter,
        )
        if heuristic.rank is not None:
            self._heuristic_pi = heuristic.rank.pi
        return mixed_weights(result, heuristic, share)

    def predicted_edge_probabilities(self, model: np.ndarray | None = None) -> np.ndarray:
        """P(e) = pi(v) P(c|v) under ``model`` (default: this refiner's player model)."""
        model = self.player_model() if model is None else model
        src, _, dst = self.graph.edge_arrays()
        prob = model.reshape(-1)
        rank = staterank(src, dst, prob, self.graph.n_vertices, self.graph.start, self.restart)
        return edge_probabilities(rank.pi, src, prob)

    # ---- growth -----------------------------------------------------------------------
    def relink(self, edge: int) -> bool:
        return relink_blend_edge(
            self.graph, self.bank, self.dynamics, edge, prefilter_k=self.config.prefilter_k
        )

    def plan_epoch(
        self, count: int | None = None, ranked: EdgeWeights | None = None
    ) -> EpochOutcome:
        """Rank (or take the weights ``ranked`` already), then pop the top BLEND edges
        (relinking lazily) to expand next: the one place growth's settings pick them."""
        ranked = self.weights() if ranked is None else ranked
        return select_for_expansion(
            self.graph,
            ranked.weights,
            count or self.config.batch_size,
            self.relink,
        )

    def grow(
        self,
        *,
        frames: int | None = None,
        expansions: int | None = None,
        on_expansion: Callable[[Expansion], None] | None = None,
    ) -> list[EpochOutcome]:
        """Grow by a budget of simulated frames or of expansions (whichever is given)."""
        budget = GrowthBudget.of(self.graph.size_frames, frames=frames, expansions=expansions)
        per_expansion = self.graph.n_controls * self.graph.frames_per_clip
        done = 0
        epochs = []
        while (left := budget.left(self.graph.size_frames, done, per_expansion)) > 0:
            epoch = self.plan_epoch(min(self.config.batch_size, left))
            if not epoch.expanded:
                break
            for edge in epoch.expanded:
                expansion = expand_blend_edge(
                    self.graph,
                    self.bank,
                    self.dynamics,
                    edge,
                    prefilter_k=self.config.prefilter_k,
                )
                done += 1
                if on_expansion is not None:
                    on_expansion(expansion)
            epochs.append(epoch)
        return epochs

    # ---- play ---------------------------------------------------------------------------
    def publish(self) -> tuple[Publication, list[int]]:
        """Pre-publish relinking, then a frozen copy; returns the relinked edges too."""
        relinked = relink_all(
            self.graph, self.bank, self.dynamics, prefilter_k=self.config.prefilter_k
        )
        return freeze(self.graph), relinked

    def learn(self, traces: Sequence[Trace], publication: Publication | None = None) -> None:
        """Take sessions played on ``publication`` (a version of this graph) into account,
        numbered after those learnt before (their folds follow, :mod:`app.core.players.crowd_play`).

        A crowd model that ``reads_publications`` reads the publication each session was
        played on; the others read none, so their callers need not load them.
        """
        self.learn_counts(PlayCounts.of_traces(traces, first=self.play.sessions), publication)

    def learn_counts(self, play: PlayCounts, publication: Publication | None = None) -> None:
        """:meth:`learn` of sessions already summed, their buckets those of their ordinals
        among every session learnt (the store keeps them so)."""
        self.played.append((publication, play))
        self._fitted = None
