"""The logit-prior player model: goal features, the fit, cross-validation, the posterior."""

from __future__ import annotations

import functools
import itertools

import numpy as np
import pytest

from app.core import refinement
from app.core.bots import BotKind, play_sessions
from app.core.choice_model import (
    ChoiceGraph,
    ChoiceModel,
    Kernel,
    PlayedGraph,
    choice_features,
    fit_choice_model,
    goal_values,
    scaled_goal,
)
from app.core.clipbank import MemoryClipBank
from app.core.crowd_play import PlayCounts
from app.core.growth import expand_blend_edge, initial_tree
from app.core.player_models import (
    PlayerModelKind,
    crowd_player_model,
    heuristic_player_model,
    kernel_counts,
    observed_control_counts,
    parse_player_model,
)
from app.core.publication import Publication
from app.core.refinement import Refiner, RefinerConfig
from app.core.strategies import Strategy
from app.core.toy import ToyDynamics

DYN = ToyDynamics()
N = 3
#: the synthetic crowd's logit: goal, goal_before, keep, bias of controls 1 and 2
TRUE_WEIGHTS = np.array([3.0, 1.0, 1.5, 0.4, -0.5])
TRUE_HORIZON, TRUE_DISCOUNT = 3, 0.7


# ---- features -----------------------------------------------------------------------------
def tiny_graph() -> ChoiceGraph:
    """Three vertices, two controls: 0 -> (1, 2), 1 -> (2, 0), 2 -> (0, 1)."""
    return ChoiceGraph(
        edge_dst=np.array([1, 2, 2, 0, 0, 1]),
        edge_score=np.array([1.0, 0.0, 0.0, 2.0, 3.0, 1.0]),
        vertex_control=np.array([0, 0, 1]),
        vertex_parent=np.array([0, 0, 0]),
        n_controls=2,
    )


def test_goal_values_of_one_step_are_the_edge_scores() -> None:
    np.testing.assert_array_equal(
        goal_values(tiny_graph(), 1, 0.5), [[1.0, 0.0], [0.0, 2.0], [3.0, 1.0]]
    )


def test_goal_values_of_two_and_three_steps_by_hand() -> None:
    graph = tiny_graph()
    # two steps: the mean next score is 0.5 at vertex 0, 1 at vertex 1, 2 at vertex 2
    np.testing.assert_allclose(
        goal_values(graph, 2, 1.0), [[1 + 1, 0 + 2], [0 + 2, 2 + 0.5], [3 + 0.5, 1 + 1]]
    )
    np.testing.assert_allclose(
        goal_values(graph, 2, 0.5), [[1.5, 1.0], [1.0, 2.25], [3.25, 1.5]], rtol=0, atol=1e-15
    )
    # three steps at discount 0.5: the two-step values' row means are 1.25, 1.625, 2.375
    np.testing.assert_allclose(
        goal_values(graph, 3, 0.5),
        [[1.8125, 1.1875], [1.1875, 2.625], [3.625, 1.8125]],
        rtol=0,
        atol=1e-15,
    )
    # no discount beyond the first step: the edge's own score
    np.testing.assert_array_equal(goal_values(graph, 3, 0.0), goal_values(graph, 1, 0.0))


def random_graph(
    seed: int, n_vertices: int = 200, n_controls: int = N, *, score_seed: int | None = None
) -> ChoiceGraph:
    """Random destinations, scores and lineage (each vertex's parent comes before it)."""
    rng = np.random.default_rng(seed)
    parent = np.concatenate([[0], [rng.integers(0, v) for v in range(1, n_vertices)]])
    score_rng = rng if score_seed is None else np.random.default_rng(score_seed)
    return ChoiceGraph(
        edge_dst=rng.integers(0, n_vertices, size=n_vertices * n_controls),
        edge_score=score_rng.random(n_vertices * n_controls),
        vertex_control=rng.integers(0, n_controls, size=n_vertices),
        vertex_parent=parent.astype(np.int64),
        n_controls=n_controls,
    )


def mean_path_value(graph: ChoiceGraph, vertex: int, control: int, horizon: int, d: float) -> float:
    """The discounted score averaged over every control sequence of ``horizon`` steps."""
    n = graph.n_controls
    totals = []
    for rest in itertools.product(range(n), repeat=horizon - 1):
        v, total = vertex, 0.0
        for step, c in enumerate((control, *rest)):
            total += d**step * graph.edge_score[v * n + c]
            v = int(graph.edge_dst[v * n + c])
        totals.append(total)
    return float(np.mean(totals))


