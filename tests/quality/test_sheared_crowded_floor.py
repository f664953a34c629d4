"""The residual floor of sheared targets on the trial's 3x4 grid (issue 20 item 1, docs/cli.md "Session 44: crowded
floor (crowd44)").

Row 7d's scene (a 45 deg squinted Ku-band spotlight at 800 m over 1.2 km, ground_los, 600 Hz PRF, a 3x4 grid 33 m x
26 m apart) backprojected onto its default grid (340 x 390): the ridges run out 40 nulls and more. A lone sheared
target's warp and cubic were fitted from none on its whole ridge strips, where Gauss-Newton does not converge (the
phase errors far out are cycles), and the gates rejected both: one target alone at the grid's middle left -37.95 dB
(uniform) / -41.04 dB (Hamming), the 3x4 -32.78 / -36.39 dB. They are now fitted first within
``CUBIC_NEAR_NULLS`` of the peak, then on the whole strips with the warp, the chirp, the widths and the keystone
refined in the cubic's Gauss-Newton (:func:`sarproc.quality.residual._fit_cubics`).
"""

from __future__ import annotations

from collections.abc import Callable

import pytest

from sarproc.focus.backprojection import BackprojectParams, backproject
from sarproc.quality.metrics import EvaluateParams, evaluate_product
from sarproc.simulation.scene import scene_from_mapping
from sarproc.simulation.simulate import simulate

RADAR = {
    "carrier_frequency": "16 GHz",
    "bandwidth": "200 MHz",
    "pulse_duration": "1 us",
    "range_sampling_rate": "240 MHz",
    "prf": "600 Hz",
}
AZIMUTHS, RANGES = (-33, 0, 33), (-39, -13, 13, 39)


def scene(amplitude: Callable[[int, int], float]) -> dict:
    """Row 7d's 3x4 grid as points (amplitude(i, j) each), with its range gate."""
    points = [
        {"name": f"T{i:02d}_{j:02d}", "azimuth": f"{a} m", "range": f"{r} m", "amplitude": amplitude(i, j)}
        for i, a in enumerate(AZIMUTHS)
        for j, r in enumerate(RANGES)
    ]
    return {
        "radar": RADAR,
        "platform": {"velocity": "80 m/s", "altitude": "800 m"},
        "geometry": {"reference_range": "1.2 km", "squint": "45 deg"},
        "acquisition": {"mode": "spotlight", "aperture_time": "0.6 s"},
        "targets": {"frame": "ground_los", "points": points},
        "effects": {"range_gate": {"pulses_per_step": 16}},
    }


# the 3x4's default image grid (340 x 390 samples, centred on the grid's middle), for T01_01 alone
GRID = {
    "azimuth_spacing": 0.28709,
    "azimuth_center": 0.0,
    "azimuth_extent": 97.611,
    "range_spacing": 0.30975,
    "range_center": 894.427,
    "range_extent": 120.802,
    "margin_cells": 0,
}


@pytest.fixture(scope="module")
def lone_raw():
    """T01_01 alone."""
    one = scene(lambda i, j: 1.0)
    one["targets"]["points"] = [p for p in one["targets"]["points"] if p["name"] == "T01_01"]
    return simulate(scene_from_mapping(one))


@pytest.mark.parametrize(("window", "floor_db"), [("none", -60.0), ("hamming", -52.0)])
def test_a_lone_sheared_target_on_a_large_grid_has_its_far_ridges_subtracted(lone_raw, window, floor_db):
    """main: floor -37.95 dB uniform (warp 0.867 and cubic 0.995 of the misfit, both rejected), -41.04 Hamming;
    now -65.76 / -55.31 (in process, 2026-12-07)."""
    image = backproject(lone_raw, BackprojectParams(frame="ground_los", range_window=window, **GRID))
    report = evaluate_product(image, EvaluateParams())
    assert report.residual.floor_db < floor_db
    assert report.false_target.level_db < -50.0


@pytest.mark.slow
def test_the_crowded_sheared_grid_floor_is_lower():
    """The 3x4 itself, uniform: main floor -32.78 dB, false target -31.57; now -37.45 / -36.55 (the targets' shared
    ridge lines are fitted one target at a time: docs/cli.md says what is left)."""
    image = backproject(simulate(scene_from_mapping(scene(lambda i, j: 1.0))), BackprojectParams(frame="ground_los"))
    report = evaluate_product(image, EvaluateParams())
    assert report.residual.floor_db < -36.5
    assert report.false_target.level_db < -35.5


@pytest.mark.slow
def test_targets_on_a_shared_ridge_line_are_fitted_jointly():
    """The 3x4, Hamming range window: each column's three targets share their azimuth ridge, T00_03 and T01_02 their
    range ridge; fitted one at a time, the others subtracted, main floors at -38.50 dB (false target -37.22); with
    each such pair fitted jointly on the union of their strips (:func:`sarproc.quality.residual._fit_ridge_lines`)
    -40.07 / -39.95 (in process, 2026-12-07; docs/cli.md "Session 45: shared ridge lines"); opt-in
    (EvaluateParams.joint_ridge_lines) for its CPU."""
    raw = simulate(scene_from_mapping(scene(lambda i, j: 1.0)))
    image = backproject(raw, BackprojectParams(frame="ground_los", range_window="hamming"))
    report = evaluate_product(image, EvaluateParams(joint_ridge_lines=True))
    assert report.residual.floor_db < -39.5
    assert report.false_target.level_db < -39.0
