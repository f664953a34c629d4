"""A target's own theoretical IRW overrides the image's (images whose resolution varies with position)."""

import numpy as np
import pytest
from test_metrics import SINC_ISLR, SINC_PSLR, axis_coords, separable_image, sinc_psf

from sarproc.product.errors import InputError
from sarproc.quality.metrics import evaluate_image

IMAGE_RES = (1.0, 0.8)  # what the image attribute says
WIDE_RES = (1.15, 0.7)  # target B's true resolution: 15 % coarser in azimuth, 12.5 % finer in range
STEP = (0.45, 0.3)
TRUTH = [(0.0, 0.0), (40 * STEP[0], -50 * STEP[1])]


def _image():
    coords = [axis_coords(256, STEP[0]), axis_coords(300, STEP[1])]
    a = separable_image(coords, [sinc_psf(0.886 / r) for r in IMAGE_RES], TRUTH[:1])
    b = separable_image(coords, [sinc_psf(0.886 / r) for r in WIDE_RES], TRUTH[1:])
    return (a + b).astype(np.complex64), coords


def test_target_theory_overrides_the_image_theory():
    img, coords = _image()
    dims = ("azimuth", "range")
    plain = evaluate_image(img, dims, coords, IMAGE_RES, TRUTH, names=["A", "B"])
    own = np.array([[np.nan, np.nan], WIDE_RES])  # A: not recorded, the image's theory applies
    rep = evaluate_image(img, dims, coords, IMAGE_RES, TRUTH, names=["A", "B"], target_irw=own)
    for a, ax in enumerate(dims):
        # with the image's theory alone, B's width is off by its true/claimed ratio
        assert plain.target("B").axis(ax).irw_ratio == pytest.approx(WIDE_RES[a] / IMAGE_RES[a], rel=0.005)
        assert plain.target("B").axis(ax).theory == "image"
        a_ax, b_ax = rep.target("A").axis(ax), rep.target("B").axis(ax)
        assert a_ax.theory == "image" and a_ax.irw_theory == pytest.approx(IMAGE_RES[a])
        assert b_ax.theory == "target" and b_ax.irw_theory == pytest.approx(WIDE_RES[a])
        for m in (a_ax, b_ax):
            assert abs(m.irw_ratio - 1) < 0.005, m
            assert abs(m.pslr_db - SINC_PSLR) < 0.1 and abs(m.islr_db - SINC_ISLR) < 0.1, m  # own +-10 nulls
            assert abs(m.position_error_cells) < 0.02, m
        assert b_ax.position_error_cells == pytest.approx(b_ax.position_error / WIDE_RES[a])


@pytest.mark.parametrize(
    "own, match",
    [
        (np.ones((1, 2)), "shape"),
        (np.array([[1.0, 0.8], [-1.0, 0.8]]), "positive"),
        (np.array([[1.0, 0.8], [1.0, 0.2]]), "not finer"),  # a 0.2 IRW is undersampled at 0.3 spacing
    ],
)
def test_bad_target_theory_is_refused(own, match):
    img, coords = _image()
    with pytest.raises(InputError, match=match):
        evaluate_image(img, ("azimuth", "range"), coords, IMAGE_RES, TRUTH, target_irw=own)


def test_weighted_target_is_judged_against_its_own_window_theory():
    # Hamming-weighted responses in an image whose attribute keeps the unweighted theory (0.886 / B): with the
    # targets' own theory (IRW 1.30 / B, null 1 / B, Hamming side lobes) no irw_factor is needed
    from test_metrics import hamming_psf

    from sarproc.product.theory import window_theory
    from sarproc.quality.metrics import check_report, expectations_from_mapping

    # one target: the neighbour model subtracts unweighted responses unless irw_factor says Hamming
    coords = [axis_coords(256, STEP[0]), axis_coords(300, STEP[1])]
    truth = TRUTH[:1]
    img = separable_image(coords, [hamming_psf(0.886 / r) for r in IMAGE_RES], truth).astype(np.complex64)
    ham = window_theory("hamming")
    own = np.array([[ham.irw * r / 0.886 for r in IMAGE_RES]])
    nulls = np.array([[r / 0.886 for r in IMAGE_RES]])
    lobes = np.broadcast_to([ham.pslr_db, ham.islr_db], (1, 2, 2))
    dims = ("azimuth", "range")
    rep = evaluate_image(img, dims, coords, IMAGE_RES, truth, target_irw=own, target_null=nulls, target_sidelobes=lobes)
    plain = evaluate_image(img, dims, coords, IMAGE_RES, truth)
    expect = expectations_from_mapping(
        {
            "irw_ratio_max": 1.01,
            "irw_ratio_min": 0.99,
            "pslr_vs_theory_db": [-0.2, 0.2],
            "islr_vs_theory_db": [-0.2, 0.2],
        }
    )
    assert check_report(rep, expect) == []
    for t in rep.targets:
        for m in t.axes:
            assert abs(m.irw_ratio - 1) < 0.005 and m.theory == "target"
            assert m.pslr_theory_db == pytest.approx(-42.68, abs=0.05)
            assert abs(m.pslr_db - m.pslr_theory_db) < 0.1 and abs(m.islr_db - m.islr_theory_db) < 0.1
    # against the image's unweighted theory the same responses are 1.47x wide and 29 dB below the sinc's side lobes
    failed = {(f.metric, f.axis) for f in check_report(plain, expect)}
    assert {("irw_ratio", "azimuth"), ("pslr_vs_theory_db", "range"), ("islr_vs_theory_db", "azimuth")} <= failed
    assert plain.targets[0].axes[0].irw_ratio == pytest.approx(ham.factor / 0.886, rel=0.01)
    assert plain.targets[0].axes[0].pslr_theory_db == pytest.approx(-13.26, abs=0.01)
