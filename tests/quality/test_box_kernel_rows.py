"""The residual's box kernels (sarproc.quality.residual_kernels.keystone_box_sum, keystone_warped_box_sum) evaluate
each row's samples side by side (:func:`_row_sums`): the same bits as the per-sample loop they replaced, copied
here from main 6d4f8e2 (one sample at a time, the orders and signs summed in it); and a warped model whose keystone
is too small for :func:`residual._keystoned` is subtracted through the warped box kernel (model_values sums its
strips), not the per-sample columns, equal to :func:`model_values` to rounding.
"""

from __future__ import annotations

import math

import numba
import numpy as np
import pytest

from sarproc.quality import residual_aot, residual_kernels as rk
from sarproc.quality.residual import _model_on_box, _strip_count, spectral_orders
from sarproc.quality.residual_kernels import RESEED, _box_tables, _product_at, _set_rotations, _strip_angles


@numba.njit(error_model="numpy")
def _old_sample(c, x, orders, kappa, n_strips, e_half, e_shalf, e_phase, e_l, tables, two_pi_pow, j_pow):
    cos_dh, sin_dh, cos_sdh, sin_sdh, shift, cos_l, sin_l, coef = tables
    ndim = c.shape[0]
    n_orders = orders.shape[0]
    n_signs = e_half.shape[0]
    width = 1.0 / n_strips
    near = False
    for a in range(ndim - 1):
        for q in range(n_orders):
            if abs(c[a] + 0.5 * orders[q, a]) < 1e-7:
                near = True
    total = 0j
    if near:
        for q in range(n_orders):
            for a in range(ndim):
                x[a] = c[a] + 0.5 * orders[q, a]
            total += coef[q] * _product_at(x, kappa, n_strips)
    else:
        last = c[ndim - 1]
        s_l, c_l = e_l.imag, e_l.real
        for q in range(n_orders):
            acc = 0j
            for s in range(n_signs):
                sh, ch = e_half[s].imag, e_half[s].real
                ssh, csh = e_shalf[s].imag, e_shalf[s].real
                den = sh * cos_dh[s, q] + ch * sin_dh[s, q]
                if abs(den) < 1e-9:
                    dirichlet = (
                        n_strips * (csh * cos_sdh[s, q] - ssh * sin_sdh[s, q]) / (ch * cos_dh[s, q] - sh * sin_dh[s, q])
                    )
                else:
                    dirichlet = (ssh * cos_sdh[s, q] + csh * sin_sdh[s, q]) / den
                acc += dirichlet * (e_phase[s] * shift[s, q])
            x_l = last + 0.5 * orders[q, ndim - 1]
            den_a = two_pi_pow
            for a in range(ndim - 1):
                den_a *= c[a] + 0.5 * orders[q, a]
            on_axis = abs(x_l) < 1e-12
            factor = width / den_a if on_axis else (s_l * cos_l[q] + c_l * sin_l[q]) / (math.pi * x_l * den_a)
            total += acc * factor
        total *= j_pow
    return total


