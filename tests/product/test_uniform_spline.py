"""sarproc.product.uniform_spline against scipy.interpolate.CubicSpline, which it replaces (to float rounding)."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.interpolate

from sarproc.product.uniform_spline import uniform_cubic_spline


@pytest.mark.parametrize("n", [2, 3, 4, 5, 9, 50, 400])
def test_uniform_cubic_spline_is_scipys_not_a_knot_spline(n):
    rng = np.random.default_rng(n)
    te = (np.arange(n) - n // 2) / 16.0
    ve = rng.standard_normal(n) + 1j * rng.standard_normal(n)
    x = np.linspace(te[0], te[-1], 3 * n + 1)
    got = uniform_cubic_spline(te[0], te[1] - te[0], ve, x)
    want = scipy.interpolate.CubicSpline(te, ve)(x)
    assert np.abs(got - want).max() <= 1e-13 * np.abs(want).max()
    assert np.allclose(uniform_cubic_spline(te[0], te[1] - te[0], ve, te), ve, rtol=0, atol=1e-14)


@pytest.mark.parametrize("n", [3, 6, 200])
def test_a_track_is_splined_per_coordinate_and_extended_past_its_ends(n):
    """pfa2's de-aliasing: platform positions (pulses x 3) at upsampled pulse times, a little past the last."""
    rng = np.random.default_rng(n)
    t = np.arange(n, dtype=float)
    track = np.stack([7e3 + 0.3 * t, 5.0 * np.sin(t / 40.0), 3e3 + rng.normal(0.0, 0.01, n)], axis=1)
    x = np.linspace(-0.5, n - 1 + 0.75, 4 * n)
    got = uniform_cubic_spline(0.0, 1.0, track, x)
    want = scipy.interpolate.CubicSpline(t, track, axis=0)(x)
    assert got.shape == (len(x), 3)
    assert np.abs(got - want).max() <= 1e-12 * np.abs(want).max()


def test_one_knot_is_refused():
    with pytest.raises(ValueError, match="at least 2 knots"):
        uniform_cubic_spline(0.0, 1.0, np.ones(1), np.zeros(3))
