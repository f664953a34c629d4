"""Each target's ridge angle recorded by the processor that sighted its pulses (issue 20 item 5, session 43).

evaluate took every 2D target's ridge angle (:func:`sarproc.product.theory.target_ridge_angle`) from the image's
pulses, a sighting of every pulse per target that backproject had made already for the target's theory and its
support's extent (twice: ``target_theory`` with the azimuth taper, ``support_extent`` without). backproject now
sights the pulses once per target (:func:`sarproc.product.theory.target_shape`) and records the angle in the
targets table (``ridge_angle``, degrees), fine-focus records it from its image's pulses, and evaluate reads it
where recorded (0: not recorded, as in older files, computed as before). The numbers are the same bits.
"""

from __future__ import annotations

import copy
import dataclasses
from pathlib import Path

import numpy as np
import pytest
import yaml

from sarproc.focus.backprojection import BackprojectParams, backproject, plan_backprojection
from sarproc.product import theory
from sarproc.product.frames import make_frame, targets_in_frame
from sarproc.product.io import read_product, write_product
from sarproc.product.model import as_target_table
from sarproc.quality.metrics import target_ridge_angles
from sarproc.simulation.scene import scene_from_mapping
from sarproc.simulation.simulate import simulate
from tests.quality.test_ground_plane_ridges import SCENE as GROUND_PLANE_SCENE

ROOT = Path(__file__).resolve().parents[2]

# tests/quality/test_ground_plane_ridges.py's sheared scene (ridges 36.9 deg apart in space) with a second target
# and no backproject key
SCENE = {
    **{key: value for key, value in GROUND_PLANE_SCENE.items() if key != "backproject"},
    "targets": {"frame": "ground_los", "points": [{"name": "A"}, {"name": "B", "azimuth": "6 m", "range": "-5 m"}]},
}
PARAMS = BackprojectParams(
    azimuth_extent=30.0, range_extent=40.0, azimuth_spacing=0.2, range_spacing=0.15, margin_cells=0
)


@pytest.fixture(scope="module")
def raw():
    return simulate(scene_from_mapping(SCENE))


@pytest.fixture(scope="module")
def image(raw):
    return backproject(raw, PARAMS)


def _theory_tuple(per_axis):
    return [dataclasses.astuple(t) for t in per_axis]


def _same(a, b) -> bool:
    """Equal bit for bit (NaNs where NaNs)."""
    return np.array_equal(np.asarray(a, float), np.asarray(b, float), equal_nan=True)


@pytest.mark.parametrize("window", ["none", "hamming"])
@pytest.mark.parametrize("beam", [False, True])
def test_one_sighting_gives_the_theory_the_extent_and_the_angle_bit_for_bit(raw, window, beam):
    radar = dataclasses.replace(raw.radar, azimuth_beamwidth=0.0 if not beam else 0.02)
    frame = make_frame("ground_los", radar)
    at = targets_in_frame(raw.targets, frame)
    pos = raw.aux["platform_position"]
    taper = theory.sample_taper(window, len(pos))
    for i in range(len(at)):
        coords = (float(at["azimuth"][i]), float(at["range"][i]))
        shape = theory.target_shape(radar, pos, pos, frame, coords, "hamming", taper, frame.metric())
        own = theory.target_theory(radar, pos, pos, frame, coords, range_window="hamming", taper=taper)
        assert _same(np.ravel(_theory_tuple(shape.theory)), np.ravel(_theory_tuple(own)))
        assert _same(shape.extent, theory.support_extent(radar, pos, pos, frame, coords))
        assert _same(shape.ridge_angle, theory.target_ridge_angle(radar, pos, pos, frame, coords, frame.metric()))
        assert 30 < shape.ridge_angle < 45  # sheared: the stored angle is not the slant plane's 90
    no_metric = theory.target_shape(radar, pos, pos, frame, coords, taper=taper)
    assert np.isnan(no_metric.ridge_angle)


