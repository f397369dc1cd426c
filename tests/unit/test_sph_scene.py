"""Scene presets, energies and the NumPy geometry of the PCISPH solver."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from app.core.liquid import pcisph
from app.core.liquid.scene import (
    FLUIDS,
    VISCOUS_STEP,
    Scene,
    cfl_substeps,
    initial_particles,
    kinetic_energy,
    potential_energies,
    tilt_tank,
    viscous_substeps,
)
from app.core.liquid.sph_grid import (
    make_grid,
    pcisph_delta,
    sort_by_cell,
    wall_particles,
    wall_volumes,
)
from app.liquid.validation import martin_moyce_front


@pytest.mark.parametrize(
    ("preset", "lo", "hi"), [("tiny", 1500, 2500), ("small", 7000, 9000), ("paper", 38000, 46000)]
)
def test_presets_have_the_documented_sizes(preset: str, lo: int, hi: int) -> None:
    scene = tilt_tank(preset)
    assert lo <= len(initial_particles(scene)) <= hi
    assert scene.n_controls == 3
    assert scene.frames_per_clip == 10 and scene.fps == 30


def test_scene_round_trips_through_json() -> None:
    scene = tilt_tank("small")
    again = Scene.from_dict(json.loads(json.dumps(scene.to_dict())))
    assert again == scene


def test_controls_tilt_gravity_about_the_viewing_axis() -> None:
    g = np.asarray(tilt_tank("tiny").gravity)
    assert np.allclose(np.linalg.norm(g, axis=1), 9.81)
    assert g[0, 0] == 0 and g[1, 0] < 0 < g[2, 0]
    assert np.allclose(np.degrees(np.arctan2(g[:, 0], -g[:, 1])), [0, -30, 30])
    assert np.all(g[:, 2] == 0)


def test_substeps_satisfy_the_cfl_condition() -> None:
    scene = tilt_tank("small")
    speed = math.sqrt(2 * 9.81 * scene.tank.hi[1])
    assert scene.dt * speed <= 0.4 * scene.spacing
    assert cfl_substeps(0.01, 1.0, 30) == 9


@pytest.mark.parametrize(("preset", "substeps"), [("tiny", 12), ("small", 19), ("paper", 33)])
def test_the_low_fluid_is_the_scene_graphs_were_grown_with(preset: str, substeps: int) -> None:
    scene = tilt_tank(preset, "low")
    assert scene == tilt_tank(preset)
    assert scene.name == f"tilt-tank/{preset}" and scene.substeps == substeps
    assert (scene.viscosity, scene.wall_viscosity) == (1e-3, 5e-4)


@pytest.mark.parametrize("preset", ["tiny", "small", "paper"])
def test_the_high_fluid_differs_only_in_the_fluid_table(preset: str) -> None:
    low, high = tilt_tank(preset).to_dict(), tilt_tank(preset, "high").to_dict()
    changed = {key for key in low if low[key] != high[key]}
    assert changed <= {"name", "viscosity", "wall_viscosity", "viscosity_steps", "target"}
    assert high["name"] == f"tilt-tank/{preset}-high"
    assert (high["viscosity"], high["wall_viscosity"], tilt_tank(preset, "high").target) == (
        FLUIDS["high"].viscosity,
        FLUIDS["high"].wall_viscosity,
        FLUIDS["high"].target,
    )
    assert high["viscosity"] >= 10 * low["viscosity"]
    # the CFL's substeps for both; the viscosity takes steps of its own inside them, as
    # many as its explicit bound needs and no more than one substep's worth beyond it
    steps, needed = high["viscosity_steps"], viscous_substeps(low["spacing"], 1e-2, 30)
    assert high["substeps"] == low["substeps"] and low["viscosity_steps"] == 1
    assert steps * high["substeps"] >= needed > (steps - 1) * high["substeps"]


@pytest.mark.parametrize("fluid", list(FLUIDS))
@pytest.mark.parametrize("preset", ["tiny", "small", "paper"])
def test_every_scene_keeps_the_explicit_viscosity_stable(preset: str, fluid: str) -> None:
    scene = tilt_tank(preset, fluid)
    step = scene.dt / scene.viscosity_steps
    assert step <= VISCOUS_STEP * scene.spacing**2 / scene.viscosity


def test_viscous_bound_matches_the_largest_eigenvalue_of_the_viscosity_operator() -> None:
    """Power iteration on the NumPy twin: |lambda_max| dt_visc <= 0.5 for the high fluid.

    The viscosity term is linear in the velocities, so a_visc = A v; explicit steps are
    stable for dt |lambda_max(A)| < 2, and VISCOUS_STEP keeps a factor four of margin.
    """
    scene = tilt_tank("tiny", "high")
    pos = initial_particles(scene)[:, :3].astype(np.float64)
    walls = wall_particles(scene)
    psi = wall_volumes(walls, scene)
    nb = pcisph.find_neighbours(pos, walls, scene.support)
    v = np.random.default_rng(0).normal(size=pos.shape)
    for _ in range(60):
        a = pcisph.viscous_accel(pos, v, nb, walls, psi, scene)
        lam = float(np.sum(a * v) / np.sum(v * v))
        v = a / np.linalg.norm(a)
    assert lam < 0
    assert 0.3 < abs(lam) * scene.dt / scene.viscosity_steps <= 0.5


def test_an_unknown_fluid_is_refused() -> None:
    with pytest.raises(ValueError, match="unknown fluid 'bogus'"):
        tilt_tank("tiny", "bogus")


def test_energies() -> None:
    scene = tilt_tank("tiny")
    state = initial_particles(scene)
    assert kinetic_energy(scene, state) == 0.0
    state[:, 3] = 2.0
    mass = scene.particle_mass * len(state)
    assert kinetic_energy(scene, state) == pytest.approx(0.5 * mass * 4.0, rel=1e-6)
    v = potential_energies(scene, state)
    lifted = state.copy()
    lifted[:, 1] += 0.1
    # lifting by 0.1 m costs m g 0.1 under the level control, m g cos(30) 0.1 tilted
    dv = potential_energies(scene, lifted) - v
    c = math.cos(math.pi / 6)
    assert dv == pytest.approx(mass * 9.81 * 0.1 * np.array([1, c, c]))


def test_sort_by_cell_is_stable_and_complete() -> None:
    scene = tilt_tank("tiny")
    pos = initial_particles(scene)[:, :3]
    grid = make_grid(scene)
    order, start = sort_by_cell(pos, grid)
    assert sorted(order.tolist()) == list(range(len(pos)))
    assert start[-1] == len(pos) and np.all(np.diff(start) >= 0)


def test_walls_fill_the_density_of_the_first_layer() -> None:
    """Calibrated Akinci volumes: lattice particles at walls, edges, corners near rho0.

    Without the calibration the first layer is 6 % over-dense (corners 15 %).
    """
    scene = tilt_tank("tiny")
    pos = initial_particles(scene)[:, :3]
    walls = wall_particles(scene)
    psi = wall_volumes(walls, scene)
    nb = pcisph.find_neighbours(pos, walls, scene.support)
    rho = pcisph.density(pos, nb, walls, psi, scene)
    below_surface = pos[:, 1] < pos[:, 1].max() - scene.support
    rel = rho[below_surface] / scene.rest_density - 1
    assert np.max(np.abs(rel)) < 0.02 and abs(np.mean(rel)) < 0.002


def test_pcisph_delta_scales_with_inverse_dt_squared() -> None:
    scene = tilt_tank("tiny")
    from dataclasses import replace

    halved = replace(scene, substeps=2 * scene.substeps)
    assert pcisph_delta(halved) == pytest.approx(4 * pcisph_delta(scene), rel=1e-9)


def test_kernel_is_normalised() -> None:
    h = 0.04
    dx = h / 8
    axis = np.arange(-8, 9) * dx
    d = np.stack(np.meshgrid(axis, axis, axis), axis=-1).reshape(-1, 3)
    assert np.sum(pcisph.cubic_kernel(np.linalg.norm(d, axis=1), h)) * dx**3 == pytest.approx(
        1, 1e-3
    )


def test_martin_moyce_data_loads() -> None:
    data = martin_moyce_front()
    assert data.shape[1] == 2 and len(data) >= 10
    assert np.all(np.diff(data[:, 0]) > 0) and data[0, 1] > 1.0
