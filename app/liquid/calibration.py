"""Measure a liquid preset's constants and store them (``srg calibrate --preset small``).

Each fluid (``--fluid low|high``) has its own calibration: the constants below are
measured on the preset's scene with that fluid.

* **T0** (``rest_kinetic``): the largest kinetic energy over the last second of a 3 s
  settle (the scene's definition), unless the scene already carries a measured value.
* **w_e** (``energy_weight``): fitted so that ``dist_s ~ w_e dist_e`` over pairs of nearly-
  at-rest clips (paper section 5.1). Those clips start from the settled tank given a
  uniform horizontal push whose kinetic energy is 0, 1/2, 1, 2, 4 and 8 T0, and run
  under the level control, so their shapes and energies differ by about what separates
  "visually at rest" clips.
* **crowd_radius**: the median over clips of the pdist to the nearest other clip of the
  same control, in a depth-2 tree of clips from the settled tank plus the near-rest
  clips: the kernel of one visited vertex reaches its typical neighbours.
* **high_error_threshold**: the dist above which blends are mostly *visibly* wrong,
  measured on the pictures players see (``app.liquid.threshold``,
  ``docs/threshold.md``). Stored with how it was measured (``visible_threshold``) and,
  for comparison, the former definition (``percentile_threshold``): the 90th percentile
  over the clips above of the best blend error to another clip of the same control.
  ``srg calibrate --only threshold`` re-measures it alone (:func:`calibrate_threshold`).
"""

from __future__ import annotations

import itertools
import json
from collections.abc import Callable
from typing import Any

import numpy as np

from app.core.graph.dynamics import ClipFeatures
from app.core.liquid.liquid_metrics import (
    LiquidMetricParams,
    clip_distance,
    descriptor_distance,
    energy_distance,
    fit_energy_weight,
    shape_distance,
)
from app.liquid.adapter import (
    CALIBRATION_DIR,
    LiquidCalibration,
    LiquidDynamics,
    calibration_json,
    calibration_path,
)
from app.liquid.devices import LiquidDevices
from app.liquid.threshold import ThresholdStudy, measure_blends, measure_visible_threshold
from app.liquid.validation import measure_rest_kinetic

#: kinetic energies of the pushed near-rest clips, in units of T0
PUSH_ENERGIES = (0.0, 0.5, 1.0, 2.0, 4.0, 8.0)
HIGH_ERROR_PERCENTILE = 90.0


def pushed(dyn: LiquidDynamics, rest: np.ndarray, energy: float) -> np.ndarray:
    """The rest state plus a uniform x velocity carrying ``energy`` (J) more kinetic energy."""
    state = rest.copy()
    mass = dyn.scene.particle_mass * len(state)
    state[:, 3] += np.float32(np.sqrt(2.0 * energy / mass))
    return state


def _nearest(values: np.ndarray, controls: list[int]) -> np.ndarray:
    """Per row, the smallest value to another clip of the same control."""
    same = np.equal.outer(controls, controls) & ~np.eye(len(controls), dtype=bool)
    return np.where(same, values, np.inf).min(axis=1)