def test_backproject_records_the_angle_evaluate_computed_from_the_pulses(image, tmp_path):
    recorded = image.targets["ridge_angle"]
    assert recorded == pytest.approx([36.86, 36.07], abs=0.01)  # sheared: not the slant plane's 90
    assert _same(recorded, theory.image_ridge_angles(image, recorded=False))
    # through the file: the field and its unit
    path = tmp_path / "image.h5"
    write_product(path, image)
    back = read_product(path)
    assert _same(back.targets["ridge_angle"], recorded)
    # evaluate reads it without sighting the pulses again
    with pytest.MonkeyPatch.context() as mp:

        def refused(*args, **kwargs):
            raise AssertionError("the pulses sighted again")

        mp.setattr(theory, "target_ridge_angle", refused)
        assert _same(target_ridge_angles(back), recorded)
    # an older file (no field) or an unrecorded row: computed from the pulses, the same numbers
    old = dataclasses.replace(image, targets=image.targets.copy())
    old.targets["ridge_angle"] = [0.0, recorded[1]]
    assert _same(target_ridge_angles(old), recorded)
    lacking = np.dtype([(n, image.targets.dtype[n]) for n in image.targets.dtype.names if n != "ridge_angle"])
    table = np.zeros(len(image.targets), lacking)
    for n in lacking.names:
        table[n] = image.targets[n]
    converted = as_target_table(table)
    assert np.all(converted["ridge_angle"] == 0)
    assert _same(target_ridge_angles(dataclasses.replace(image, targets=converted)), recorded)


def test_the_plan_sights_each_target_once(raw, monkeypatch):
    """backproject's plan took each target's support twice (the theory's, tapered; the grid's extent, untapered);
    one sighting of the pulses per target now gives both and the ridge angle."""
    calls = []
    sighting = theory._sighting

    def counted(*args, **kwargs):
        calls.append(1)
        return sighting(*args, **kwargs)

    monkeypatch.setattr(theory, "_sighting", counted)
    for window in ("none", "hamming"):
        calls.clear()
        plan = plan_backprojection(raw, dataclasses.replace(PARAMS, azimuth_window=window))
        assert len(calls) == len(raw.targets)
        assert np.all(plan.targets["ridge_angle"] > 30)


def test_a_table_moved_to_another_frame_forgets_its_angle(image):
    moved = targets_in_frame(image.targets, make_frame("squint", image.radar))
    assert np.all(moved["ridge_angle"] == 0) and np.all(image.targets["ridge_angle"] > 0)


def test_fine_focus_records_the_angle_evaluate_computed_from_the_pulses():
    from sarproc.focus.squint_deramp.coarse_focus import CoarseFocusParams, coarse_focus
    from sarproc.focus.squint_deramp.fine_focus import FineFocusParams, fine_focus
    from sarproc.focus.squint_deramp.preprocess import PreprocessParams, preprocess
    from sarproc.product.config import build

    cfg = yaml.safe_load((ROOT / "configs" / "an2012_exp1_small.yaml").read_text())
    cfg = copy.deepcopy(cfg)
    cfg["radar"]["prf"] = "2000 Hz"
    cfg["targets"]["points"] = [p for p in cfg["targets"]["points"] if p["name"] in ("C", "NE")]
    stages = ("preprocess", "coarse_focus", "fine_focus")
    raw = simulate(scene_from_mapping({k: v for k, v in cfg.items() if k not in stages}))
    p = preprocess(raw, build(PreprocessParams, cfg.get("preprocess") or {}))
    c = coarse_focus(p, build(CoarseFocusParams, cfg.get("coarse_focus") or {}))
    img = fine_focus(c, build(FineFocusParams, {**(cfg.get("fine_focus") or {}), "flow": 1}))
    recorded = img.targets["ridge_angle"]
    assert np.all(recorded > 89.9)  # the squint frame is a slant plane: 90 within 0.1 deg
    assert _same(recorded, theory.image_ridge_angles(img, recorded=False))
