"""Ridges of a ground-plane image whose depression angle changes along the aperture (Session 41 new-user trial).

A 45 deg squinted Ku-band spotlight at a steep depression (800 m over 1.2 km), backprojected onto a ground_los
grid: along the aperture the range, hence the depression angle, changes, so the ground-projected azimuth sweep
gains a ground-range component and the support is a parallelogram whose ridges make 37 deg in space, not 90.
evaluate took a SAR support's ridges as perpendicular in space and replaced the second one found: the azimuth
cut ran 36 deg off the azimuth axis (IRW/theory 1.91) and the range cut across the range ridge (0.33), every
target a residual misfit. The angle between the ridges is now each target's own theory's
(:func:`sarproc.product.theory.target_ridge_angle`); slant-plane frames keep 90.
"""

from __future__ import annotations

import pytest

from sarproc.focus.backprojection import BackprojectParams, backproject
from sarproc.product.frames import make_frame, targets_in_frame
from sarproc.product.theory import support_extent, target_ridge_angle
from sarproc.quality.metrics import EvaluateParams, evaluate_product, target_ridge_angles
from sarproc.simulation.scene import scene_from_mapping
from sarproc.simulation.simulate import simulate

SCENE = {
    "radar": {
        "carrier_frequency": "16 GHz",
        "bandwidth": "200 MHz",
        "pulse_duration": "1 us",
        "range_sampling_rate": "240 MHz",
        "prf": "250 Hz",
    },
    "platform": {"velocity": "80 m/s", "altitude": "800 m"},
    "geometry": {"reference_range": "1.2 km", "squint": "45 deg"},
    "acquisition": {"mode": "spotlight", "aperture_time": "0.6 s"},
    "backproject": {},  # the stage that unfolds the PRF's azimuth fold
    "targets": {"frame": "ground_los", "points": [{"name": "A"}]},
}
# finer than the default grid along range: the sheared support spans more range frequency than the ridge's band
PARAMS = BackprojectParams(
    azimuth_extent=30.0, range_extent=40.0, azimuth_spacing=0.2, range_spacing=0.15, margin_cells=0
)


@pytest.fixture(scope="module")
def image():
    return backproject(simulate(scene_from_mapping(SCENE)), PARAMS)


def test_the_theory_puts_the_ridges_37_deg_apart_and_90_at_broadside(image):
    (angle,) = target_ridge_angles(image)
    assert angle == pytest.approx(36.9, abs=0.5)
    # broadside, the range and the depression angle stand still at the aperture centre: perpendicular ridges
    raw = simulate(scene_from_mapping({**SCENE, "geometry": {"reference_range": "1.2 km", "squint": "0 deg"}}))
    frame = make_frame("ground_los", raw.radar)
    pos = raw.aux["platform_position"]
    at = targets_in_frame(raw.targets, frame)
    coords = (float(at["azimuth"][0]), float(at["range"][0]))
    assert target_ridge_angle(raw.radar, pos, pos, frame, coords, frame.metric()) == pytest.approx(90, abs=0.1)


def test_cuts_follow_the_ridges_and_match_their_theory(image):
    target = evaluate_product(image, EvaluateParams()).target("A")
    for ax in target.axes:
        assert ax.irw_ratio == pytest.approx(1.0, abs=0.02), ax.axis
        assert ax.pslr_db == pytest.approx(ax.pslr_theory_db, abs=0.3), ax.axis
        assert ax.islr_db == pytest.approx(ax.islr_theory_db, abs=0.3), ax.axis


def test_a_polar_format_images_rectangle_keeps_perpendicular_ridges(image):
    """pfa2 resamples the support onto a rectangle of the frame's k axes (attribute support_rectangle): its
    edges are perpendicular whatever the pulses' geometry, so no angle is taken from the pulses."""
    import dataclasses

    import numpy as np

    rect = dataclasses.replace(image, attrs={**image.attrs, "support_rectangle": [0.0, 1.0, 0.0, 1.0]})
    assert np.isnan(target_ridge_angles(rect)).all()


def test_the_default_grid_samples_the_sheared_support_without_wrapping():
    """backproject's default spacing was the ridge IRW / oversample: 0.42 m in range, 2.37 samples/m, where the
    sheared support reaches 2.83 cycles/m along range: it wrapped, and evaluate's band-limited chips misread it.
    Each axis now samples at least SUPPORT_WRAP_MARGIN x the widest target support's extent along it."""
    import numpy as np

    from sarproc.focus.backprojection import SUPPORT_WRAP_MARGIN

    raw = simulate(scene_from_mapping(SCENE))
    image = backproject(raw, BackprojectParams())
    frame = make_frame(image.attrs["frame"]["name"], raw.radar)
    at = targets_in_frame(raw.targets, frame)
    pos = raw.aux["platform_position"]
    extent = support_extent(raw.radar, pos, pos, frame, (float(at["azimuth"][0]), float(at["range"][0])))
    assert extent[1] == pytest.approx(2.83, abs=0.05)
    for a, d in enumerate(image.dims):
        assert abs(float(np.diff(image.coords[d][:2])[0])) <= 1 / (SUPPORT_WRAP_MARGIN * extent[a]) * (1 + 1e-9), d
    target = evaluate_product(image, EvaluateParams()).target("A")
    for ax in target.axes:
        assert ax.irw_ratio == pytest.approx(1.0, abs=0.02), ax.axis
        assert ax.pslr_db == pytest.approx(ax.pslr_theory_db, abs=0.3), ax.axis
