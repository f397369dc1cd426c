"""OpenCL PCISPH kernels against their NumPy twins, determinism and short physics runs."""

from __future__ import annotations

import numpy as np
import pyopencl as cl
import pytest

from app.core.liquid import pcisph as twin
from app.core.liquid.scene import initial_particles, kinetic_energy, tilt_tank
from app.kernels.context import runtime
from app.kernels.launch_shapes import GPU_SCAN_BLOCK
from app.kernels.pcisph import PcisphSolver, iterations_used
from app.kernels.pcisph_kernels import PcisphKernels
from app.kernels.sph_layout import MAX_NEIGHBOURS, MAX_WALL_NEIGHBOURS
from app.liquid import validation as v


@pytest.fixture(scope="module")
def tiny_rest() -> tuple[PcisphSolver, np.ndarray]:
    sim = PcisphSolver(tilt_tank("tiny"))
    return sim, sim.settle(seconds=2.0, damped_seconds=1.0)


def test_runtime_is_per_process_and_memoises_programs() -> None:
    rt = runtime()
    assert runtime() is rt
    assert rt.program("pcisph.cl") is rt.program("pcisph.cl")


@pytest.mark.parametrize("fluid", ["low", "high"])
def test_kernels_match_numpy_twins(fluid: str) -> None:
    """Every kernel, the viscous step included (two of them a substep for ``high``)."""
    result = v.check_twins(tilt_tank("tiny", fluid))
    errors = result["relative_errors"]
    assert errors["sort_order"] == 0.0
    assert all(e < 1e-4 for e in errors.values()), errors


def test_neighbour_lists_match_twin() -> None:
    scene = tilt_tank("tiny")
    state = initial_particles(scene)
    state[:, :3] += np.random.default_rng(1).normal(0, 0.1 * scene.spacing, (len(state), 3))
    k = PcisphKernels(scene, len(state))
    k.load(state)
    k.sort()
    k.find_neighbours()
    pos = k.read(k.pos, np.float32, 4)[:, :3]
    count = k.read(k.nb_count, np.int32)
    lists = k.read(k.nb, np.int32, MAX_NEIGHBOURS)
    expected = twin.find_neighbours(pos, k.walls, scene.support)
    per_particle = np.bincount(expected.fluid[:, 0], minlength=len(pos))
    # pairs within float32 rounding of h may fall either side; they carry zero weight
    assert np.max(np.abs(count - per_particle)) <= 2
    assert np.mean(count == per_particle) > 0.95
    i = int(np.argmax(count))
    assert set(lists[i, : count[i]]) == set(expected.fluid[expected.fluid[:, 0] == i, 1])
    assert k.overflowed() == 0


def test_the_cell_scan_in_blocks_is_the_scan_in_one_walk() -> None:
    """A GPU's scan (blocks of cells, three launches) gives the CPU's integers: the same
    cell starts, the cumulative sums of the counts, and the same sort."""
    scene = tilt_tank("tiny")
    state = initial_particles(scene)
    state[:, :3] += np.random.default_rng(2).normal(0, 0.1 * scene.spacing, (len(state), 3))
    sorted_by: dict[int | None, tuple[np.ndarray, ...]] = {}
    for block in (None, GPU_SCAN_BLOCK, 7, 1):
        k = PcisphKernels(scene, len(state), cells_per_scan=block)
        k.load(state)
        k.sort()
        n_cells = k.grid.n_cells
        start = np.empty(n_cells + 1, dtype=np.int32)
        cl.enqueue_copy(k.queue, start, k.start)
        cells = k.read(k.cell, np.int32)
        sorted_by[block] = (start, k.read(k.ids, np.int32), k.read(k.pos, np.float32, 4))
        expected = np.concatenate([[0], np.cumsum(np.bincount(cells, minlength=n_cells))])
        np.testing.assert_array_equal(start, expected)
    assert sorted_by[None][0].size > GPU_SCAN_BLOCK * 7  # several blocks, a partial last
    for block, arrays in sorted_by.items():
        for a, b in zip(arrays, sorted_by[None], strict=True):
            assert np.array_equal(a, b), block


