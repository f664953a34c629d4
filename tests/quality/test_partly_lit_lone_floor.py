"""A partly lit rect-beam target under Hamming fitted alone under -50 dB (issue 20 item 1; docs/product.md,
"Lone models of partly lit targets").

Campaign scene 23 (scripts/evaluate_campaign.py --scenes 24 --seed 1: rect beam, Hamming both axes, 22.83 deg
squint): T3, 94 % lit, simulated and backprojected alone on the scene's grid. Its azimuth band is a Hamming
segment cut by the beam's edge: its theory's two spectral orders leave -28.5 dB beside it (a misfit), and the
widths' search on two orders finds nothing better. One order more than the theory's, for a misfitted lone
target, fits it to -68.6 dB. And a -45 dB ghost beside it is listed once, at its level and place.
"""

from __future__ import annotations

import dataclasses

import pytest
from conftest import CAMPAIGN_STRIPMAP, assert_ghost_listed_once, merge, with_ghost

from sarproc.focus.backprojection import BackprojectParams, backproject
from sarproc.quality.metrics import EvaluateParams, evaluate_product
from sarproc.simulation.scene import scene_from_mapping
from sarproc.simulation.simulate import simulate

# scene 23's three targets: T3 alone, the others at amplitude 0 (they set the image grid, as in the campaign)
POINTS = [
    {"name": "T1", "azimuth": "20.36 m", "range": "-29.431 m", "amplitude": 0.0},
    {"name": "T2", "azimuth": "-26.676 m", "range": "-5.165 m", "amplitude": 0.0},
    {"name": "T3", "azimuth": "-26.142 m", "range": "1.105 m", "amplitude": 0.731},
]
SCENE = merge(
    CAMPAIGN_STRIPMAP,
    {
        "geometry": {"squint": "22.83 deg"},
        "effects": {"antenna": {"pattern": "rect"}},
        "targets": {"points": POINTS},
    },
)
HAMMING = BackprojectParams(frame="zero_doppler", margin_cells=28, range_window="hamming", azimuth_window="hamming")
NAMES = [p["name"] for p in POINTS]
# beside T3: 6 m on in azimuth, 4 m in range, off both its ridges (azimuth -26.142 m, range 1.105 m)
GHOST = {"name": "G", "azimuth": "-20.1 m", "range": "5.1 m", "amplitude": 0.5}
GHOST_DB = -45.0


def _only(image, name):
    names = [str(n.decode() if isinstance(n, bytes) else n) for n in image.targets["name"]]
    return dataclasses.replace(image, targets=image.targets[[n == name for n in names]])


@pytest.fixture(scope="module")
def lone():
    return backproject(simulate(scene_from_mapping(SCENE)), HAMMING, grid_targets=NAMES)


def test_a_partly_lit_rect_beam_target_is_fitted_under_minus_50_db(lone):
    """Main: T3 a misfit, floor -28.5 dB."""
    rep = evaluate_product(_only(lone, "T3"), EvaluateParams())
    assert rep.residual.misfit_targets == ()
    assert rep.residual.floor_db <= -50.0
    # what is listed, if anything, is the far ridge's residue (-66.9..-67.5 dB, 93-131 cells out), not a ghost
    assert rep.false_targets is not None
    assert all(e.pixel_level_db <= -60.0 for e in rep.false_targets.entries)


def test_a_ghost_beside_the_partly_lit_target_is_listed(lone):
    scene = merge(SCENE, {"targets": {"points": [dict(p, amplitude=0.0) for p in POINTS] + [GHOST]}})
    ghost = backproject(simulate(scene_from_mapping(scene)), HAMMING, grid_targets=NAMES)
    rep = evaluate_product(_only(with_ghost(lone, ghost, GHOST_DB), "T3"), EvaluateParams())
    assert rep.residual.misfit_targets == ()
    assert rep.residual.floor_db <= -50.0
    # over the far ridge's residue (above)
    assert_ghost_listed_once(rep, lone, ghost, GHOST_DB, above_db=-60.0)