@pytest.mark.parametrize(("horizon", "discount"), [(1, 0.9), (2, 0.9), (3, 0.5), (4, 1.0)])
def test_goal_values_are_the_mean_discounted_path(horizon: int, discount: float) -> None:
    graph = random_graph(4, n_vertices=12)
    q = goal_values(graph, horizon, discount)
    expected = [
        [mean_path_value(graph, v, c, horizon, discount) for c in range(N)] for v in range(12)
    ]
    np.testing.assert_allclose(q, expected, rtol=1e-12)


@pytest.mark.parametrize(("horizon", "discount"), [(0, 0.5), (2, -0.1), (2, 1.5)])
def test_goal_values_refuse_a_bad_horizon_or_discount(horizon: int, discount: float) -> None:
    with pytest.raises(ValueError, match="horizon"):
        goal_values(tiny_graph(), horizon, discount)


def test_scaled_goal_spans_minus_one_to_zero_and_is_zero_on_flat_rows() -> None:
    rng = np.random.default_rng(0)
    q = rng.normal(size=(50, 4)) * 10.0
    q[7] = 2.5  # every control alike
    s = scaled_goal(q)
    assert s.min() >= -1.0 and s.max() <= 0.0
    rows = np.delete(np.arange(50), 7)
    np.testing.assert_allclose(s[rows].max(axis=1), 0.0, atol=1e-15)
    np.testing.assert_allclose(s[rows].min(axis=1), -1.0, atol=1e-15)
    np.testing.assert_array_equal(s[7], 0.0)
    # order within a row is kept, and an affine change of a row's scores changes nothing
    np.testing.assert_array_equal(np.argsort(s[rows], axis=1), np.argsort(q[rows], axis=1))
    np.testing.assert_allclose(scaled_goal(3.0 * q + 1.0), s, atol=1e-12)


def test_choice_features_columns() -> None:
    graph = random_graph(1, n_vertices=30)
    f = choice_features(graph, 2, 0.9)
    assert f.shape == (30, N, 3 + N - 1)
    goal = scaled_goal(goal_values(graph, 2, 0.9))
    np.testing.assert_array_equal(f[:, :, 0], goal)
    np.testing.assert_array_equal(f[:, :, 1], goal[graph.vertex_parent])
    # keep: one at the control that produced the vertex, zero elsewhere
    np.testing.assert_array_equal(f[:, :, 2].sum(axis=1), 1.0)
    np.testing.assert_array_equal(f[:, :, 2].argmax(axis=1), graph.vertex_control)
    # one bias per control but the first, the same at every vertex
    for j in range(N - 1):
        np.testing.assert_array_equal(f[:, :, 3 + j], np.tile(np.arange(N) == j + 1, (30, 1)))


def test_choice_graph_of_a_publication_takes_the_first_vertices_of_a_grown_lineage() -> None:
    publication = Publication(
        n_controls=2,
        start=0,
        edge_dst=np.array([1, 0, 0, 1]),
        edge_kind=np.zeros(4, dtype=np.int8),
        edge_err=np.zeros(4),
        edge_score=np.array([0.1, 0.2, 0.3, 0.4]),
    )
    graph = ChoiceGraph.of(publication, np.array([0, 1, 1, 0]), np.array([0, 0, 1, 1]))
    assert graph.n_vertices == 2 and graph.n_controls == 2
    np.testing.assert_array_equal(graph.vertex_control, [0, 1])
    np.testing.assert_array_equal(graph.vertex_parent, [0, 0])
    np.testing.assert_array_equal(graph.edge_score, publication.edge_score)


# ---- the model's answers --------------------------------------------------------------------
def softmax_rows(z: np.ndarray) -> np.ndarray:
    e = np.exp(z - z.max(axis=1, keepdims=True))
    return e / e.sum(axis=1, keepdims=True)


def true_model(prior_weight: float = 2.0) -> ChoiceModel:
    return ChoiceModel(TRUE_WEIGHTS, TRUE_HORIZON, TRUE_DISCOUNT, 1e-4, prior_weight)