@pytest.mark.parametrize("variant", ["-DPORTABLE_COMPACTION", "-DLANE_BUILD"])
def test_every_list_build_gives_the_same_lists(variant: str) -> None:
    """The AVX2 lane-permutation append, the portable prefix-sum one and a GPU's build
    of one candidate at a time agree."""
    scene = tilt_tank("tiny")
    state = initial_particles(scene)
    state[:, :3] += np.random.default_rng(4).normal(0, 0.1 * scene.spacing, (len(state), 3))
    found = []
    for options in ((), (variant,)):
        k = PcisphKernels(scene, len(state), build_options=options)
        k.load(state)
        k.sort()
        k.find_neighbours()
        count = k.read(k.nb_count, np.int32)
        lists = k.read(k.nb, np.int32, MAX_NEIGHBOURS)
        wall_count = k.read(k.wall_nb_count, np.int32)
        walls = k.read(k.wall_nb, np.int32, MAX_WALL_NEIGHBOURS)
        padded = (count + 7) // 8 * 8
        found.append(
            (
                count,
                wall_count,
                [row[:c].tolist() for row, c in zip(lists, padded, strict=True)],
                [row[:c].tolist() for row, c in zip(walls, wall_count, strict=True)],
            )
        )
        assert k.overflowed() == 0
    assert np.array_equal(found[0][0], found[1][0])
    assert np.array_equal(found[0][1], found[1][1])
    assert found[0][2] == found[1][2] and found[0][3] == found[1][3]
    assert found[0][1].max() > 0


