"""evaluate's bowed-edge term F(a, b) = integral over u in (-1/2, 1/2) of exp(2 pi j (a u + b u^2)) to float64's
accuracy at every bow (issue 20 item 1, session 44).

The Fresnel integrals' closed form divides by b (its phase a^2 / 2b and its 1 / sqrt(b)), so its rounding grew as
|b| shrank: 3e-2 at b = 1e-14, 3e-4 at 1e-11 against |F| ~ 1e-2, where evaluate's bow fits put thousands of
samples. ``_fresnel_box`` now sums a series in b below ``SERIES_B``. The reference is a Gauss-Legendre rule in
long double (nodes refined by Newton's method there, phases reduced mod 1 before the exponential), good to
~1e-18; the bound, 8 eps (1 + |a|), is float64's: the phase 2 pi a u alone carries a rounding of eps pi |a|.
"""

from __future__ import annotations

import numpy as np
import pytest

from sarproc.quality.residual import SERIES_B, _fresnel_box

LONG = np.finfo(np.longdouble).eps < 1e-18
PI = np.longdouble("3.14159265358979323846264338327950288")


def _legendre(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Gauss-Legendre nodes and weights on (-1/2, 1/2), in long double."""
    x = np.polynomial.legendre.leggauss(n)[0].astype(np.longdouble)
    for _ in range(4):
        p0, p1 = np.ones_like(x), x.copy()
        for k in range(2, n + 1):
            p0, p1 = p1, ((2 * k - 1) * x * p1 - (k - 1) * p0) / k
        dp = n * (x * p1 - p0) / (x * x - 1)
        x = x - p1 / dp
    return x / 2, 1 / ((1 - x * x) * dp * dp)


def _reference(a: np.ndarray, b: np.ndarray, n: int = 300) -> np.ndarray:
    u, w = _legendre(n)
    phase = np.multiply.outer(a.astype(np.longdouble), u) + np.multiply.outer(b.astype(np.longdouble), u * u)
    phase -= np.round(phase)
    return (np.exp((2j * PI) * phase.astype(np.clongdouble)) * w).sum(-1)


def _grid() -> tuple[np.ndarray, np.ndarray]:
    mags = np.concatenate([np.linspace(0.0, 50.0, 101), np.geomspace(1e-4, 50.0, 15), [0.6366, 0.63662, 0.6367]])
    bows = np.concatenate([np.geomspace(1e-14, 10.0, 31), np.linspace(0.13, 0.21, 9), [SERIES_B]])
    a, b = np.meshgrid(np.concatenate([mags, -mags]), np.concatenate([bows, -bows]), indexing="ij")
    return a.ravel(), b.ravel()


@pytest.mark.skipif(not LONG, reason="the reference needs an extended long double")
def test_fresnel_box_to_float64_accuracy_at_every_bow():
    a, b = _grid()
    want = _reference(a, b)
    far = np.abs(a) > 49.0  # the reference has converged: a coarser rule agrees to long double's rounding
    assert np.abs(_reference(a[far], b[far], 240) - want[far]).max() < 1e-17
    mixed = _fresnel_box(a, b)  # every bow in one call: the series takes all its terms
    single = np.empty_like(mixed)
    for bow in np.unique(b):  # one bow at a time, as a bow's samples come: the series takes fewer
        single[b == bow] = _fresnel_box(a[b == bow], b[b == bow])
    eps = np.finfo(float).eps
    want = want.astype(complex)
    err = np.maximum(np.abs(mixed - want), np.abs(single - want)) / (eps * (1.0 + np.abs(a)))
    worst = np.unravel_index(np.argmax(err), err.shape)
    assert err.max() <= 8.0, (err.max(), a[worst], b[worst])
    small = np.abs(b) < 1e-6  # where the closed form's rounding was all but the bow: now float64's
    assert err[small].max() <= 1.0


def test_fresnel_box_at_zero_bow_is_the_sinc_bit_for_bit():
    a = np.concatenate([np.linspace(-50.0, 50.0, 1001), [0.0, 1e-300, 0.6366]])
    assert np.array_equal(_fresnel_box(a, np.zeros_like(a)), np.sinc(a).astype(complex))
    # F(a, -b) is F(a, b)'s conjugate on both sides of the switch
    for bow in (1e-9, 0.01, SERIES_B * 0.999, SERIES_B, 1.0):
        up, down = _fresnel_box(a, np.full_like(a, bow)), _fresnel_box(a, np.full_like(a, -bow))
        assert np.abs(up - np.conj(down)).max() < 1e-15
