"""Bots, strategies and the refining loop on the toy."""

from __future__ import annotations

import numpy as np
import pytest
from trace_helpers import looping_trace

from app.core.graph.clipbank import MemoryClipBank
from app.core.graph.publication import Publication
from app.core.graph.toy import ToyDynamics
from app.core.growth.expansion import initial_tree
from app.core.growth.kinds import Strategy, parse_strategy
from app.core.growth.refinement import Refiner, RefinerConfig
from app.core.growth.strategies import EdgeWeights, edge_weights, mixed_weights
from app.core.players.bots import LEVEL_CONTROL, AvoiderBot, HesitantBot, play_sessions
from app.core.players.kinds import BotKind

DYN = ToyDynamics()


def refiner(strategy: Strategy) -> Refiner:
    bank = MemoryClipBank()
    graph = initial_tree(DYN, bank)
    return Refiner(graph, bank, DYN, strategy, RefinerConfig(batch_size=4))


@pytest.fixture(scope="module")
def publication():  # type: ignore[no-untyped-def]
    r = refiner(Strategy.SR_HEURISTIC)
    r.grow(expansions=60)
    return r.publish()[0]


@pytest.mark.parametrize("kind", list(BotKind))
def test_bots_are_reproducible_and_follow_edges(publication, kind: BotKind) -> None:  # type: ignore[no-untyped-def]
    a = play_sessions(publication, kind, sessions=5, mean_steps=30, seed=7)
    b = play_sessions(publication, kind, sessions=5, mean_steps=30, seed=7)
    assert all(np.array_equal(x, y) for x, y in zip(a, b, strict=True))
    assert all(publication.follows_edges(t) and t[0, 0] == publication.start for t in a)


def test_goal_directed_bots_score_more_than_random_ones(publication) -> None:  # type: ignore[no-untyped-def]
    def mean_score(kind: BotKind) -> float:
        traces = play_sessions(publication, kind, sessions=40, mean_steps=40, seed=1)
        steps = np.concatenate(traces)
        return float(publication.edge_score[steps[:, 0] * 3 + steps[:, 1]].mean())

    assert mean_score(BotKind.GOAL_DIRECTED) > 1.5 * mean_score(BotKind.RANDOM)


def test_unknown_strategy_names_the_known_ones() -> None:
    with pytest.raises(ValueError, match="sr-crowd"):
        parse_strategy("best")


def test_staterank_weights_are_edge_probabilities_and_baseline_is_local() -> None:
    r = refiner(Strategy.SR_HEURISTIC)
    r.grow(expansions=10)
    model = r.heuristic_model()
    ranked = edge_weights(Strategy.SR_HEURISTIC, r.graph, model, restart=1 / 90)
    assert ranked.weights.sum() == pytest.approx(1.0)
    baseline = edge_weights(Strategy.BASELINE, r.graph, model, restart=1 / 90)
    assert np.array_equal(baseline.weights, model.reshape(-1))
    assert baseline.rank is None


def test_grow_by_frames_meets_the_budget() -> None:
    r = refiner(Strategy.BASELINE)
    start = r.graph.size_frames
    r.grow(frames=300)
    assert r.graph.size_frames >= start + 300
    assert r.graph.size_frames < start + 300 + DYN.n_controls * DYN.frames_per_clip
    with pytest.raises(ValueError, match="exactly one budget"):
        r.grow()


def test_sr_crowd_learns_from_traces_and_others_ignore_them(publication) -> None:  # type: ignore[no-untyped-def]
    crowd, heuristic = refiner(Strategy.SR_CROWD), refiner(Strategy.SR_HEURISTIC)
    for r in (crowd, heuristic):
        r.grow(expansions=20)
        pub = r.publish()[0]
        r.learn(play_sessions(pub, BotKind.GOAL_DIRECTED, sessions=10, mean_steps=30, seed=2), pub)
    assert not np.allclose(crowd.player_model(), crowd.heuristic_model())
    assert np.array_equal(heuristic.player_model(), heuristic.heuristic_model())
    assert crowd.restart != pytest.approx(1 / 90)


def test_two_huge_looping_traces_of_one_player_do_not_stop_growth() -> None:
    """The finding: L = 85,000 steps made STATERANK miss convergence on every epoch."""
    r = refiner(Strategy.SR_CROWD)
    r.grow(expansions=2)
    publication = r.publish()[0]
    r.learn([looping_trace(publication, 1, 85_000) for _ in range(2)], publication)
    before = r.graph.n_vertices
    epochs = r.grow(expansions=4)
    assert r.graph.n_vertices == before + 4
    assert 1.0 / r.restart == r.config.max_session_steps
    assert r.weights().fallback is None  # the bounded restart converges: no fallback needed
    assert len(epochs) == 1


def test_staterank_that_fails_to_converge_falls_back_to_the_local_ordering() -> None:
    r = refiner(Strategy.SR_HEURISTIC)
    r.grow(expansions=10)
    model = r.heuristic_model()
    ranked = edge_weights(Strategy.SR_HEURISTIC, r.graph, model, restart=1 / 90, max_iter=1)
    assert ranked.rank is None
    assert np.array_equal(ranked.weights, model.reshape(-1))  # the baseline's weights
    assert ranked.fallback is not None
    assert "did not converge in 1 iterations" in ranked.fallback
    assert "baseline" in ranked.fallback
    converged = edge_weights(Strategy.SR_HEURISTIC, r.graph, model, restart=1 / 90)
    assert converged.fallback is None and converged.rank is not None