@numba.njit(error_model="numpy")
def _old_warped_box_sum(c0, d_row, d_col, w_rr, w_rc, w_cc, n_rows, n_cols, orders, coef, kappa, n_strips):
    ndim = c0.shape[0]
    n_signs = 1 << (ndim - 1)
    width = 1.0 / n_strips
    signs, tables, two_pi_pow, j_pow = _box_tables(orders, coef, kappa, n_strips, ndim)
    out = np.empty((n_rows, n_cols), dtype=np.complex128)
    e_half = np.empty(n_signs, dtype=np.complex128)
    e_shalf = np.empty(n_signs, dtype=np.complex128)
    e_phase = np.empty(n_signs, dtype=np.complex128)
    r_half = np.empty(n_signs, dtype=np.complex128)
    r_shalf = np.empty(n_signs, dtype=np.complex128)
    r_phase = np.empty(n_signs, dtype=np.complex128)
    t_half = np.empty(n_signs, dtype=np.complex128)
    t_shalf = np.empty(n_signs, dtype=np.complex128)
    t_phase = np.empty(n_signs, dtype=np.complex128)
    for s in range(n_signs):
        th, tp = _strip_angles(w_cc, signs[s], kappa, n_strips)
        _set_rotations(t_half, t_shalf, t_phase, s, th, tp, n_strips, 2.0)
    turn_l = 2.0 * math.pi * width * w_cc[ndim - 1]
    t_l = complex(math.cos(turn_l), math.sin(turn_l))
    row = np.empty(ndim)
    lin = np.empty(ndim)
    c = np.empty(ndim)
    step = np.empty(ndim)
    x = np.empty(ndim)
    e_l = 1.0 + 0j
    r_l = 1.0 + 0j
    for i in range(n_rows):
        for a in range(ndim):
            row[a] = c0[a] + i * d_row[a] + i * i * w_rr[a]
            lin[a] = d_col[a] + i * w_rc[a]
        for j in range(n_cols):
            for a in range(ndim):
                c[a] = row[a] + j * lin[a] + j * j * w_cc[a]
            if j % RESEED == 0:
                for a in range(ndim):
                    step[a] = lin[a] + (2 * j + 1) * w_cc[a]
                for s in range(n_signs):
                    half, phase = _strip_angles(c, signs[s], kappa, n_strips)
                    _set_rotations(e_half, e_shalf, e_phase, s, half, phase, n_strips, 1.0)
                    dh, dp = _strip_angles(step, signs[s], kappa, n_strips)
                    _set_rotations(r_half, r_shalf, r_phase, s, dh, dp, n_strips, 1.0)
                arg = math.pi * width * c[ndim - 1]
                e_l = complex(math.cos(arg), math.sin(arg))
                arg = math.pi * width * step[ndim - 1]
                r_l = complex(math.cos(arg), math.sin(arg))
            out[i, j] = _old_sample(
                c, x, orders, kappa, n_strips, e_half, e_shalf, e_phase, e_l, tables, two_pi_pow, j_pow
            )
            for s in range(n_signs):
                e_half[s] *= r_half[s]
                e_shalf[s] *= r_shalf[s]
                e_phase[s] *= r_phase[s]
                r_half[s] *= t_half[s]
                r_shalf[s] *= t_shalf[s]
                r_phase[s] *= t_phase[s]
            e_l *= r_l
            r_l *= t_l
    return out


@numba.njit(error_model="numpy")
def _old_box_sum(c0, d_row, d_col, n_rows, n_cols, orders, coef, kappa, n_strips):
    ndim = c0.shape[0]
    n_signs = 1 << (ndim - 1)
    width = 1.0 / n_strips
    signs, tables, two_pi_pow, j_pow = _box_tables(orders, coef, kappa, n_strips, ndim)
    out = np.empty((n_rows, n_cols), dtype=np.complex128)
    e_half = np.empty(n_signs, dtype=np.complex128)
    e_shalf = np.empty(n_signs, dtype=np.complex128)
    e_phase = np.empty(n_signs, dtype=np.complex128)
    r_half = np.empty(n_signs, dtype=np.complex128)
    r_shalf = np.empty(n_signs, dtype=np.complex128)
    r_phase = np.empty(n_signs, dtype=np.complex128)
    zero = np.zeros(ndim)
    for s in range(n_signs):
        dh, dp = _strip_angles(d_col, signs[s], kappa, n_strips)
        dh0, dp0 = _strip_angles(zero, signs[s], kappa, n_strips)
        dh -= dh0
        dp -= dp0
        _set_rotations(r_half, r_shalf, r_phase, s, dh, dp, n_strips, 1.0)
    step_l = math.pi * width * d_col[ndim - 1]
    r_l = complex(math.cos(step_l), math.sin(step_l))
    c = np.empty(ndim)
    x = np.empty(ndim)
    pix = np.empty(ndim)
    e_l = 1.0 + 0j
    for i in range(n_rows):
        for a in range(ndim):
            c[a] = c0[a] + i * d_row[a]
        for j in range(n_cols):
            for a in range(ndim):
                pix[a] = c[a] + j * d_col[a]
            if j % RESEED == 0:
                for s in range(n_signs):
                    half, phase = _strip_angles(pix, signs[s], kappa, n_strips)
                    _set_rotations(e_half, e_shalf, e_phase, s, half, phase, n_strips, 1.0)
                arg = math.pi * width * pix[ndim - 1]
                e_l = complex(math.cos(arg), math.sin(arg))
            out[i, j] = _old_sample(
                pix, x, orders, kappa, n_strips, e_half, e_shalf, e_phase, e_l, tables, two_pi_pow, j_pow
            )
            for s in range(n_signs):
                e_half[s] *= r_half[s]
                e_shalf[s] *= r_shalf[s]
                e_phase[s] *= r_phase[s]
            e_l *= r_l
    return out