def test_logit_is_the_softmax_of_the_weighted_features() -> None:
    graph = random_graph(2)
    logit = true_model().logit(graph)
    features = choice_features(graph, TRUE_HORIZON, TRUE_DISCOUNT)
    np.testing.assert_allclose(logit, softmax_rows(features @ TRUE_WEIGHTS), rtol=1e-12)
    np.testing.assert_allclose(logit.sum(axis=1), 1.0, rtol=0, atol=1e-12)


def test_posterior_is_the_logit_without_evidence_and_the_frequencies_with_much() -> None:
    graph = random_graph(2)
    model = true_model(prior_weight=2.0)
    logit = model.logit(graph)
    evidence = np.zeros((graph.n_vertices, N))
    np.testing.assert_allclose(model.probabilities(graph, evidence), logit, rtol=1e-12)
    evidence[5] = [1.0, 3.0, 6.0]
    evidence[9] = [4_000.0, 0.0, 16_000.0]
    p = model.probabilities(graph, evidence)
    np.testing.assert_allclose(p.sum(axis=1), 1.0, rtol=0, atol=1e-12)
    # a Dirichlet posterior with 2 pseudo-steps of the logit
    np.testing.assert_allclose(p[5], (evidence[5] + 2.0 * logit[5]) / 12.0, rtol=1e-12)
    np.testing.assert_allclose(p[9], [0.2, 0.0, 0.8], atol=2.0 / 20_000)
    untouched = np.setdiff1d(np.arange(graph.n_vertices), [5, 9])
    np.testing.assert_allclose(p[untouched], logit[untouched], rtol=1e-12)


# ---- fitting on a synthetic crowd -----------------------------------------------------------
def synthetic_sessions(
    graph: ChoiceGraph, seed: int, sessions: int = 200, steps: int = 50
) -> list[np.ndarray]:
    """Sessions at uniformly drawn vertices, each choice drawn from the true logit."""
    rng = np.random.default_rng(seed)
    p = true_model().logit(graph)
    cumulative = p.cumsum(axis=1)
    traces = []
    for _ in range(sessions):
        vertices = rng.integers(0, graph.n_vertices, size=steps)
        u = rng.random(steps)[:, None]
        controls = np.minimum((u > cumulative[vertices]).sum(axis=1), N - 1)
        traces.append(np.column_stack([vertices, controls]).astype(np.int64))
    return traces


def separate_kernel(n_vertices: int, vertex_control: np.ndarray) -> Kernel:
    """A kernel that reaches no other vertex: the evidence is each vertex's own counts."""
    return Kernel(np.arange(n_vertices, dtype=np.float64)[:, None], vertex_control, 0.5)


SMALL_GRID = {"discounts": (TRUE_DISCOUNT,), "penalties": (1e-4,), "folds": 3}


Crowd = tuple[ChoiceGraph, list[np.ndarray]]


@pytest.fixture(scope="module")
def crowd() -> Crowd:
    graph = random_graph(11)
    return graph, synthetic_sessions(graph, seed=12)


def test_fit_recovers_the_weights_and_cross_validation_the_horizon(crowd: Crowd) -> None:
    graph, traces = crowd
    model = fit_choice_model(
        [PlayedGraph(graph, PlayCounts.of_traces(traces))],
        separate_kernel(graph.n_vertices, graph.vertex_control),
        horizons=(1, TRUE_HORIZON),
        prior_weights=(1.0,),
        **SMALL_GRID,  # type: ignore[arg-type]
    )
    assert model.horizon == TRUE_HORIZON
    assert model.discount == TRUE_DISCOUNT
    # 10,000 choices on five weights: standard errors of about 0.05 to 0.15
    np.testing.assert_allclose(model.weights, TRUE_WEIGHTS, atol=0.35)
    key = f"horizon={{}} discount={TRUE_DISCOUNT} penalty=0.0001"
    assert model.cv_scores[key.format(TRUE_HORIZON)] > model.cv_scores[key.format(1)]
    assert all(score < 0.0 for score in model.cv_scores.values())  # log-likelihoods per step