def test_a_mix_of_rankings_is_a_mix_of_distributions_and_never_mixes_a_fallback() -> None:
    r = refiner(Strategy.SR_HEURISTIC)
    r.grow(expansions=10)
    model = r.heuristic_model()
    ranked = edge_weights(Strategy.SR_HEURISTIC, r.graph, model, restart=1 / 90)
    uniform = EdgeWeights(np.full(r.graph.n_edges, 1.0 / r.graph.n_edges), None)
    mixed = mixed_weights(ranked, uniform, 0.25)
    np.testing.assert_allclose(mixed.weights, 0.75 * ranked.weights + 0.25 / r.graph.n_edges)
    assert mixed.rank is ranked.rank and mixed.fallback is None
    stuck = edge_weights(Strategy.SR_HEURISTIC, r.graph, model, restart=1 / 90, max_iter=1)
    kept = mixed_weights(ranked, stuck, 0.5)
    assert np.array_equal(kept.weights, ranked.weights) and kept.fallback == stuck.fallback
    with pytest.raises(ValueError, match="in \\[0, 1\\]"):
        mixed_weights(ranked, uniform, 1.5)


def test_growth_proceeds_when_staterank_never_converges() -> None:
    bank = MemoryClipBank()
    graph = initial_tree(DYN, bank)
    config = RefinerConfig(batch_size=4, staterank_max_iter=1)
    stuck = Refiner(graph, bank, DYN, Strategy.SR_CROWD, config)
    before = graph.n_vertices
    epochs = stuck.grow(expansions=8)
    assert [len(e.expanded) for e in epochs] == [4, 4]
    assert graph.n_vertices == before + 8


# ---- bots unlike the goal-directed one ------------------------------------------------------
def mean_score_per_step(publication: Publication, traces: list[np.ndarray]) -> float:
    steps = np.concatenate(traces)
    return float(publication.edge_score[steps[:, 0] * 3 + steps[:, 1]].mean())


def level_fraction(traces: list[np.ndarray]) -> float:
    return float(np.mean(np.concatenate(traces)[:, 1] == LEVEL_CONTROL))


def best_choice_share(best: np.ndarray, traces: list[np.ndarray], lag: int) -> float:
    """How often a control at step t is a best choice at the vertex of step t - lag
    (tilts only: level is what a hesitant player plays whatever the state)."""
    hits = [
        best[t[: len(t) - lag, 0], t[lag:, 1]][t[lag:, 1] != LEVEL_CONTROL]
        for t in traces
        if len(t) > lag
    ]
    return float(np.concatenate(hits).mean())


def test_hesitant_bots_let_the_tank_go_level_far_more_than_goal_directed_ones(publication) -> None:  # type: ignore[no-untyped-def]
    hesitant = play_sessions(publication, BotKind.HESITANT, sessions=40, mean_steps=40, seed=1)
    aiming = play_sessions(publication, BotKind.GOAL_DIRECTED, sessions=40, mean_steps=40, seed=1)
    assert level_fraction(hesitant) > HesitantBot().level_rate - 0.05
    assert level_fraction(hesitant) > 5 * level_fraction(aiming)


def test_hesitant_bots_play_goal_directed_decisions_late(publication) -> None:  # type: ignore[no-untyped-def]
    # no letting go and a near-greedy choice: every tilt is decided `delay` steps earlier
    sure = HesitantBot(temperature=0.01, level_rate=0.0)
    table = sure.policy(publication)
    best = table == table.max(axis=1, keepdims=True)
    traces = play_sessions(
        publication, BotKind.HESITANT, sessions=20, mean_steps=40, seed=3, hesitant=sure
    )
    for t in traces:
        assert np.all(t[: sure.delay, 1] == LEVEL_CONTROL)  # nothing decided yet
        assert np.all(best[t[: -sure.delay, 0], t[sure.delay :, 1]])
    assert best_choice_share(best, traces, lag=0) < 0.6
    # the default hesitant bot: its tilts follow the state of 3 steps ago, not the present
    default = HesitantBot()
    aim = HesitantBot(level_rate=0.0).policy(publication)
    traces = play_sessions(publication, BotKind.HESITANT, sessions=40, mean_steps=40, seed=1)
    best = aim == aim.max(axis=1, keepdims=True)
    late = best_choice_share(best, traces, lag=default.delay)
    assert late > best_choice_share(best, traces, lag=0) + 0.15


def test_avoiders_score_less_than_random_bots_and_goal_directed_ones_more(publication) -> None:  # type: ignore[no-untyped-def]
    def score(kind: BotKind, **bots: AvoiderBot) -> float:
        traces = play_sessions(publication, kind, sessions=40, mean_steps=40, seed=1, **bots)
        return mean_score_per_step(publication, traces)

    random = score(BotKind.RANDOM)
    assert score(BotKind.AVOIDER) < 0.9 * random
    assert score(BotKind.GOAL_DIRECTED) > 1.5 * random
    # without a reaction delay the avoider keeps the target window almost dry
    assert score(BotKind.AVOIDER, avoider=AvoiderBot(delay=0)) < 0.01 * random
