"""evaluate's fast numerics (normal-equation least squares, pruned orientation density) give the same
report as the reference path (EvaluateParams(exact=True): SVD least squares, full density)."""

from __future__ import annotations

import math

import numpy as np
from test_metrics import axis_coords, separable_image, sinc_psf

from sarproc.quality.metrics import EvaluateParams, evaluate_image, least_squares, principal_directions


def _floats(d, prefix=""):
    if isinstance(d, dict):
        for k, v in d.items():
            yield from _floats(v, f"{prefix}/{k}")
    elif isinstance(d, (list, tuple)):
        for i, v in enumerate(d):
            yield from _floats(v, f"{prefix}[{i}]")
    else:
        yield prefix, d


def _assert_same(fast, exact):
    a, b = dict(_floats(fast.to_dict())), dict(_floats(exact.to_dict()))
    assert a.keys() == b.keys()
    for k in a:
        if k == "/params/exact":
            continue
        if isinstance(a[k], float) and isinstance(b[k], float):
            assert math.isclose(a[k], b[k], rel_tol=1e-9, abs_tol=1e-9), (k, a[k], b[k])
        else:
            assert a[k] == b[k], (k, a[k], b[k])


def test_3d_support_and_least_squares_same_as_reference():
    res, steps = (0.02, 1.0, 0.8), (0.012, 0.6, 0.5)
    bw = tuple(0.886 / r for r in res)
    coords = [axis_coords(40, steps[0]), axis_coords(40, steps[1]), axis_coords(40, steps[2])]
    doppler = (0.3 / steps[0], 0.45 / steps[1], -0.2 / steps[2])
    chip = separable_image(coords, [sinc_psf(b, f) for b, f in zip(bw, doppler)], [(0.0013, 0.21, -0.37)])
    nulls = [r / (0.886 * s) for r, s in zip(res, steps)]
    centers = [f * s for f, s in zip(doppler, steps)]
    V_fast, fc_fast = principal_directions(chip, centers, nulls)
    V_exact, fc_exact = principal_directions(chip, centers, nulls, exact=True)
    np.testing.assert_allclose(V_fast, V_exact, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(fc_fast, fc_exact)
    # a tall system like the neighbour fit's: shifted responses and their derivatives
    x = np.linspace(-20, 20, 4000)
    B = np.stack(
        [np.sinc(x - s) * np.exp(2j * np.pi * 0.3 * x) for s in np.linspace(-3, 3, 13)]
        + [x * np.sinc(x - s) for s in (-1.0, 0.0, 1.0)],
        axis=1,
    )
    y = B @ (np.arange(16) + 1j) + 1e-3 * np.cos(7 * x)
    np.testing.assert_allclose(least_squares(B, y), least_squares(B, y, exact=True), rtol=1e-9)


def test_crowded_skewed_2d_same_report():
    coords = [axis_coords(96, 0.4), axis_coords(96, 0.35)]
    a, r = np.meshgrid(coords[0], coords[1], indexing="ij")
    img = np.zeros(a.shape, dtype=complex)
    targets = [(0.3, -0.2), (3.1, 2.2)]
    for (ta, tr), amp in zip(targets, (1.0, 0.7j)):
        da, dr = a - ta, r - tr  # a skewed support: the range ridge leans on azimuth
        img += amp * np.sinc(0.886 * da) * np.sinc(0.886 / 0.8 * (dr + 0.15 * da)) * np.exp(2j * np.pi * 0.4 * da)
    fast = evaluate_image(img, ("azimuth", "range"), coords, (1.0, 0.8), targets)
    exact = evaluate_image(img, ("azimuth", "range"), coords, (1.0, 0.8), targets, params=EvaluateParams(exact=True))
    assert any(t.neighbours_removed for t in fast.targets)
    _assert_same(fast, exact)
