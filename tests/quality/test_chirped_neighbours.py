"""Crowded responses that carry a known chirp (paper 004's cube; issue 20 item 4): the neighbour models carry it.

array3d's azimuth matched filter spans the whole FFT band, so each response is its aperture's sinc times
exp(j pi K (x - x0)^2) about its own peak. Neighbours 12.4 nulls apart on one azimuth line then put their side
lobes into each other's ISLR windows; an ideal (chirp-free) neighbour model fits them at about -12 dB, so the
cuts were flagged "contaminated" and read 4-6 % wide with ISLR 2-3 dB high. With the chirp given (as
``target_chirp``, from the product's metadata) the group fits, nothing is flagged and every cut reads its theory.
"""

from __future__ import annotations

import numpy as np
import pytest
from test_metrics import axis_coords, separable_image, sinc_psf

from sarproc.quality.metrics import EvaluateParams, evaluate_image

STEPS = (0.001, 0.125, 0.333)  # elevation rad, azimuth m, range m
NULLS = (4.0, 3.2, 1.2)  # samples
K = 0.51  # 1/m^2: 0.008 cycles/sample^2 at 0.125 m, array3d's 2 / (lambda r) at 490 m, 37.5 GHz
SPACING = 12.4  # nulls between neighbours on the azimuth line (the du2010 cube's)


def chirped_scene():
    coords = [axis_coords(105, STEPS[0]), axis_coords(181, STEPS[1]), axis_coords(41, STEPS[2])]
    band = [1.0 / (n * s) for n, s in zip(NULLS, STEPS)]
    az = sinc_psf(band[1])
    psfs = [sinc_psf(band[0]), lambda x: az(x) * np.exp(1j * np.pi * K * x**2), sinc_psf(band[2])]
    gap = SPACING * NULLS[1] * STEPS[1]
    truth = np.array([[0.0, 0.0, 0.0], [0.0, gap, 0.0], [0.0, -gap, 0.0]])
    image = separable_image(coords, psfs, truth)
    irw = [0.886 * n * s for n, s in zip(NULLS, STEPS)]
    return image, coords, irw, truth


def test_neighbours_that_carry_their_chirp_are_subtracted():
    image, coords, irw, truth = chirped_scene()
    dims = ("elevation", "azimuth", "range")
    chirp = np.zeros(truth.shape)
    chirp[:, 1] = K
    rep = evaluate_image(image, dims, coords, irw, truth, names=["3", "4", "5"], target_chirp=chirp)
    for t in rep.targets:
        assert set(t.neighbours_removed) >= ({"4", "5"} if t.name == "3" else {"3"})
        for m in t.axes:
            assert m.contaminated_db is None and not m.truncated, (t.name, m)
            assert m.irw_ratio == pytest.approx(1.0, abs=0.01), (t.name, m)
            # +-0.5 dB (issue 20's tolerance): 4 and 5 are 24.8 nulls apart, beyond each other's chips, so 5's
            # side lobes (-33 dB there) stay in 4's window (4 alone at its place: -13.23 dB)
            assert m.pslr_db == pytest.approx(-13.26, abs=0.5), (t.name, m)
            assert m.islr_db == pytest.approx(-10.16, abs=0.5), (t.name, m)
    # the same scene without the chirp: ideal neighbours leave their side lobes, and the cuts say so (ideal models
    # only: the response-model refit that such a group gets by default fits no better, is dropped, and leaves these
    # figures as they are to the last bit; ~28 s of the test's ~30 s on 2 cores)
    plain = evaluate_image(
        image, dims, coords, irw, truth, names=["3", "4", "5"], params=EvaluateParams(neighbour_orders=0)
    )
    assert plain.target("3").axis("azimuth").contaminated_db is not None


def test_target_chirp_is_checked():
    image, coords, irw, truth = chirped_scene()
    with pytest.raises(Exception, match="target_chirp"):
        evaluate_image(image, ("elevation", "azimuth", "range"), coords, irw, truth, target_chirp=np.zeros((3, 2)))
