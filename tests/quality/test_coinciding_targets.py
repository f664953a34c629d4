"""Targets that coincide in an image are one response there: the residual false-target level is not taken
(issue 20 items 1 and 5; docs/product.md, "Coinciding targets").

Paper 004's receiver images before elevation compression (make reproduce-004's image_channel14.h5) hold
targets 3, 6 and 7, 2 deg apart in elevation, on one pixel: a model per target on one response left the fits
crawling (evaluate 28.5 s CPU against array3d's 0.46 s) and residual figures that moved 2 dB with the last bits
of the arithmetic (docs/performance.md). Here analytic sinc images: a pair on one pixel, and the same pair 0.6
of a null apart (resolvable by the rule: its residual is taken).
"""

from __future__ import annotations

import numpy as np
from test_metrics import BW2, RES2, STEP2, axis_coords, separable_image, sinc_psf

from sarproc.quality.metrics import EvaluateParams, _Axis, coinciding_targets, evaluate_image
from sarproc.quality.residual import COINCIDE_NULLS

NULL = tuple(1.0 / b for b in BW2)  # null spacings, axis units


def _image(targets):
    coords = [axis_coords(160, STEP2[0]), axis_coords(180, STEP2[1])]
    phases = np.exp(1j * np.array([0.3, -2.0, 1.1][: len(targets)]))
    img = separable_image(coords, [sinc_psf(b) for b in BW2], targets, phases).astype(np.complex64)
    return img, coords


def test_a_pair_on_one_pixel_is_named_and_its_residual_not_taken():
    targets = [(0.0, 0.0), (0.0, 0.0), (20 * STEP2[0], -25 * STEP2[1])]
    img, coords = _image(targets)
    rep = evaluate_image(img, ("azimuth", "range"), coords, RES2, targets, names=["P", "Q", "R"])
    assert rep.residual is None and rep.false_targets is None
    assert "targets P and Q coincide" in rep.residual_note and "R" not in rep.residual_note.split("coincide")[0]
    assert rep.false_target == rep.false_target_guard
    # the guard-window figure is still a measurement: the sinc's own side lobes beyond the guard, about -35 dB
    assert rep.false_target.level_db < -30


def test_a_pair_over_half_a_null_apart_keeps_its_residual():
    apart = COINCIDE_NULLS + 0.1  # nulls in azimuth, beyond the rule's
    targets = [(0.0, 0.0), (apart * NULL[0], 0.0), (20 * STEP2[0], -25 * STEP2[1])]
    img, coords = _image(targets)
    rep = evaluate_image(
        img, ("azimuth", "range"), coords, RES2, targets, names=["P", "Q", "R"], params=EvaluateParams()
    )
    assert rep.residual_note is None and rep.residual is not None


def test_coinciding_groups_chain_and_stay_apart():
    axes = [_Axis("azimuth", -25.0, 0.5, 100, 0.886, 2.0), _Axis("range", -25.0, 0.5, 100, 0.886, 2.0)]
    null = 2.0 * 0.5  # 2 samples of 0.5: axis units
    truth = np.array([[0, 0], [0.4 * null, 0], [0.8 * null, 0], [10, 10], [10, 10 + 0.3 * null], [-10, 0]])
    groups = coinciding_targets(truth, axes, ["a", "b", "c", "d", "e", "f"])
    assert sorted(groups) == [["a", "b", "c"], ["d", "e"]]


def test_a_group_holding_coinciding_targets_is_not_refitted(monkeypatch):
    """The crowded cuts' response-model refit (metrics._refit_rich) models one response per member: on a peak
    that holds two targets it was tried and refused (receiver 14: 4 s CPU for nothing). A neighbour 8 samples
    away joins the pair's group; with the pair 0.6 of a null apart the group is tried as before."""
    import sarproc.quality.metrics as metrics

    tried = []
    real = metrics._refit_rich

    def spy(data, points, y, fit, members, nulls, params):
        tried.append(tuple(members))
        return real(data, points, y, fit, members, nulls, params)

    monkeypatch.setattr(metrics, "_refit_rich", spy)
    params = EvaluateParams(residual=False)
    for apart, expect_tried in ((0.0, False), (COINCIDE_NULLS + 0.1, True)):
        tried.clear()
        targets = [(0.0, 0.0), (apart * NULL[0], 0.0), (8 * STEP2[0], 0.0)]
        img, coords = _image(targets)
        evaluate_image(img, ("azimuth", "range"), coords, RES2, targets, names=["P", "Q", "R"], params=params)
        assert bool(tried) == expect_tried, (apart, tried)
