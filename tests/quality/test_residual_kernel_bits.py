"""The residual's strip-sum kernels at their singular and pole points.

:func:`sarproc.quality.residual_kernels.keystone_columns` (the fits' bases, one call per Gauss-Newton trial) takes
the Dirichlet kernel's limit by choosing its operands before one division and writes its complex products out in
real arithmetic: the same bits as the per-sample complex loop it computes (the copy of int37's one-sample-at-a-time
loop in tests/quality/test_columns_kernel_blocks.py), on points at every special case (Dirichlet poles exactly and
within the 1e-9 limit's reach of them, which that test's points do not reach; removable singularities of a
keystoned axis and within 1e-7 of them; the last axis' zero); and within stated bounds of the direct product
:func:`_product_at` (per sample and order, its own angles) at the same points. :func:`keystone_derivatives`
(blocks of samples; its bits against the per-order loop: tests/quality/test_evaluate_fast_paths.py) within a
stated bound of :func:`_derivatives_at` summed over the orders at the same pole points. These changes keep the
bits, so the tests pass on main too; each fails on a wrong kernel (checked: the columns' limit threshold at
1e-10 instead of 1e-9, which test_columns_kernel_blocks.py passes; the derivatives' series threshold at 1e-6
instead of SERIES_SH).
"""

from __future__ import annotations

import numba
import numpy as np
import pytest
from test_columns_kernel_blocks import _old_columns  # int37's one-sample-at-a-time loop

from sarproc.quality import residual_kernels as rk
from sarproc.quality.residual import _strip_count, spectral_orders
from sarproc.quality.residual_kernels import _product_at


@numba.njit(error_model="numpy")
def _direct_columns(c, orders, kappa, n_strips):
    """Every order's strip sum by :func:`_product_at` at c + order / 2: the direct formula."""
    ndim, n = c.shape
    out = np.empty((orders.shape[0], n), dtype=np.complex128)
    x = np.empty(ndim)
    for i in range(n):
        for q in range(orders.shape[0]):
            for a in range(ndim):
                x[a] = c[a, i] + 0.5 * orders[q, a]
            out[q, i] = _product_at(x, kappa, n_strips)
    return out


def _pole_points(rng: np.random.Generator, ndim: int, strips: int, kappa: np.ndarray) -> np.ndarray:
    """Ridge coordinates at every special case of the strip sum: on a Dirichlet pole of an order (the half
    angle of one sign a multiple of pi) and at offsets around the 1e-9 limit's reach (|sin h| ~ pi / S
    times the offset), on and within 1e-7 of a keystoned axis' removable singularity, on and near the last
    axis' zero, and ordinary points."""
    c = rng.uniform(-60, 60, size=(ndim, 3000))
    c[:, :400] = rng.uniform(-3, 3, size=(ndim, 400))
    # poles: with sign +, half = pi / S (x_l + sum_a kappa_a x_a / 2) = m pi at x_l = m S - sum_a kappa_a x_a / 2
    for k, offset in enumerate([0.0, 1e-12, 3e-9, 1e-8, -1e-8, 3.2e-8, 1e-6, 1e-3]):
        sl = slice(400 + 40 * k, 440 + 40 * k)
        n_l = rng.integers(-2, 3, 40)  # an order's last-axis shift
        m = rng.integers(-2, 3, 40)
        shift = sum(0.5 * kappa[a] * c[a, sl] for a in range(ndim - 1))
        c[-1, sl] = m * strips - 0.5 * n_l - shift + offset
    c[0, 720:740] = 0.5  # on a removable singularity of an order (c_0 + n_0 / 2 = 0)
    c[0, 740:760] = 0.5 + rng.uniform(-1e-7, 1e-7, 20)
    c[0, 760:780] = 1e-6 * rng.uniform(-1, 1, 20)  # within the keystone sum's cancellation
    c[-1, 780:800] = 0.0
    c[-1, 800:820] = -1.0 + rng.uniform(-1e-12, 1e-12, 20)  # an order's last-axis zero (n_l = 2)
    return c


@pytest.mark.parametrize("ndim", [2, 3])
@pytest.mark.parametrize("keystone", [0.0, 0.003, -0.15])
def test_keystone_columns_equal_the_per_sample_loop_bit_for_bit(ndim, keystone):
    """The blocked kernel on evaluate's orders (2D: the 37 of beam_edge's widest fits) at every special case:
    the same bits as the per-sample complex loop (compared as values: zeros' signs aside)."""
    rng = np.random.default_rng(11)
    orders = np.ascontiguousarray(spectral_orders(ndim, 3 if ndim == 2 else 1, 3 if ndim == 2 else 1), dtype=np.int64)
    kappa = np.linspace(keystone, 0.5 * keystone, ndim - 1)
    strips = _strip_count(kappa)
    c = _pole_points(rng, ndim, strips, kappa)
    want = _old_columns(c, orders, kappa, strips)
    got = rk.keystone_columns(c, orders, kappa, strips)
    assert np.isfinite(got).all()
    assert np.array_equal(got, want)  # equal nonzero doubles are the same bits


