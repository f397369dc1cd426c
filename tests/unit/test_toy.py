"""The toy tank: physics sanity and the metric properties the liquid must also have."""

from __future__ import annotations

import numpy as np
import pytest

from app.core.graph.clipbank import MemoryClipBank
from app.core.graph.dynamics import Dynamics
from app.core.graph.toy import ToyDynamics
from app.core.growth.expansion import expand_blend_edge, initial_tree

DYN = ToyDynamics()


def rocked(controls: list[int]) -> np.ndarray:
    state = DYN.initial_state()
    for control in controls:
        state = DYN.simulate(state, control).end_state
    return state


def test_toy_satisfies_the_dynamics_protocol() -> None:
    assert isinstance(DYN, Dynamics)


def test_water_is_conserved_and_stays_positive() -> None:
    state = DYN.initial_state()
    water = state[: DYN.cells].sum()
    for control in [1, 1, 2, 2, 1, 0, 2, 2, 2, 1]:
        clip = DYN.simulate(state, control)
        assert np.all(clip.frames > 0)
        state = clip.end_state
    assert state[: DYN.cells].sum() == pytest.approx(water, rel=1e-12)


def test_simulation_is_deterministic() -> None:
    state = rocked([1, 2, 1])
    a, b = DYN.simulate(state, 2), DYN.simulate(state, 2)
    assert np.array_equal(a.frames, b.frames) and np.array_equal(a.end_state, b.end_state)


def test_clips_simulated_together_are_each_clip_alone() -> None:
    state = DYN.initial_state()
    clips = DYN.simulate_many([state, state], [2, 1])
    for clip, control in zip(clips, (2, 1), strict=True):
        alone = DYN.simulate(state, control)
        assert clip.control == control
        assert np.array_equal(clip.frames, alone.frames)
        assert np.array_equal(clip.end_state, alone.end_state)


def test_tank_at_rest_stays_at_rest_under_the_level_control() -> None:
    clip = DYN.simulate(DYN.initial_state(), 0)
    assert DYN.features(clip).kinetic < DYN.rest_kinetic


def test_rhythmic_rocking_scores_more_than_holding_still() -> None:
    def total(controls: list[int]) -> float:
        state, score = DYN.initial_state(), 0.0
        for control in controls:
            clip = DYN.simulate(state, control)
            score += DYN.features(clip).score
            state = clip.end_state
        return score

    assert total([1, 1, 2, 2] * 5) > 10 * max(total([0] * 20), 1e-6)


def test_potential_energy_depends_on_the_control() -> None:
    features = DYN.features(DYN.simulate(rocked([1, 1]), 1))
    assert len(set(np.round(features.potential, 9))) == DYN.n_controls


def test_dist_to_itself_is_zero_and_shape_is_symmetric() -> None:
    a = DYN.features(DYN.simulate(rocked([1, 2]), 1))
    b = DYN.features(DYN.simulate(rocked([2, 2, 1]), 1))
    assert DYN.dist(a, a, 1) == 0.0
    assert DYN.shape_distance(a, b) == pytest.approx(DYN.shape_distance(b, a))


def test_an_energy_gain_costs_more_than_an_equal_loss() -> None:
    low = DYN.features(DYN.simulate(rocked([1]), 0))
    high = DYN.features(DYN.simulate(rocked([1, 2, 1]), 0))
    assert high.energy(0) > low.energy(0) + DYN.rest_kinetic
    assert DYN.energy_distance(low, high, 0) > DYN.energy_distance(high, low, 0)


def test_two_resting_clips_with_the_same_control_are_at_distance_zero() -> None:
    a = DYN.features(DYN.simulate(DYN.initial_state(), 0))
    settled = rocked([1] * 40)
    b = DYN.features(DYN.simulate(settled, 1))
    c = DYN.features(DYN.simulate(DYN.simulate(settled, 1).end_state, 1))
    assert a.kinetic < DYN.rest_kinetic
    assert b.kinetic < DYN.rest_kinetic and c.kinetic < DYN.rest_kinetic
    assert DYN.dist(b, c, 1) == 0.0


def test_blend_starts_at_the_source_and_ends_at_the_destination() -> None:
    src = DYN.simulate(rocked([1]), 2).frames
    dst = DYN.simulate(rocked([2, 2]), 1).frames
    blended = DYN.blend(src, dst)
    assert np.allclose(blended[0], src[0]) and np.allclose(blended[-1], dst[-1])


def test_blends_the_graph_chooses_add_little_water() -> None:
    """The union term of eq. 8 adds volume where profiles differ: between a clip and a
    target it is not too different from (error below the high-error threshold) it stays
    within 10% of the larger endpoint."""
    bank = MemoryClipBank()
    graph = initial_tree(DYN, bank)
    rng = np.random.default_rng(0)
    for _ in range(40):
        expand_blend_edge(graph, bank, DYN, int(rng.choice(graph.blend_edges())))
    good = [e for e in graph.blend_edges() if graph.edge_err[e] < DYN.high_error_threshold]
    assert len(good) > 10
    for edge in good:
        src = bank.frames(graph.edge_clip[edge])
        dst = bank.frames(graph.edge_clip[graph.edge_target[edge]])
        volume = DYN.blend(src, dst).sum(axis=1)
        assert np.all(volume <= 1.1 * np.maximum(src.sum(axis=1), dst.sum(axis=1)))


def test_descriptor_is_a_6_by_6_occupancy_in_unit_range() -> None:
    features = DYN.features(DYN.simulate(rocked([1, 2]), 0))
    assert features.descriptor.shape == (36,)
    assert np.all((features.descriptor >= 0) & (features.descriptor <= 1))


def test_render_draws_small_rgb_frames() -> None:
    clip = DYN.simulate(rocked([1]), 2)
    images = DYN.render(clip.frames)
    assert images.shape[0] == DYN.frames_per_clip and images.shape[-1] == 3
    assert images.dtype == np.uint8 and images.std() > 0