def test_fit_at_a_wrong_horizon_misses_the_weights(crowd: Crowd) -> None:
    graph, traces = crowd
    model = fit_choice_model(
        [PlayedGraph(graph, PlayCounts.of_traces(traces))],
        separate_kernel(graph.n_vertices, graph.vertex_control),
        horizons=(1,),
        prior_weights=(1.0,),
        **SMALL_GRID,  # type: ignore[arg-type]
    )
    assert model.horizon == 1
    assert not np.allclose(model.weights, TRUE_WEIGHTS, atol=0.35)


def test_posterior_follows_the_frequencies_where_visited_and_the_logit_elsewhere(
    crowd: Crowd,
) -> None:
    graph, traces = crowd
    kernel = separate_kernel(graph.n_vertices, graph.vertex_control)
    model = fit_choice_model(
        [PlayedGraph(graph, PlayCounts.of_traces(traces))],
        kernel,
        horizons=(TRUE_HORIZON,),
        prior_weights=(1.0, 10.0),
        **SMALL_GRID,  # type: ignore[arg-type]
    )
    logit = model.logit(graph)
    rng = np.random.default_rng(5)
    heavy, frequencies = 17, np.array([0.1, 0.7, 0.2])
    visits = 3_000
    counts = observed_control_counts(traces, graph.n_vertices, N)
    counts[:100] = 0  # the first half of the vertices: as if nobody went there
    counts[heavy] = np.bincount(rng.choice(N, visits, p=frequencies), minlength=N)
    p = model.probabilities(graph, kernel.counts(counts))
    np.testing.assert_allclose(p.sum(axis=1), 1.0, rtol=0, atol=1e-12)
    unvisited = np.flatnonzero(counts.sum(axis=1) == 0)
    assert unvisited.size > 90
    np.testing.assert_allclose(p[unvisited], logit[unvisited], rtol=1e-12)
    # many visits: the observed frequencies, up to prior_weight pseudo-steps in 3,000
    observed = counts[heavy] / visits
    assert np.abs(logit[heavy] - observed).max() > 0.1  # the logit alone says otherwise
    np.testing.assert_allclose(p[heavy], observed, atol=model.prior_weight / visits)
    # a few visits: between the logit and the frequencies
    few = np.flatnonzero(counts[100:].sum(axis=1) > 0)[0] + 100
    share = counts[few].sum() / (counts[few].sum() + model.prior_weight)
    np.testing.assert_allclose(
        p[few], share * counts[few] / counts[few].sum() + (1 - share) * logit[few], rtol=1e-12
    )


def test_fit_explains_each_session_by_the_graph_it_was_played_on() -> None:
    """Two publications of one lineage with different scores and edges."""
    first = random_graph(21, n_vertices=150)
    grown = random_graph(22, n_vertices=200)
    grown = ChoiceGraph(
        grown.edge_dst,
        grown.edge_score,
        np.concatenate([first.vertex_control, grown.vertex_control[150:]]),
        np.concatenate([first.vertex_parent, grown.vertex_parent[150:]]),
        N,
    )
    on_first = synthetic_sessions(first, seed=23, sessions=100)
    on_grown = synthetic_sessions(grown, seed=24, sessions=100)
    kernel = separate_kernel(200, grown.vertex_control)
    grid = {"horizons": (TRUE_HORIZON,), "prior_weights": (1.0,), **SMALL_GRID}
    own = fit_choice_model(
        [
            PlayedGraph(first, PlayCounts.of_traces(on_first)),
            PlayedGraph(grown, PlayCounts.of_traces(on_grown, first=len(on_first))),
        ],
        kernel,
        **grid,  # type: ignore[arg-type]
    )
    np.testing.assert_allclose(own.weights, TRUE_WEIGHTS, atol=0.35)
    # the grown graph's sessions read against the first graph's features (its first 150
    # vertices only: the later ones do not exist there) explain less
    inside = [t[t[:, 0] < 150] for t in on_grown]
    mixed = fit_choice_model(
        [
            PlayedGraph(first, PlayCounts.of_traces(on_first)),
            PlayedGraph(first, PlayCounts.of_traces(inside, first=len(on_first))),
        ],
        kernel,
        **grid,  # type: ignore[arg-type]
    )
    assert mixed.weights[0] < own.weights[0] - 0.5
    assert not np.allclose(mixed.weights, own.weights, atol=0.2)


