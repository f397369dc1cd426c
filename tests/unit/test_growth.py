"""The state graph's structural promises under initialisation, expansion and relinking."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from app.core.graph.clipbank import MemoryClipBank
from app.core.graph.state_graph import EdgeKind, StateGraph
from app.core.graph.toy import ToyDynamics
from app.core.growth.expansion import (
    best_target,
    expand_blend_edge,
    initial_tree,
    integrate_expansion,
    relink_all,
    select_for_expansion,
    simulate_clips,
)

DYN = ToyDynamics()


def fresh_tree(depth: int = 2) -> tuple[StateGraph, MemoryClipBank]:
    bank = MemoryClipBank()
    return initial_tree(DYN, bank, depth=depth), bank


def test_initial_tree_of_depth_two_has_n_sim_and_n_squared_blend_edges() -> None:
    graph, _ = fresh_tree()
    n = DYN.n_controls
    kinds = np.asarray(graph.edge_kind)
    assert graph.n_vertices == 1 + n
    assert np.sum(kinds == EdgeKind.SIM) == n
    assert np.sum(kinds == EdgeKind.BLEND) == n * n
    assert graph.size_frames == (n + n * n) * DYN.frames_per_clip
    graph.check()


def test_initial_tree_rejects_depth_one() -> None:
    with pytest.raises(ValueError, match="depth"):
        initial_tree(DYN, MemoryClipBank(), depth=1)


@settings(max_examples=25, deadline=None)
@given(st.lists(st.integers(min_value=0, max_value=10_000), min_size=1, max_size=25))
def test_any_sequence_of_expansions_keeps_the_graph_complete(picks: list[int]) -> None:
    graph, bank = fresh_tree()
    for pick in picks:
        blends = graph.blend_edges()
        expand_blend_edge(graph, bank, DYN, int(blends[pick % len(blends)]))
        graph.check()
        assert graph.n_edges == graph.n_vertices * graph.n_controls
        assert graph.size_frames == graph.n_clips * graph.frames_per_clip
        for edge in graph.blend_edges():
            target = graph.edge_target[edge]
            assert graph.edge_clip[target] != graph.edge_clip[edge]
            assert graph.edge_kind[target] == EdgeKind.SIM
    assert graph.n_clips == DYN.n_controls * (1 + DYN.n_controls + len(picks))


def test_expansion_turns_the_blend_into_a_sim_edge_to_a_new_vertex() -> None:
    graph, bank = fresh_tree()
    edge = int(graph.blend_edges()[0])
    dead_end = graph.edge_clip[edge]
    expansion = expand_blend_edge(graph, bank, DYN, edge)
    assert graph.edge_kind[edge] == EdgeKind.SIM
    assert graph.edge_dst[edge] == expansion.vertex
    assert graph.vertex_clip[expansion.vertex] == dead_end
    assert graph.vertex_control[expansion.vertex] == graph.edge_control(edge)
    assert all(graph.edge_kind[e] == EdgeKind.BLEND for e in expansion.blends)


def test_integration_with_wrong_clips_changes_nothing() -> None:
    graph, bank = fresh_tree()
    edge = int(graph.blend_edges()[0])
    before = (graph.n_vertices, list(graph.edge_kind), list(graph.edge_dst))
    state = bank.end_state(graph.edge_clip[edge])
    clips = simulate_clips(DYN, state, (0, 2, 1))
    with pytest.raises(ValueError, match="control order"):
        integrate_expansion(graph, bank, DYN, edge, clips)
    assert (graph.n_vertices, list(graph.edge_kind), list(graph.edge_dst)) == before


def test_expanding_a_sim_edge_is_refused() -> None:
    graph, bank = fresh_tree()
    sim_edge = int(np.flatnonzero(np.asarray(graph.edge_kind) == EdgeKind.SIM)[0])
    with pytest.raises(ValueError, match="not a BLEND edge"):
        expand_blend_edge(graph, bank, DYN, sim_edge)


def grown(expansions: int) -> tuple[StateGraph, MemoryClipBank]:
    graph, bank = fresh_tree()
    rng = np.random.default_rng(3)
    for _ in range(expansions):
        expand_blend_edge(graph, bank, DYN, int(rng.choice(graph.blend_edges())))
    return graph, bank


def test_prefiltered_target_equals_brute_force_when_k_covers_the_graph() -> None:
    graph, bank = grown(30)
    for edge in graph.blend_edges()[:20]:
        clip, control = graph.edge_clip[edge], graph.edge_control(edge)
        found = best_target(graph, bank, DYN, clip, control, prefilter_k=10_000)
        sims = [
            e
            for e in range(graph.n_edges)
            if graph.edge_kind[e] == EdgeKind.SIM
            and graph.edge_control(e) == control
            and graph.edge_clip[e] != clip
        ]
        errs = [
            DYN.dist(bank.features(clip), bank.features(graph.edge_clip[e]), control) for e in sims
        ]
        assert found.err == pytest.approx(min(errs))


def test_energy_prefilter_returns_the_k_nearest_energies() -> None:
    graph, _ = grown(40)
    for control in range(graph.n_controls):
        sims = [
            e
            for e in range(graph.n_edges)
            if graph.edge_kind[e] == EdgeKind.SIM and graph.edge_control(e) == control
        ]
        energies = {e: graph.clip_energy(graph.edge_clip[e], control) for e in sims}
        probe = float(np.median(list(energies.values())))
        k = min(5, len(sims))
        got = graph.nearest_sim_edges_by_energy(probe, control, k)
        cutoff = sorted(abs(v - probe) for v in energies.values())[k - 1]
        assert len(got) == k
        assert all(abs(energies[e] - probe) <= cutoff + 1e-15 for e in got)


def test_relink_all_leaves_every_blend_at_its_best_target() -> None:
    graph, bank = grown(40)
    errors_before = np.asarray(graph.edge_err).copy()
    relinked = relink_all(graph, bank, DYN)
    after = np.asarray(graph.edge_err)
    assert np.all(after <= errors_before + 1e-12)
    assert all(after[e] < errors_before[e] for e in relinked)
    for edge in graph.blend_edges():
        best = best_target(graph, bank, DYN, graph.edge_clip[edge], graph.edge_control(edge))
        assert graph.edge_err[edge] == pytest.approx(best.err)
    graph.check()


def test_selection_pops_by_priority_and_requeues_relinked_edges() -> None:
    graph, _ = grown(10)
    weights = np.ones(graph.n_edges)
    err = np.asarray(graph.edge_err)
    blends = graph.blend_edges()
    top = blends[np.argsort(-err[blends], kind="stable")[:3]]
    outcome = select_for_expansion(graph, weights, 3, relink=lambda e: False)
    assert outcome.expanded == [int(e) for e in top]

    calls: list[int] = []

    def relink_first_only(edge: int) -> bool:
        calls.append(edge)
        if len(calls) == 1:
            graph.edge_err[edge] = 0.0  # a much better target was found
            return True
        return False

    outcome = select_for_expansion(graph, weights, 1, relink=relink_first_only)
    assert outcome.relinked == [int(top[0])]
    assert outcome.expanded == [int(top[1])]