def calibrate(
    preset: str,
    fluid: str,
    progress: Callable[[str], None] | None = None,
    *,
    devices: LiquidDevices,
) -> dict:
    """Measure T0, w_e, the crowd radius and the high-error threshold; write the JSON.

    Returns the stored dict (also written to ``app/data/calibration/<preset>.json``, or
    ``<preset>-<fluid>.json`` for a fluid other than ``low``). Takes about 30 s on
    ``tiny`` and 3 min on ``small`` (2 CPU cores) before the threshold, which adds
    4-8 min on ``tiny`` and up to 18 min on ``small`` (2 loaded cores); the high fluid
    takes longer (more substeps, see ``app.core.liquid.scene.viscous_substeps``).
    """
    probe = LiquidDynamics(preset, fluid, LiquidCalibration(0.0, 1.0, 0.0, 0.0), devices=devices)
    # T0 over the last second of a 3 s settle
    rest, measured_t0 = measure_rest_kinetic(probe.solver, probe.solver.settle(seconds=2.0))
    t0 = probe.scene.rest_kinetic or measured_t0
    dyn = LiquidDynamics(preset, fluid, LiquidCalibration(t0, 1.0, 0.0, 0.0), devices=devices)

    near_rest = [dyn.features(dyn.simulate(pushed(dyn, rest, f * t0), 0)) for f in PUSH_ENERGIES]
    pairs = list(itertools.combinations(near_rest, 2))
    shapes = np.array(
        [shape_distance(a.occupancy, b.occupancy, dyn.grid.voxel_volume) for a, b in pairs]
    )
    energies = np.array([energy_distance(a.energy(0), b.energy(0), t0) for a, b in pairs])
    w_e = fit_energy_weight(shapes, energies)

    tree: list[ClipFeatures] = []
    for first in range(dyn.n_controls):
        clip = dyn.simulate(rest, first)
        tree.append(dyn.features(clip))
        tree += [dyn.features(dyn.simulate(clip.end_state, c)) for c in range(dyn.n_controls)]
    clips = tree + near_rest
    controls = [c.control for c in clips]
    params = LiquidMetricParams(t0, w_e, dyn.grid.voxel_volume)
    dists = np.array(
        [
            [clip_distance(a, b, b.control, params) if a is not b else np.inf for b in clips]
            for a in clips
        ]
    )
    pdists = np.array([[descriptor_distance(a, b) for b in clips] for a in clips])
    crowd_radius = float(np.median(_nearest(pdists, controls)))
    percentile = float(np.percentile(_nearest(dists, controls), HIGH_ERROR_PERCENTILE))
    # the threshold applies to the dist of the final constants, so measure it with them
    measured = LiquidDynamics(
        preset, fluid, LiquidCalibration(t0, w_e, crowd_radius, 0.0), devices=devices
    )
    threshold, visible = measure_visible_threshold(measured, progress=progress)
    calibration = LiquidCalibration(
        rest_kinetic=t0,
        energy_weight=w_e,
        crowd_radius=crowd_radius,
        high_error_threshold=threshold,
    )
    details = {
        "measured_rest_kinetic": measured_t0,
        "near_rest_pairs": len(pairs),
        "near_rest_shape_distance_median": float(np.median(shapes)),
        "near_rest_energy_distance_median": float(np.median(energies)),
        "clips": len(clips),
        "pdist_median": float(np.median(pdists[np.triu_indices(len(clips), 1)])),
        "best_blend_dist_median": float(np.median(_nearest(dists, controls))),
        "percentile_threshold": percentile,
        "visible_threshold": visible,
    }
    CALIBRATION_DIR.mkdir(parents=True, exist_ok=True)
    text = calibration_json(preset, calibration, details, fluid)
    calibration_path(preset, fluid).write_text(text)
    return {"preset": preset, "fluid": fluid, **calibration.__dict__, **details}


def calibrate_threshold(
    preset: str,
    fluid: str,
    progress: Callable[[str], None] | None = None,
    *,
    devices: LiquidDevices,
) -> tuple[dict[str, Any], ThresholdStudy]:
    """Re-measure only the high-error threshold; every other stored value stays as it is.

    Uses the stored T0 and w_e (the dist the threshold applies to). The former
    percentile threshold is kept as ``percentile_threshold``: taken from the stored
    file, where a file without ``visible_threshold`` still holds it as
    ``high_error_threshold``. Returns the stored dict and the study (for figures).
    """
    path = calibration_path(preset, fluid)
    stored: dict[str, Any] = json.loads(path.read_text())
    study = measure_blends(LiquidDynamics(preset, fluid, devices=devices), progress=progress)
    if "percentile_threshold" not in stored and "visible_threshold" not in stored:
        stored["percentile_threshold"] = stored["high_error_threshold"]
    stored["high_error_threshold"] = study.threshold
    stored["visible_threshold"] = study.details
    path.write_text(json.dumps(stored, indent=2) + "\n")
    return stored, study
