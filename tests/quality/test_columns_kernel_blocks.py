"""The residual's per-sample columns (sarproc.quality.residual_kernels.keystone_columns) evaluate blocks of samples
side by side: the same bits as the one-sample-at-a-time loop they replaced, copied here from int37 bd04055 (the
orders and signs summed per sample), on random ridge coordinates, points on a removable singularity, near a
Dirichlet pole and on the last axis' zero, 2D and 3D, with and without a keystone, across block edges.
"""

from __future__ import annotations

import math

import numba
import numpy as np
import pytest

from sarproc.quality import residual_aot, residual_kernels as rk
from sarproc.quality.residual import _strip_count, spectral_orders
from sarproc.quality.residual_kernels import _product_at, _strip_angles, _strip_constants


@numba.njit(error_model="numpy")
def _old_columns(c, orders, kappa, n_strips):
    ndim, n = c.shape
    n_orders = orders.shape[0]
    n_signs = 1 << (ndim - 1)
    width = 1.0 / n_strips
    signs, cos_dh, sin_dh, cos_sdh, sin_sdh, shift, cos_l, sin_l = _strip_constants(orders, kappa, n_strips, ndim)
    two_pi_pow = (2.0 * math.pi) ** (ndim - 1)
    j_pow = (-1j) ** (ndim - 1)
    out = np.empty((n_orders, n), dtype=np.complex128)
    acc = np.empty(n_orders, dtype=np.complex128)
    x = np.empty(ndim)
    for i in range(n):
        near = False
        for a in range(ndim - 1):
            for q in range(n_orders):
                if abs(c[a, i] + 0.5 * orders[q, a]) < 1e-7:
                    near = True
        if near:
            for q in range(n_orders):
                for a in range(ndim):
                    x[a] = c[a, i] + 0.5 * orders[q, a]
                out[q, i] = _product_at(x, kappa, n_strips)
            continue
        last = c[ndim - 1, i]
        for q in range(n_orders):
            acc[q] = 0j
        for s in range(n_signs):
            half, phase = _strip_angles(c[:, i], signs[s], kappa, n_strips)
            sh, ch = math.sin(half), math.cos(half)
            ssh, csh = math.sin(n_strips * half), math.cos(n_strips * half)
            rot = complex(math.cos(phase), math.sin(phase))
            for q in range(n_orders):
                den = sh * cos_dh[s, q] + ch * sin_dh[s, q]
                if abs(den) < 1e-9:
                    dirichlet = (
                        n_strips * (csh * cos_sdh[s, q] - ssh * sin_sdh[s, q]) / (ch * cos_dh[s, q] - sh * sin_dh[s, q])
                    )
                else:
                    dirichlet = (ssh * cos_sdh[s, q] + csh * sin_sdh[s, q]) / den
                acc[q] += dirichlet * (rot * shift[s, q])
        s_l, c_l = math.sin(math.pi * width * last), math.cos(math.pi * width * last)
        for q in range(n_orders):
            x_l = last + 0.5 * orders[q, ndim - 1]
            small = abs(x_l) < 1e-12
            den = 1.0
            for a in range(ndim - 1):
                den *= c[a, i] + 0.5 * orders[q, a]
            den *= two_pi_pow
            factor = width / den if small else (s_l * cos_l[q] + c_l * sin_l[q]) / (math.pi * x_l * den)
            out[q, i] = acc[q] * factor * j_pow
    return out


def _points(ndim: int, n: int, orders: np.ndarray, kappa: np.ndarray, n_strips: int, seed: int) -> np.ndarray:
    """Random ridge coordinates with special points mixed in: a removable singularity (c_a = -order / 2), within
    1e-8 of one, the last axis' zero (x_l = 0), and a Dirichlet kernel's pole (its half angle a multiple of pi)."""
    rng = np.random.default_rng(seed)
    c = rng.uniform(-40, 40, (ndim, n))
    if n >= 8:
        c[0, 1] = -0.5 * orders[3, 0]
        c[0, 2] = -0.5 * orders[1, 0] + 1e-8
        c[ndim - 1, 3] = -0.5 * orders[2, ndim - 1]
        c[:, 4] = 0.0
        # the first sign's half angle pi width (x_l + sum_a kappa_a x_a / 2) = pi (a pole of sin(S h) / sin h)
        c[ndim - 1, 5] = n_strips - 0.5 * float(np.sum(kappa * c[: ndim - 1, 5]))
    return c


@pytest.mark.parametrize("ndim", [2, 3])
@pytest.mark.parametrize("kappa_value", [0.0, 0.012, -0.3])
@pytest.mark.parametrize("n", [0, 1, 9, 63, 64, 65, 300])
def test_blocked_columns_are_the_per_sample_loop_bits(ndim: int, kappa_value: float, n: int) -> None:
    for orders in [spectral_orders(ndim, m, m + (ndim == 2)) for m in (1, 2, 4)]:
        orders = np.ascontiguousarray(orders, dtype=np.int64)
        kappa = np.full(ndim - 1, kappa_value) if kappa_value else np.zeros(ndim - 1)
        if ndim == 3 and kappa_value:
            kappa[1] = -0.5 * kappa_value
        n_strips = _strip_count(kappa)
        c = np.ascontiguousarray(_points(ndim, n, orders, kappa, n_strips, seed=n + ndim))
        want = _old_columns(c, orders, kappa, n_strips)
        for kernel in (rk.keystone_columns, residual_aot.keystone_columns):
            got = kernel(c, orders, kappa, n_strips)
            assert got.shape == want.shape
            np.testing.assert_array_equal(got.view(np.float64), want.view(np.float64))
