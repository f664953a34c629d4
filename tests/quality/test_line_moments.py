"""A 3D chip's values along a line near an image axis by spectral moments equal the direct sum."""

from __future__ import annotations

import numpy as np

from sarproc.quality.line_moments import MAX_TURN, _phases, line_sums, series_length


def _direct(spec, freqs, x0, v, t):
    f = np.meshgrid(*freqs, indexing="ij")
    return np.array(
        [np.sum(spec * np.exp(2j * np.pi * sum(fa * (xa + tt * va) for fa, xa, va in zip(f, x0, v)))) for tt in t]
    )


def test_line_sums_equal_direct_sum():
    rng = np.random.default_rng(5)
    shape = (17, 12, 9)
    spec = rng.standard_normal(shape) + 1j * rng.standard_normal(shape)
    freqs = [((np.arange(n) + n // 3) % n - n // 2) / n + c for n, c in zip(shape, (0.1, -0.2, 0.05))]
    x0 = np.array([8.3, 5.6, 4.1])
    first, step, count = -30.0, 1 / 16, 961
    t = first + step * np.arange(count)
    for v in ([1.0, 0.004, -0.002], [0.003, 1.0, 0.0], [-0.01, 0.02, 1.0], [0.0, 0.0, 1.0]):
        v = np.array(v)
        got = line_sums(spec, freqs, x0, v, first, step, count)
        assert got is not None
        pick = np.array([0, 1, 333, 480, 777, count - 1])
        want = _direct(spec, freqs, x0, v, t[pick])
        np.testing.assert_allclose(got[pick], want, rtol=0, atol=1e-13 * np.abs(spec).sum())
    # an even count: the offsets' mirror halves hold no zero
    got = line_sums(spec, freqs, x0, np.array([1.0, 0.004, -0.002]), first, step, 960)
    assert got is not None
    pick = np.array([0, 1, 479, 480, 959])
    want = _direct(spec, freqs, x0, np.array([1.0, 0.004, -0.002]), first + step * pick)
    np.testing.assert_allclose(got[pick], want, rtol=0, atol=1e-13 * np.abs(spec).sum())


def test_phases_of_mirrored_offsets_are_the_exponentials():
    """The cut's table from the cosines and sines of one half of its symmetric offsets and their conjugates:
    numpy's complex exponential of every entry, to rounding, for odd and even counts."""
    freqs = (np.arange(41) - 20) / 41 + 0.013
    for count in (1541, 1240, 1):
        tau = 0.0625 * (np.arange(count) - 0.5 * (count - 1))
        np.testing.assert_allclose(_phases(tau, freqs), np.exp(2j * np.pi * np.outer(tau, freqs)), rtol=0, atol=1e-14)


def test_steep_line_left_to_the_nufft():
    spec = np.ones((8, 8, 8), dtype=complex)
    freqs = [np.arange(8) / 8 - 0.5] * 3
    assert line_sums(spec, freqs, np.zeros(3), np.array([1.0, 0.8, 0.0]), -40.0, 1 / 16, 1281) is None
    assert series_length(MAX_TURN) < 60  # the longest series taken stays short