@pytest.mark.parametrize("ndim", [2, 3])
@pytest.mark.parametrize("keystone", [0.0, 0.003, -0.15])
def test_keystone_columns_are_the_direct_product_at_poles_and_singularities(ndim, keystone):
    """Against :func:`_product_at` (each sample and order's own angles, its own limits): within 1e-12 of the
    order's largest value at ordinary points, on the poles and 1e-6 or more off them; within 1e-6 of it 1e-12
    to 3.2e-8 off a pole, where |sin h| is 1e-13 to 3e-9 and the two closed forms' sines, rounded apart (the
    kernel's angle-added, the direct one's own), differ by eps / |sin h| of the kernel's value (~S there; main's
    kernel, the same bits, measured 1.3e-7); within 1e-9 of it within 1e-6 of a keystoned axis' zero, where both
    sum the signs' terms to ~x_a of themselves (measured 3e-10; the numpy reference's bound there,
    tests/quality/test_residual_reach.py, is 1e-8)."""
    rng = np.random.default_rng(12)
    orders = np.ascontiguousarray(spectral_orders(ndim, 3 if ndim == 2 else 1, 3 if ndim == 2 else 1), dtype=np.int64)
    kappa = np.linspace(keystone, 0.5 * keystone, ndim - 1)
    strips = _strip_count(kappa)
    c = _pole_points(rng, ndim, strips, kappa)
    got = rk.keystone_columns(c, orders, kappa, strips)
    want = _direct_columns(c, orders, kappa, strips)
    err = np.abs(got - want) / np.abs(want).max(axis=1, keepdims=True)
    x_a = np.abs(c[:-1, None, :] + 0.5 * orders.T[:-1, :, None]).min(axis=0)  # (K, N): nearest keystoned zero
    cancelling = x_a < 1e-6
    assert err[cancelling].max() <= 1e-9
    per_sample = np.where(cancelling, 0.0, err).max(axis=0)
    near_pole = np.zeros(c.shape[1], dtype=bool)
    near_pole[440:680] = True  # the offsets 1e-12 .. 3.2e-8 of _pole_points
    assert per_sample[near_pole].max() <= 1e-6
    assert per_sample[~near_pole].max() <= 1e-12


@numba.njit(error_model="numpy")
def _direct_derivatives(c, orders, coef, kappa, n_strips):
    """sum_k coef_k times :func:`_derivatives_at` at c + order_k / 2 (each point's own angles and series): the
    direct formula of :func:`keystone_derivatives` away from the keystoned axes' zeros."""
    ndim, n = c.shape
    out = np.zeros((2 * ndim - 1, n), dtype=np.complex128)
    x = np.empty(ndim)
    d_x = np.empty(ndim, dtype=np.complex128)
    d_k = np.empty(max(ndim - 1, 1), dtype=np.complex128)
    for i in range(n):
        for q in range(orders.shape[0]):
            for a in range(ndim):
                x[a] = c[a, i] + 0.5 * orders[q, a]
            rk._derivatives_at(x, kappa, n_strips, d_x, d_k)
            for a in range(ndim):
                out[a, i] += coef[q] * d_x[a]
            for a in range(ndim - 1):
                out[ndim + a, i] += coef[q] * d_k[a]
    return out


@pytest.mark.parametrize("ndim", [2, 3])
@pytest.mark.parametrize("keystone", [0.0, 0.003, -0.15])
def test_keystone_derivatives_are_the_direct_formula_at_poles(ndim, keystone):
    """The blocked derivative kernel against :func:`_derivatives_at` summed over the orders, at the same pole
    points (exactly on, and 1e-12 to 1e-3 off, a Dirichlet pole; the last axis' zero), the keystoned axes'
    zeros left out (there the kernel interpolates from nodes NEAR_X away, a different formula): within 1e-10
    of each row's largest value (measured 4.4e-12 at most; the two differ where a pole's series or closed form
    is taken on angles rounded apart)."""
    rng = np.random.default_rng(13)
    orders = np.ascontiguousarray(spectral_orders(ndim, 3 if ndim == 2 else 1, 3 if ndim == 2 else 1), dtype=np.int64)
    kappa = np.linspace(keystone, 0.5 * keystone, ndim - 1)
    strips = _strip_count(kappa)
    c = _pole_points(rng, ndim, strips, kappa)
    x_a = np.abs(c[:-1, None, :] + 0.5 * orders.T[:-1, :, None]).min(axis=(0, 1))
    c = np.ascontiguousarray(c[:, x_a >= 2 * rk.NEAR_X])
    coef = rng.normal(size=len(orders)) + 1j * rng.normal(size=len(orders))
    got = rk.keystone_derivatives(c, orders, coef, kappa, strips)
    want = _direct_derivatives(c, orders, coef, kappa, strips)
    assert np.isfinite(got).all()
    err = np.abs(got - want) / np.abs(want).max(axis=1, keepdims=True)
    assert err.max() <= 1e-10
