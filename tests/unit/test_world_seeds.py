"""World seeds: a seed varies the start state, reproducibly; None is the canonical start."""

from __future__ import annotations

import numpy as np
import pytest

from app.core.graph.clipbank import MemoryClipBank
from app.core.graph.toy import ToyDynamics
from app.core.growth.expansion import initial_tree
from app.core.growth.kinds import Strategy
from app.core.growth.refinement import Refiner, RefinerConfig
from app.core.liquid.scene import WORLD_JITTER, initial_particles, tilt_tank
from app.liquid.adapter import LiquidDynamics

TOY = ToyDynamics()
TINY = tilt_tank("tiny")


# ---- toy ------------------------------------------------------------------------------
def test_the_toy_start_without_a_world_is_still_water() -> None:
    start = TOY.initial_state()
    expected = np.concatenate([np.full(TOY.cells, TOY.depth), np.zeros(TOY.cells - 1)])
    assert np.array_equal(start, expected) and np.array_equal(TOY.initial_state(None), start)


def test_a_toy_world_perturbs_the_heights_reproducibly_and_keeps_the_water() -> None:
    still = TOY.initial_state()
    worlds = [TOY.initial_state(world) for world in (0, 1, 2)]
    for world, state in zip((0, 1, 2), worlds, strict=True):
        assert np.array_equal(state, TOY.initial_state(world))
        heights = state[: TOY.cells]
        assert heights.sum() == pytest.approx(still[: TOY.cells].sum(), rel=1e-12)
        assert not np.array_equal(heights, still[: TOY.cells])
        assert np.all(np.abs(heights - TOY.depth) <= 2 * TOY.world_perturbation * TOY.depth)
        assert np.all(state[TOY.cells :] == 0.0)  # the water starts still
    assert not np.array_equal(worlds[0], worlds[1]) and not np.array_equal(worlds[1], worlds[2])


def grown_baseline(world: int | None) -> tuple[list[np.ndarray], np.ndarray]:
    """Every clip's frames and the edge errors of a small baseline graph of ``world``."""
    bank = MemoryClipBank()
    graph = initial_tree(TOY, bank, world=world)
    refiner = Refiner(graph, bank, TOY, Strategy.BASELINE, RefinerConfig(batch_size=4))
    refiner.grow(expansions=8)
    frames = [bank.frames(clip) for clip in range(graph.n_clips)]
    return frames, np.asarray(graph.edge_err)


def test_a_world_changes_baselines_graph_and_the_same_world_grows_it_bit_for_bit() -> None:
    one, again, other = grown_baseline(1), grown_baseline(1), grown_baseline(2)
    assert len(one[0]) == len(again[0])
    assert all(np.array_equal(a, b) for a, b in zip(one[0], again[0], strict=True))
    assert np.array_equal(one[1], again[1])
    assert not np.array_equal(one[0][0], other[0][0])  # the first clip already differs
    canonical = grown_baseline(None)
    assert not np.array_equal(one[0][0], canonical[0][0])


# ---- liquid ---------------------------------------------------------------------------
def test_the_liquid_lattice_without_a_world_is_the_plain_one() -> None:
    """None keeps the start every calibration and stored graph was made from."""
    dx = TINY.spacing
    lo, hi = np.asarray(TINY.fluid.lo), np.asarray(TINY.fluid.hi)
    counts = np.floor((hi - lo) / dx + 1e-6).astype(int)
    axes = [lo[i] + dx * (np.arange(counts[i]) + 0.5) for i in range(3)]
    z, y, x = np.meshgrid(axes[2], axes[1], axes[0], indexing="ij")
    lattice = np.zeros((x.size, 6), dtype=np.float32)
    lattice[:, 0], lattice[:, 1], lattice[:, 2] = x.ravel(), y.ravel(), z.ravel()
    assert np.array_equal(initial_particles(TINY), lattice)
    assert np.array_equal(initial_particles(TINY, None), lattice)


def test_a_liquid_world_jitters_the_lattice_within_a_fraction_of_the_spacing() -> None:
    plain = initial_particles(TINY)
    one = initial_particles(TINY, 1)
    assert np.array_equal(one, initial_particles(TINY, 1))
    assert not np.array_equal(one, initial_particles(TINY, 2))
    offset = (one[:, :3] - plain[:, :3]).astype(np.float64) / TINY.spacing
    assert np.all(np.abs(offset) <= WORLD_JITTER + 1e-4) and np.abs(offset).max() > WORLD_JITTER / 2
    assert np.all(one[:, 3:] == 0.0)


@pytest.fixture(scope="module")
def tiny() -> LiquidDynamics:
    return LiquidDynamics("tiny")


def short_settle(dyn: LiquidDynamics, world: int | None) -> np.ndarray:
    return dyn.solver.settle(seconds=0.4, damped_seconds=0.2, world=world)


def test_a_liquid_world_settles_to_its_own_tank_bit_for_bit(tiny: LiquidDynamics) -> None:
    plain, one, again = (short_settle(tiny, w) for w in (None, 1, 1))
    assert np.array_equal(one, again)
    assert not np.array_equal(one, plain)
    assert np.array_equal(plain, tiny.solver.settle(seconds=0.4, damped_seconds=0.2))


def test_the_liquid_settles_each_world_once(
    tiny: LiquidDynamics, monkeypatch: pytest.MonkeyPatch
) -> None:
    settled: list[int | None] = []

    def settle(world: int | None = None) -> np.ndarray:
        settled.append(world)
        return initial_particles(tiny.scene, world)

    monkeypatch.setattr(tiny, "_rest", {})
    monkeypatch.setattr(tiny.solver, "settle", settle)
    starts = [tiny.initial_state(w) for w in (None, 1, 1, None, 2)]
    assert settled == [None, 1, 2]
    assert np.array_equal(starts[1], starts[2]) and np.array_equal(starts[0], starts[3])
    assert not np.array_equal(starts[0], starts[1])
    starts[1][:] = 0.0  # a caller's copy: the cached tank is untouched
    assert np.array_equal(tiny.initial_state(1), starts[2])