def _boxes(kappa):
    """Skewed boxes with the kernels' special samples: rows on a keystoned factor's removable singularity (c_az =
    -n / 2, and within 1e-7 of it), the last axis' zero, a first sample on a Dirichlet pole (its half angle pi
    width c_range + pi width kappa c_az / 2 = pi, so its denominator is rounding), a box of one column and one of
    fewer columns than a reseed."""
    yield np.array([2.0, 32.0 - kappa]), np.array([0.5, 0.3]), np.array([0.013, 0.29]), 5, 20
    yield np.array([-20.0, -31.5]), np.array([0.5, 0.04]), np.array([0.0, 0.41]), 90, 150
    yield np.array([-3.0 + 5e-8, -16.25]), np.array([0.25, 0.0]), np.array([0.0, 0.25]), 40, 260
    yield np.array([0.5, 16.0]), np.array([0.125, 0.5]), np.array([0.001, -0.5]), 30, 70
    yield np.array([7.3, -2.2]), np.array([0.3, 0.1]), np.array([-0.02, 0.37]), 17, 1
    yield np.array([-1.5, 40.0]), np.array([0.5, -0.25]), np.array([0.07, 0.11]), 9, 11


def _bits(a):
    return np.ascontiguousarray(a).view(np.uint64)


@pytest.mark.parametrize("kappa", [0.0004, 0.003, 0.03, -0.15])
def test_row_box_kernels_are_the_per_sample_loop_bit_for_bit(kappa):
    rng = np.random.default_rng(21)
    orders = np.ascontiguousarray(spectral_orders(2, 2, 3), dtype=np.int64)
    coef = rng.normal(size=len(orders)) + 1j * rng.normal(size=len(orders))
    k = np.array([kappa])
    strips = _strip_count(k)
    warp = (np.array([1e-4, -2e-4]), np.array([3e-4, 5e-5]), np.array([-1e-4, 2e-4]))
    for c0, d_row, d_col, rows, cols in _boxes(kappa):
        got = rk.keystone_box_sum(c0, d_row, d_col, rows, cols, orders, coef, k, strips)
        want = _old_box_sum(c0, d_row, d_col, rows, cols, orders, coef, k, strips)
        assert np.isfinite(got).all() and np.array_equal(_bits(got), _bits(want))
        got = rk.keystone_warped_box_sum(c0, d_row, d_col, *warp, rows, cols, orders, coef, k, strips, np.zeros(6))
        want = _old_warped_box_sum(c0, d_row, d_col, *warp, rows, cols, orders, coef, k, strips)
        assert np.isfinite(got).all() and np.array_equal(_bits(got), _bits(want))


def test_a_warped_model_with_a_small_keystone_is_subtracted_by_the_box_kernel(monkeypatch):
    """002 small two-step's models: half of them (8.4 M of 17 M samples subtracted) have a keystone below
    :func:`_keystoned`'s reach, which model_values still sums as strips; on a box they go through the warped box
    kernel now, not the per-sample columns (samples x orders), to rounding of model_values."""
    from helpers import model_on_every_sample, warped_model
    from sarproc.quality.residual import _keystoned

    model = warped_model(np.random.default_rng(8), kappa=2e-4)
    assert not _keystoned(model.kappa)
    box = (slice(3, 140), slice(20, 230))
    want = model_on_every_sample(box, model)
    with monkeypatch.context() as m:
        m.setattr(residual_aot, "keystone_columns", None)  # not called on the box
        got = _model_on_box(box, model)
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-12 * np.abs(model.coef).sum())
