"""sarproc.dsp.spline against scipy.interpolate, which it replaces in pfa2's distortion warp (to float rounding)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.interpolate import BSpline, RectBivariateSpline

from sarproc.dsp.spline import GridSpline, bspline_basis, interpolation_knots


@pytest.mark.parametrize(("m", "n"), [(9, 9), (4, 7), (12, 5)])
def test_grid_spline_is_rect_bivariate_splines_default(m, n):
    rng = np.random.default_rng(m * 100 + n)
    # uneven spacing (steps 0.5-1.5 of the mean): the knots are the data points, not a lattice
    x = -3.0 + np.cumsum(rng.uniform(0.5, 1.5, m))
    y = 10.0 + 2.0 * np.cumsum(rng.uniform(0.5, 1.5, n))
    z = rng.normal(size=(m, n)) * 10.0
    want, got = RectBivariateSpline(x, y, z), GridSpline(x, y, z)
    assert got.degrees == want.degrees == (3, 3)
    for a, b in zip(got.tck, want.tck, strict=True):
        np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-12 * np.max(np.abs(b)))
    # inside, at the data (interpolation) and beyond the edges (clamped to the edge, as FITPACK does)
    xs = np.concatenate([[x[0] - 2.0], np.linspace(x[0], x[-1], 57), x, [x[-1] + 1.0]])
    ys = np.concatenate([[y[0] - 1.0], np.linspace(y[0], y[-1], 43), y, [y[-1] + 3.0]])
    xs.sort()
    ys.sort()
    values = got(xs, ys)
    np.testing.assert_allclose(values, want(xs, ys), rtol=0, atol=1e-12 * np.max(np.abs(z)))
    np.testing.assert_allclose(got(x, y), z, rtol=0, atol=1e-12 * np.max(np.abs(z)))


def test_basis_is_the_design_matrix_and_a_partition_of_unity():
    x = np.array([0.0, 0.3, 1.1, 2.0, 2.5, 4.0, 6.5, 7.0])
    t = interpolation_knots(x)
    xs = np.linspace(0.0, 7.0, 301)
    b = bspline_basis(xs, t)
    np.testing.assert_allclose(b, BSpline.design_matrix(xs, t, 3).toarray(), rtol=0, atol=1e-15)
    np.testing.assert_allclose(b.sum(axis=1), 1.0, rtol=0, atol=1e-15)
    assert np.all(np.count_nonzero(b, axis=1) <= 4)
    for k in (1, 2):  # other degrees on their own knots
        tk = np.concatenate([np.zeros(k), np.linspace(0.0, 7.0, 6), np.full(k, 7.0)])
        np.testing.assert_allclose(
            bspline_basis(xs, tk, k), BSpline.design_matrix(xs, tk, k).toarray(), rtol=0, atol=1e-15
        )


def test_bad_input_is_refused():
    t = interpolation_knots(np.arange(6.0))
    with pytest.raises(ValueError, match="outside the base interval"):
        bspline_basis(np.array([-0.5]), t)
    with pytest.raises(ValueError, match="at least 4 points"):
        GridSpline(np.arange(3.0), np.arange(5.0), np.zeros((3, 5)))
    with pytest.raises(ValueError, match="strictly increasing"):
        GridSpline(np.array([0.0, 2.0, 1.0, 3.0]), np.arange(5.0), np.zeros((4, 5)))
    with pytest.raises(ValueError, match="shape"):
        GridSpline(np.arange(4.0), np.arange(5.0), np.zeros((5, 4)))