def test_pressure_loop_geometry_matches_twin() -> None:
    """nonpressure_accel's stored grad W_ij scales per list slot, wall sums, padding."""
    scene = tilt_tank("tiny")
    state = initial_particles(scene)
    state[:, :3] += np.random.default_rng(3).normal(0, 0.1 * scene.spacing, (len(state), 3))
    n = len(state)
    k = PcisphKernels(scene, n)
    k.load(state)
    k.sort()
    k.find_neighbours()
    k.nonpressure_accel([scene.gravity[0]])
    pos = k.read(k.pos, np.float32, 4)[:, :3].astype(np.float64)
    count = k.read(k.nb_count, np.int32)[:, None]
    lists = k.read(k.nb, np.int32, MAX_NEIGHBOURS)
    scales = k.read(k.pair_scale, np.float32, MAX_NEIGHBOURS)
    slot = np.arange(MAX_NEIGHBOURS)[None, :]
    i, used = np.nonzero(slot < count)
    d = pos[i] - pos[lists[i, used]]
    expected = twin.cubic_kernel_gradient(d, np.linalg.norm(d, axis=1), scene.support)
    grads = d * scales[i, used, None]
    assert np.max(np.abs(grads - expected)) / np.max(np.abs(expected)) < 1e-5
    # padding up to a multiple of eight: the particle itself, with a zero gradient
    rows, pad = np.nonzero((slot >= count) & (slot < (count + 7) // 8 * 8))
    assert len(rows) > 0
    assert np.array_equal(lists[rows, pad], rows)
    assert not np.any(scales[rows, pad])
    nb = twin.find_neighbours(pos, k.walls, scene.support)
    wall_expected = twin.wall_gradient_sum(pos, nb.wall, k.walls, k.psi, scene)
    wall = k.read(k.wall_grad, np.float32, 4)[:, :3]
    assert np.max(np.abs(wall - wall_expected)) / np.max(np.abs(wall_expected)) < 1e-5


def test_loop_enqueued_ahead_equals_testing_every_iteration(
    tiny_rest: tuple[PcisphSolver, np.ndarray],
) -> None:
    """The iteration queued past convergence is a no-op: same state, same counts."""
    sim, rest = tiny_rest
    scene = sim.scene
    ahead, plain = PcisphSolver(scene), PcisphSolver(scene)
    ahead.kernels.load(rest)
    plain.kernels.load(rest)
    gravity = scene.gravity[1]
    k = plain.kernels
    for _ in range(2 * scene.substeps):
        (used,) = ahead.substep([gravity])
        k.sort()
        k.find_neighbours()
        k.nonpressure_accel([gravity])
        k.pressure_predict()
        k.reset_errors(scene.max_iterations)
        it = 0
        while it < scene.max_iterations:
            k.density_pressure(it)
            k.pressure_predict(0.0, it)
            it += 1
            if it >= scene.min_iterations and k.density_error(it - 1) < scene.eta:
                break
        k.advance()
        assert used == it
    for name, width in (("pos", 4), ("vel", 4), ("p", 1)):
        a = ahead.kernels.read(getattr(ahead.kernels, name), np.float32, width)
        b = k.read(getattr(k, name), np.float32, width)
        assert np.array_equal(a, b), name


def test_clips_are_bit_identical(tiny_rest: tuple[PcisphSolver, np.ndarray]) -> None:
    sim, rest = tiny_rest
    a_frames, a_end = sim.simulate_clip(rest, 2)
    b_frames, b_end = PcisphSolver(sim.scene).simulate_clip(rest, 2)
    assert a_frames.shape == (10, sim.n, 3) and a_frames.dtype == np.float32
    assert a_end.shape == (sim.n, 6)
    assert np.array_equal(a_frames, b_frames) and np.array_equal(a_end, b_end)
    assert not np.array_equal(a_frames[0], a_frames[-1])
    # a GPU's shapes on the CPU: the cell scan in blocks, lists built a candidate at a time
    for gpu_shaped in (
        PcisphKernels(sim.scene, sim.n, cells_per_scan=GPU_SCAN_BLOCK),
        PcisphKernels(sim.scene, sim.n, build_options=("-DLANE_BUILD",)),
    ):
        other = PcisphSolver(sim.scene)
        other.kernels = gpu_shaped
        c_frames, c_end = other.simulate_clip(rest, 2)
        assert np.array_equal(a_frames, c_frames) and np.array_equal(a_end, c_end)


@pytest.mark.parametrize("budget", [1, 3, 8])
def test_a_frame_queued_at_once_is_the_careful_frame(
    tiny_rest: tuple[PcisphSolver, np.ndarray], budget: int
) -> None:
    """Substeps queued a frame at once, with budgets that the loop outgrows (the frame
    is then run again the careful way) and budgets that leave no-op iterations, give the
    careful way's frames and iteration counts."""
    sim, rest = tiny_rest
    careful = PcisphSolver(sim.scene, queue_frames=False)
    ahead = PcisphSolver(sim.scene, queue_frames=True)
    ahead.budget = budget
    restored = []
    kernels = ahead.kernels
    kernels.restore_state = lambda: (restored.append(1), PcisphKernels.restore_state(kernels))
    a_frames, a_end = careful.run(rest, 1, 3)
    b_frames, b_end = ahead.run(rest, 1, 3)
    assert np.array_equal(a_frames, b_frames) and np.array_equal(a_end, b_end)
    assert ahead.stats.iteration_counts == careful.stats.iteration_counts
    assert ahead.stats.max_error == careful.stats.max_error
    assert min(careful.stats.iteration_counts) > 1
    assert not sim.queue_frames  # the careful way is every device's default (docs/sph.md)
    if budget == 1:  # too few for any substep: the first frame was put back, and the
        assert restored == [1]  # budget then grew to fit the frames after it


@pytest.mark.parametrize("queue_frames", [False, True])
def test_a_batch_of_clips_is_each_clip_alone(
    tiny_rest: tuple[PcisphSolver, np.ndarray], queue_frames: bool
) -> None:
    """Clips from two start states under three controls, in one launch sequence, give
    each clip's solo frames, end state and iteration counts bit for bit, the careful
    way and queued a frame at once (with a budget that one frame outgrows)."""
    sim, rest = tiny_rest
    solo = PcisphSolver(sim.scene, queue_frames=False)
    _, moving = solo.run(rest, 1, 2)
    states, controls = [rest, moving, rest], [2, 0, 1]
    alone = []
    for state, control in zip(states, controls, strict=True):
        solo.stats.iteration_counts.clear()
        frames, end = solo.run(state, control, 3)
        alone.append((frames, end, list(solo.stats.iteration_counts)))
    batch = PcisphSolver(sim.scene, queue_frames=queue_frames, batch=4)
    batch.budget = 2
    frames, ends = batch.run_batch(states, controls, 3)
    assert frames.shape == (3, 3, sim.n, 3) and ends.shape == (3, sim.n, 6)
    counts = np.array(batch.stats.iteration_counts).reshape(-1, 3)  # substep-major
    for c, (solo_frames, solo_end, solo_counts) in enumerate(alone):
        assert np.array_equal(frames[c], solo_frames) and np.array_equal(ends[c], solo_end)
        assert counts[:, c].tolist() == solo_counts
    # the clips' loops stop at different iterations: the batch holds the early ones still
    assert any(len(set(row)) > 1 for row in counts.tolist())


def test_a_batch_larger_than_the_buffers_is_refused(
    tiny_rest: tuple[PcisphSolver, np.ndarray],
) -> None:
    sim, rest = tiny_rest
    two = PcisphSolver(sim.scene, batch=2)
    with pytest.raises(ValueError, match="not 1 to 2 clips"):
        two.run_batch([rest] * 3, [0, 1, 2], 1)
    with pytest.raises(ValueError, match="2 states for 1 controls"):
        two.run_batch([rest] * 2, [0], 1)


def test_iterations_used_reads_where_each_loop_stopped() -> None:
    errors = np.array(
        [
            [0.05, 0.004, 0.002, 0.0, 0.0],  # below eta at the 2nd, but min 3: stops at 3
            [0.05, 0.03, 0.02, 0.009, 0.0],  # stops at 4
            [0.05, 0.03, 0.02, 0.012, 0.011],  # budget 5 reached: not converged
        ],
        dtype=np.float32,
    )
    assert iterations_used(errors[:2], 3, 0.01) == [3, 4]
    assert iterations_used(errors, 3, 0.01) is None
    assert iterations_used(errors[:2], 1, 0.01) == [2, 4]


def test_tilted_clip_stays_in_tank_and_moves_the_liquid(
    tiny_rest: tuple[PcisphSolver, np.ndarray],
) -> None:
    sim, rest = tiny_rest
    frames, end = sim.simulate_clip(rest, 1)
    lo, hi = np.asarray(sim.scene.tank.lo), np.asarray(sim.scene.tank.hi)
    assert np.all((frames >= lo) & (frames <= hi))
    # gravity tilted towards -x: the liquid's centre moves left and it gains energy
    assert end[:, 0].mean() < rest[:, 0].mean()
    assert kinetic_energy(sim.scene, end) > 10 * kinetic_energy(sim.scene, rest)


def test_hydrostatic_tank(tiny_rest: tuple[PcisphSolver, np.ndarray]) -> None:
    sim, rest = tiny_rest
    result = v.check_hydrostatic(sim, rest, seconds=1.0, gauge_seconds=1.0)
    assert result["contained"]
    assert result["mean_density_error"] < 0.01
    assert result["surface_drift"] < 0.5 * sim.scene.spacing
    # floor gauge (wall particles' load, averaged over 360 substeps) against rho0 g H
    assert result["bottom_pressure_error"] < 0.05, result
    assert result["floor_load_error"] < 0.05, result
    assert result["passed"]


def test_floor_force_is_newtons_third_law_of_the_wall_term() -> None:
    scene = tilt_tank("tiny")
    k = PcisphKernels(scene, 1)
    rng = np.random.default_rng(2)
    pos = rng.uniform(0.0, 0.1, (50, 3))
    p = rng.uniform(0.0, 2000.0, 50)
    nb = twin.find_neighbours(pos, k.walls, scene.support)
    walls_only = twin.Neighbours(np.zeros((0, 2), dtype=np.int64), nb.wall)
    on_fluid = twin.pressure_accel(pos, p, walls_only, k.walls, k.psi, scene)
    on_wall = twin.wall_pressure_forces(pos, p, nb.wall, k.walls, k.psi, scene)
    assert len(nb.wall) > 0
    total = on_wall.sum(axis=0)
    np.testing.assert_allclose(total, -scene.particle_mass * on_fluid.sum(axis=0), rtol=1e-9)


def test_dam_break_follows_martin_moyce() -> None:
    result = v.check_dam_break("tiny")
    assert result["contained"]
    assert result["max_relative_error"] < 0.10, result