def test_fit_without_a_step_is_an_error() -> None:
    graph = random_graph(3, n_vertices=10)
    with pytest.raises(ValueError, match="no trace has a step"):
        fit_choice_model(
            [PlayedGraph(graph, PlayCounts.of_traces([np.empty((0, 2), dtype=np.int64)]))],
            separate_kernel(10, graph.vertex_control),
        )


def test_fit_is_reproducible() -> None:
    graph = random_graph(6, n_vertices=40)
    traces = synthetic_sessions(graph, seed=7, sessions=20, steps=20)
    kernel = separate_kernel(40, graph.vertex_control)
    grid = {"horizons": (1, 2), "prior_weights": (1.0, 3.0), **SMALL_GRID}
    played = [PlayedGraph(graph, PlayCounts.of_traces(traces))]
    a = fit_choice_model(played, kernel, **grid)  # type: ignore[arg-type]
    b = fit_choice_model(played, kernel, **grid)  # type: ignore[arg-type]
    np.testing.assert_array_equal(a.weights, b.weights)
    assert a.cv_scores == b.cv_scores
    assert a.prior_weight in (1.0, 3.0)
    assert set(a.cv_scores) >= {"prior_weight=1.0", "prior_weight=3.0"}


# ---- eq. 2's kernel counts ----------------------------------------------------------------------
@pytest.mark.parametrize("seed", range(3))
def test_crowd_model_is_the_normalised_kernel_counts_plus_the_eps_prior(seed: int) -> None:
    rng = np.random.default_rng(seed)
    descriptors = rng.random((80, 3))
    vertex_control = rng.integers(0, N, size=80)
    counts = rng.integers(0, 5, size=(80, N))
    counts[rng.random(80) < 0.6] = 0
    counts[vertex_control == 2] = 0  # a control group nobody visited: the fallback
    fallback = heuristic_player_model(vertex_control, N, 0.8)
    radius, eps = 0.35, 1e-2
    k = kernel_counts(descriptors, vertex_control, counts, radius)
    group_totals = np.array([counts[vertex_control == c].sum(axis=0) for c in range(N)])
    scores = k + eps * group_totals[vertex_control]
    expected = fallback.copy()
    supported = scores.sum(axis=1) > 0
    expected[supported] = scores[supported] / scores[supported].sum(axis=1, keepdims=True)
    model = crowd_player_model(descriptors, vertex_control, counts, radius, eps, fallback=fallback)
    np.testing.assert_allclose(model, expected, rtol=1e-12, atol=1e-15)
    assert np.array_equal(model[vertex_control == 2], fallback[vertex_control == 2])


def test_kernel_counts_weigh_own_visits_fully_and_neighbours_by_the_triangle() -> None:
    descriptors = np.array([[0.0, 0.0], [0.3, 0.4], [0.0, 0.1], [5.0, 5.0]])
    vertex_control = np.array([1, 1, 0, 1])
    counts = np.array([[2, 6, 0], [1, 0, 1], [9, 0, 0], [0, 3, 0]])
    k = kernel_counts(descriptors, vertex_control, counts, radius=1.0)
    # 0 and 1 are 0.5 apart in group 1: weight 0.5 each way; 2 is alone in group 0; 3 is far
    np.testing.assert_allclose(k[0], [2 + 0.5, 6, 0.5])
    np.testing.assert_allclose(k[1], [1 + 1, 3, 1])
    np.testing.assert_array_equal(k[2], [9, 0, 0])
    np.testing.assert_array_equal(k[3], [0, 3, 0])
    # a radius that reaches nobody else leaves each vertex its own counts
    np.testing.assert_array_equal(kernel_counts(descriptors, vertex_control, counts, 0.05), counts)


def test_player_model_names_parse_and_unknown_ones_name_the_known() -> None:
    assert parse_player_model("eq2") is PlayerModelKind.EQ2
    assert parse_player_model("logit") is PlayerModelKind.LOGIT
    with pytest.raises(ValueError, match="eq2, logit"):
        parse_player_model("best")


