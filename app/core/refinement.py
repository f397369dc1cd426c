"""The self-refining loop on one graph: rank, pick, relink lazily, expand; learn; publish.

:class:`Refiner` is the one growth driver. The eager CLI, the experiment and the Celery
``grow_epoch`` all call it; only where clips are simulated differs (in-process here,
fanned out to workers there, through :func:`app.core.growth.integrate_expansion`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from app.core.choice_model import ChoiceGraph, ChoiceModel, Kernel, PlayedGraph, fit_choice_model
from app.core.clipbank import ClipBank
from app.core.crowd_play import PlayCounts
from app.core.dynamics import Dynamics
from app.core.error_share import ERROR_SHARE_KINDS, ShareFit, fit_error_share
from app.core.fresh_evidence import FreshFit, fit_fresh_evidence, weighted_counts
from app.core.graph import StateGraph
from app.core.growth import (
    EpochOutcome,
    Expansion,
    GrowthBudget,
    expand_blend_edge,
    relink_all,
    relink_blend_edge,
    select_for_expansion,
)
from app.core.neighbour_model import NeighbourFit, choose_neighbours, neighbour_player_model
from app.core.player_models import (
    PlayerModelKind,
    crowd_player_model,
    heuristic_player_model,
    session_length_of_median,
)
from app.core.publication import Publication, freeze
from app.core.rank_error import RankError
from app.core.shrunk_model import (
    MIXED_KINDS,
    SHRUNK_KINDS,
    ShrunkFit,
    fit_shrunk_model,
    shrunk_player_model,
)
from app.core.staterank import STATERANK_MAX_ITER, edge_probabilities, staterank
from app.core.strategies import (
    UNSEEN_SHARE,
    EdgeWeights,
    Strategy,
    edge_weights,
    mixed_weights,
    split_weights,
)

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
    #: the crowd model sr-crowd learns: the paper's eq. 2, or eq. 2 under a logit prior
    player_model: PlayerModelKind = PlayerModelKind.EQ2
    #: what a blend's error costs in the ranking (app.core.rank_error)
    rank_error: RankError = RankError.MEAN
    #: the visibility threshold in force, where that cost may turn (``squared-large``)
    high_error_threshold: float = 0.0


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
    _choice: ChoiceModel | None = None
    _neighbours: NeighbourFit | None = None
    _shrunk: ShrunkFit | None = None
    _fresh: FreshFit | None = None
    _share: ShareFit | None = None
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
        first ones; its edges are the ones its players saw); default: the graph now.
        """
        vertices = self.graph.n_vertices if on is None else on.n_vertices
        heuristic = self.heuristic_model()[:vertices]
        if not self._learnt:
            return heuristic
        counts = self.learnt_counts()
        if self.config.player_model is PlayerModelKind.KNN:
            return neighbour_player_model(
                self.graph.vertex_descriptors(),
                np.asarray(self.graph.vertex_control),
                counts,
                self.neighbour_fit().neighbours,
                self.config.crowd_eps,
                fallback=self.heuristic_model(),
            )[:vertices]
        if self.config.player_model in SHRUNK_KINDS:
            return self.shrunk_model(counts)[:vertices]
        if self.config.player_model is PlayerModelKind.LOGIT:
            graph = ChoiceGraph.of(
                freeze(self.graph) if on is None else on,
                np.asarray(self.graph.vertex_control),
                self.graph.vertex_parents(),
            )
            evidence = self.kernel().counts(counts)[:vertices]
            return self.choice_model().probabilities(graph, evidence)
        return crowd_player_model(
            self.kernel().descriptors,
            np.asarray(self.graph.vertex_control),
            counts,
            self.config.crowd_radius,
            self.config.crowd_eps,
            fallback=self.heuristic_model(),
        )[:vertices]

    def kernel(self) -> Kernel:
        """Eq. 2's kernel over this graph's vertices."""
        return Kernel(
            self.graph.vertex_descriptors(),
            np.asarray(self.graph.vertex_control),
            self.config.crowd_radius,
        )

    def neighbour_fit(self) -> NeighbourFit:
        """The neighbour count cross-validated on the sessions learnt so far (chosen once)."""
        if self._neighbours is None:
            self._neighbours = choose_neighbours(
                self.graph.vertex_descriptors(),
                np.asarray(self.graph.vertex_control),
                self.play,
                self.graph.n_controls,
                self.config.crowd_eps,
                reference_radius=self.config.crowd_radius,
            )
        return self._neighbours

    def shrunk_fit(self) -> ShrunkFit:
        """The radius and prior weight chosen on the sessions learnt so far: by 5-fold
        cross-validation, or for ``mixed-forward`` with two publications' sessions or more
        by how the earlier ones predict the latest's (learnt one publication at a time)."""
        if self._shrunk is None:
            played = [play for _, play in self.played if play.sessions]
            forward = self.config.player_model is PlayerModelKind.MIXED_FORWARD and len(played) > 1
            self._shrunk = fit_shrunk_model(
                self.graph.vertex_descriptors(),
                np.asarray(self.graph.vertex_control),
                PlayCounts.merged(played[:-1]) if forward else self.play,
                self.heuristic_model(),
                self.config.crowd_radius,
                latest=played[-1] if forward else None,
            )
        return self._shrunk

    def learnt_counts(self) -> np.ndarray:
        """The (V, N) control counts the crowd model learns from: every session's steps,
        for ``mixed-fresh`` weighed by what has changed since (:meth:`fresh_fit`)."""
        if self.config.player_model is not PlayerModelKind.MIXED_FRESH:
            return self.play.control_counts(self.graph.n_vertices, self.graph.n_controls)
        fresh = self.fresh_fit()
        return weighted_counts(
            self.published_play(),
            freeze(self.graph),
            self.graph.n_vertices,
            fresh.discount,
            fresh.depth,
        )

    def shrunk_model(self, counts: np.ndarray) -> np.ndarray:
        """P(c|v) of ``shrunk`` learnt from ``counts``, its radius and weight chosen
        (:meth:`shrunk_fit`)."""
        fit = self.shrunk_fit()
        return shrunk_player_model(
            self.graph.vertex_descriptors(),
            np.asarray(self.graph.vertex_control),
            counts,
            fit.radius,
            fit.prior_weight,
            prior=self.heuristic_model(),
        )

    def published_play(self) -> list[tuple[Publication, PlayCounts]]:
        """The sessions learnt, each publication's with it, oldest first; ValueError
        when some were learnt without theirs."""
        if any(publication is None for publication, _ in self.played):
            raise ValueError(
                f"the {self.config.player_model} model needs every session's publication"
            )
        return [(publication, play) for publication, play in self.played if publication is not None]

    def fresh_fit(self) -> FreshFit:
        """For ``mixed-fresh``: how much a step counts where the graph has changed since
        it was played, chosen on the latest publication's sessions (fitted once)."""
        if self._fresh is None:
            self._fresh = fit_fresh_evidence(
                self.published_play(), self.shrunk_model, self.graph.n_vertices
            )
        return self._fresh

    def share_fit(self) -> ShareFit:
        """The share of heuristic players the ranking's population holds: ``mixed``'s,
        or for ``mixed-error`` and ``mixed-held`` chosen where the latest publication's
        players met error (fitted once)."""
        kind = self.config.player_model
        if self._share is None:
            self._share = (
                fit_error_share(
                    self.published_play(),
                    self.shrunk_model,
                    self.heuristic_model(),
                    self.graph.n_vertices,
                    self.restart,
                    held=kind is PlayerModelKind.MIXED_HELD,
                )
                if kind in ERROR_SHARE_KINDS
                else ShareFit(UNSEEN_SHARE)
            )
        return self._share

    def choice_model(self) -> ChoiceModel:
        """The logit-prior model fitted to the sessions learnt so far (fitted once)."""
        if self._choice is None:
            control, parents = np.asarray(self.graph.vertex_control), self.graph.vertex_parents()
            played = [
                PlayedGraph(ChoiceGraph.of(publication, control, parents), play)
                for publication, play in self.published_play()
            ]
            self._choice = fit_choice_model(played, self.kernel())
        return self._choice

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
        pi), else from this refiner's last; for the mixed models with traces, the crowd's
        and the heuristic model's mixed (:func:`mixed_weights`, :meth:`share_fit`)."""
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
        if not (self.config.player_model in MIXED_KINDS and self._learnt):
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
        if self.config.player_model is PlayerModelKind.MIXED_SPLIT:
            return split_weights(result, heuristic, self.share_fit().share)
        return mixed_weights(result, heuristic, self.share_fit().share)

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
            hedge=ranked.hedge,
            rank_error=self.config.rank_error,
            threshold=self.config.high_error_threshold,
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
        numbered after those learnt before (their folds follow, :mod:`app.core.crowd_play`).

        The logit model reads each session's goals on the publication it was played on;
        eq. 2 reads none, so its callers need not load them.
        """
        self.learn_counts(PlayCounts.of_traces(traces, first=self.play.sessions), publication)

    def learn_counts(self, play: PlayCounts, publication: Publication | None = None) -> None:
        """:meth:`learn` of sessions already summed, their buckets those of their ordinals
        among every session learnt (the store keeps them so)."""
        self.played.append((publication, play))
        self._choice = None
        self._neighbours = None
        self._shrunk = None
        self._fresh = None
        self._share = None