# ---- the graph's lineage and the refiner ---------------------------------------------------------
def test_vertex_parents_of_a_grown_graph() -> None:
    bank = MemoryClipBank()
    graph = initial_tree(DYN, bank)
    np.testing.assert_array_equal(graph.vertex_parents(), [0] * (1 + DYN.n_controls))
    rng = np.random.default_rng(3)
    sources = {}
    for _ in range(12):
        edge = int(rng.choice(graph.blend_edges()))
        expansion = expand_blend_edge(graph, bank, DYN, edge)
        sources[expansion.vertex] = graph.edge_source(edge)
    parents = graph.vertex_parents()
    assert parents.shape == (graph.n_vertices,)
    assert parents[graph.start] == graph.start
    for vertex, source in sources.items():
        assert parents[vertex] == source
    assert np.all(parents[1:] < np.arange(1, graph.n_vertices))  # appended after the parent


def logit_refiner() -> tuple[Refiner, Publication]:
    """An sr-crowd refiner that learnt from bots on its first publication, then grew on."""
    bank = MemoryClipBank()
    r = Refiner(
        initial_tree(DYN, bank),
        bank,
        DYN,
        Strategy.SR_CROWD,
        RefinerConfig(batch_size=4, player_model=PlayerModelKind.LOGIT),
    )
    r.grow(expansions=20)
    first = r.publish()[0]
    r.learn(play_sessions(first, BotKind.GOAL_DIRECTED, sessions=12, mean_steps=30, seed=2), first)
    r.grow(expansions=8)
    return r, first


def test_refiner_with_the_logit_model_answers_for_every_vertex_and_publication(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # the refiner's own fit, on a one-point logit grid: the default grid takes seconds
    small = functools.partial(
        fit_choice_model, horizons=(2,), discounts=(0.9,), penalties=(1e-2,), folds=3
    )
    monkeypatch.setattr(refinement, "fit_choice_model", small)
    r, first = logit_refiner()
    eq2 = Refiner(r.graph, r.bank, DYN, Strategy.SR_CROWD, RefinerConfig(), played=r.played)
    assert r.graph.n_vertices > first.n_vertices
    model = r.player_model()
    assert model.shape == (r.graph.n_vertices, N)
    assert np.all(model >= 0.0)
    np.testing.assert_allclose(model.sum(axis=1), 1.0, rtol=0, atol=1e-12)
    assert not np.allclose(model, eq2.player_model())  # the same sessions, eq. 2
    older = r.player_model(on=first)
    assert older.shape == (first.n_vertices, N)
    np.testing.assert_allclose(older.sum(axis=1), 1.0, rtol=0, atol=1e-12)
    # on an older publication: its own edges, so other goal values than the graph's now
    assert not np.allclose(older, model[: first.n_vertices])
    # the fitted model is kept until new sessions come
    fitted = r.choice_model()
    assert r.choice_model() is fitted
    second = r.publish()[0]
    r.learn(play_sessions(second, BotKind.RANDOM, sessions=6, mean_steps=20, seed=3), second)
    assert r.choice_model() is not fitted


def test_sessions_without_a_step_leave_the_logit_refiner_at_the_heuristic() -> None:
    bank = MemoryClipBank()
    config = RefinerConfig(player_model=PlayerModelKind.LOGIT)
    r = Refiner(initial_tree(DYN, bank), bank, DYN, Strategy.SR_CROWD, config)
    publication = r.publish()[0]
    r.learn([np.empty((0, 2), dtype=np.int64)], publication)
    eq2 = Refiner(r.graph, r.bank, DYN, Strategy.SR_CROWD, RefinerConfig(), played=r.played)
    np.testing.assert_array_equal(eq2.player_model(), r.heuristic_model())
    np.testing.assert_array_equal(r.player_model(), r.heuristic_model())


def test_eq2_learns_without_publications_and_the_logit_model_refuses_to() -> None:
    bank = MemoryClipBank()
    graph = initial_tree(DYN, bank)
    publication = Refiner(graph, bank, DYN, Strategy.SR_CROWD, RefinerConfig()).publish()[0]
    traces = play_sessions(publication, BotKind.GOAL_DIRECTED, sessions=4, mean_steps=10, seed=1)
    eq2 = Refiner(graph, bank, DYN, Strategy.SR_CROWD, RefinerConfig())
    eq2.learn(traces)
    assert not np.allclose(eq2.player_model(), eq2.heuristic_model())
    config = RefinerConfig(player_model=PlayerModelKind.LOGIT)
    logit = Refiner(graph, bank, DYN, Strategy.SR_CROWD, config)
    logit.learn(traces)
    with pytest.raises(ValueError, match="logit model needs every session.s publication"):
        logit.player_model()
