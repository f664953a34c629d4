"""Evaluate's cheaper paths give the numbers of the ones they replace, bit for bit (docs/performance.md, "Session 32").

- :func:`sarproc.quality.residual_kernels.keystone_derivatives`, its orders in branch-free real loops, against
  the per-order complex loop it replaced (copied here as it was);
- :func:`sarproc.quality.linesum._spread`, compiled, against its numpy reference;
- :func:`sarproc.quality.residual._bounded_minimum` against ``scipy.optimize.minimize_scalar(method="bounded")``.
"""

from __future__ import annotations

import math

import numba
import numpy as np
import pytest

from sarproc.quality import linesum, residual_aot, residual_kernels as rk
from sarproc.quality.residual import _bounded_minimum, _strip_count, spectral_orders
from sarproc.quality.residual_kernels import (
    NEAR_X,
    NODE,
    _derivatives_at,
    _dirichlet,
    _last_factor,
    _strip_angles,
    _strip_constants,
)


@numba.njit(error_model="numpy")
def _per_order_derivatives(
    c: np.ndarray, orders: np.ndarray, coef: np.ndarray, kappa: np.ndarray, n_strips: int
) -> np.ndarray:  # pragma: no cover - compiled
    """Session 31's kernel, one order at a time (complex arithmetic, a branch per order)."""
    ndim, n = c.shape
    n_k = ndim - 1
    n_orders = orders.shape[0]
    n_signs = 1 << n_k
    width = 1.0 / n_strips
    u0 = 0.5 * width - 0.5
    signs, cos_dh, sin_dh, cos_sdh, sin_sdh, shift, cos_l, sin_l = _strip_constants(orders, kappa, n_strips, ndim)
    d_half = np.empty((n_signs, n_orders))  # the orders' half-angle shifts (for the series' distance to a pole)
    for s in range(n_signs):
        for q in range(n_orders):
            d_half[s, q] = 0.5 * math.pi * width * orders[q, n_k]
            for a in range(n_k):
                d_half[s, q] += 0.25 * math.pi * width * signs[s, a] * kappa[a] * orders[q, a]
    h_const = (-1j) ** n_k / (2.0 * math.pi) ** n_k
    out = np.zeros((2 * ndim - 1, n), dtype=np.complex128)
    t = np.empty(n_orders, dtype=np.complex128)
    t_l = np.empty(n_orders, dtype=np.complex128)
    t_a = np.empty((n_orders, max(n_k, 1)), dtype=np.complex128)
    t_k = np.empty((n_orders, max(n_k, 1)), dtype=np.complex128)
    near = np.empty(n_orders, dtype=np.bool_)
    x = np.empty(ndim)
    node = np.empty(ndim)
    d_x = np.empty(ndim, dtype=np.complex128)
    d_k = np.empty(max(n_k, 1), dtype=np.complex128)
    weights = (-1.0 / 6.0, 2.0 / 3.0, 2.0 / 3.0, -1.0 / 6.0)  # Lagrange, nodes -2, -1, 1, 2 (times NODE), at 0
    for i in range(n):
        for q in range(n_orders):
            near[q] = False
            for a in range(n_k):
                if abs(c[a, i] + 0.5 * orders[q, a]) < NEAR_X:
                    near[q] = True
            t[q] = 0j
            t_l[q] = 0j
            for a in range(n_k):
                t_a[q, a] = 0j
                t_k[q, a] = 0j
        last = c[n_k, i]
        for s in range(n_signs):
            half, phase = _strip_angles(c[:, i], signs[s], kappa, n_strips)
            sh, ch = math.sin(half), math.cos(half)
            ssh, csh = math.sin(n_strips * half), math.cos(n_strips * half)
            rot = complex(math.cos(phase), math.sin(phase))
            for q in range(n_orders):
                if near[q]:
                    continue
                d, dd = _dirichlet(
                    half + d_half[s, q],
                    sh * cos_dh[s, q] + ch * sin_dh[s, q],
                    ch * cos_dh[s, q] - sh * sin_dh[s, q],
                    ssh * cos_sdh[s, q] + csh * sin_sdh[s, q],
                    csh * cos_sdh[s, q] - ssh * sin_sdh[s, q],
                    n_strips,
                )
                e = rot * shift[s, q]  # the signs' product included
                t[q] += e * d
                t_l[q] += e * (dd * math.pi * width + 1j * d * (2.0 * math.pi * u0 + (n_strips - 1) * math.pi * width))
                for a in range(n_k):
                    sg = signs[s, a]
                    h_a = 0.5 * math.pi * width * sg
                    t_a[q, a] += e * (
                        dd * h_a * kappa[a]
                        + 1j * d * (math.pi * sg * (1.0 + kappa[a] * u0) + (n_strips - 1) * h_a * kappa[a])
                    )
                    t_k[q, a] += (e * (c[a, i] + 0.5 * orders[q, a])) * (
                        dd * h_a + 1j * d * (math.pi * sg * u0 + (n_strips - 1) * h_a)
                    )
        s_l, c_l = math.sin(math.pi * width * last), math.cos(math.pi * width * last)
        for q in range(n_orders):
            if near[q]:  # the four nodes move every keystoned coordinate within NEAR_X of 0 by the same t
                for a in range(ndim):
                    x[a] = c[a, i] + 0.5 * orders[q, a]
                for w_i in range(4):
                    step = (w_i - 2 if w_i < 2 else w_i - 1) * NODE
                    for a in range(ndim):
                        node[a] = x[a] + step if a < n_k and abs(x[a]) < NEAR_X else x[a]
                    _derivatives_at(node, kappa, n_strips, d_x, d_k)
                    for a in range(ndim):
                        out[a, i] += weights[w_i] * coef[q] * d_x[a]
                    for a in range(n_k):
                        out[ndim + a, i] += weights[w_i] * coef[q] * d_k[a]
                continue
            x_l = last + 0.5 * orders[q, n_k]
            g, dg = _last_factor(x_l, s_l * cos_l[q] + c_l * sin_l[q], c_l * cos_l[q] - s_l * sin_l[q], width)
            h = h_const
            for a in range(n_k):
                h /= c[a, i] + 0.5 * orders[q, a]
            gh = coef[q] * g * h
            for a in range(n_k):
                out[a, i] += (t_a[q, a] - t[q] / (c[a, i] + 0.5 * orders[q, a])) * gh
                out[ndim + a, i] += t_k[q, a] * gh
            out[n_k, i] += coef[q] * (t_l[q] * g + t[q] * dg) * h
    return out


def _points(rng: np.random.Generator, ndim: int, strips: int) -> np.ndarray:
    """Ridge coordinates with the kernel's special points: removable singularities of an order and within
    1e-7 of one, the last axis' zero and near it, Dirichlet poles and within the series' reach of them (and
    just beyond), a keystoned axis within NEAR_X of its zero."""
    c = rng.uniform(-60, 60, size=(ndim, 3000))
    c[:, :300] = rng.uniform(-3, 3, size=(ndim, 300))
    c[0, 300:320] = 0.5
    c[0, 320:340] = 0.5 + 1e-9
    c[-1, 340:360] = 0.0
    c[-1, 360:380] = rng.uniform(-1e-4, 1e-4, 20)
    c[-1, 380:400] = 0.5 * strips + rng.uniform(-1e-3, 1e-3, 20)
    c[-1, 400:420] = strips + rng.uniform(-2e-2, 2e-2, 20)  # |sin h| around the series' threshold
    c[0, 420:460] = 0.5 + rng.uniform(-1e-3, 1e-3, 40)
    return c


def _bits(a: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(a).view(np.uint64)


@pytest.mark.parametrize("ndim", [2, 3])
@pytest.mark.parametrize("keystone", [0.0, 0.003, -0.15])
def test_keystone_derivatives_equal_the_per_order_loop_bit_for_bit(ndim, keystone):
    """The vectorised kernel on evaluate's orders (2D: the 57 of a Hamming-weighted image's fits) and on
    points at every special case: the same bits as the per-order complex loop, zeros' signs included."""
    rng = np.random.default_rng(5)
    orders = np.ascontiguousarray(spectral_orders(ndim, 4 if ndim == 2 else 1, 5 if ndim == 2 else 2), dtype=np.int64)
    kappa = np.linspace(keystone, 0.5 * keystone, ndim - 1)
    strips = _strip_count(kappa)
    coef = rng.normal(size=len(orders)) + 1j * rng.normal(size=len(orders))
    c = _points(rng, ndim, strips)
    want = _per_order_derivatives(c, orders, coef, kappa, strips)
    got = rk.keystone_derivatives(c, orders, coef, kappa, strips)
    assert np.isfinite(got).all()
    assert np.array_equal(_bits(got), _bits(want))


@pytest.mark.parametrize(("terms", "grid"), [(5, 34), (1000, 64), (2500, 201), (40000, 200)])
def test_compiled_spread_is_the_numpy_grid(terms, grid, monkeypatch):
    """The compiled spreading of a line sum's terms: numpy's grid bit for bit, over several blocks of terms
    too (the block size lowered so that 2500 terms take three), terms at the grid's ends and at 0 included."""
    monkeypatch.setattr(linesum, "_BLOCK", 1000)
    assert residual_aot.spread_kernels() is not None  # the compiled path runs (numba's kernels are loaded)
    rng = np.random.default_rng(terms)
    coef = rng.normal(size=terms) + 1j * rng.normal(size=terms)
    x = rng.uniform(-np.pi, np.pi, terms)
    x[:3] = [-np.pi, 0.0, math.nextafter(np.pi, 0.0)]
    got, want = linesum._spread(coef, x, grid), linesum._spread_numpy(coef, x, grid)
    # on every machine: numpy's SIMD exp (AVX-512 builds) would round its last bit otherwise than libm's, which
    # numba calls; the reference takes libm's (linesum._libm_exp)
    assert np.array_equal(_bits(got), _bits(want))


def test_libm_exp_is_libms_exp():
    """The numpy reference's exp gives libm's bits (math.exp's) where numpy's own exp does not (AVX-512)."""
    z = np.random.default_rng(0).uniform(-40.0, 0.0, 100_000)
    z[:3] = [0.0, -40.0, -1e-300]
    want = np.array([math.exp(v) for v in z])
    assert np.array_equal(_bits(linesum._libm_exp(z)), _bits(want))


@pytest.mark.parametrize(
    ("func", "lo", "hi"),
    [
        (lambda b: (b - 0.0123) ** 2 + 1.0, -0.1, 0.1),
        (lambda b: math.cos(40.0 * b) + 0.3 * b, -0.2, 0.05),
        (lambda b: abs(b + 0.07) ** 0.5, -0.1, 0.0),
        (lambda b: 1.0, 0.0, 0.1),
        (lambda b: -b, -0.04, 0.04),
    ],
)
def test_bounded_minimum_is_scipys(func, lo, hi):
    """The bounded scalar search the bow's fit uses: scipy's point and value exactly (minimum inside, at a
    bound, on a flat function, several local minima)."""
    scipy_optimize = pytest.importorskip("scipy.optimize")
    calls: list[float] = []

    def counted(b: float) -> float:
        calls.append(float(b))
        return func(b)

    found = scipy_optimize.minimize_scalar(counted, bounds=(lo, hi), method="bounded", options={"xatol": 2e-4})
    theirs, calls[:] = list(calls), []
    x, fx = _bounded_minimum(counted, lo, hi, 2e-4)
    assert calls == theirs
    assert (x, fx) == (float(found.x), float(found.fun))
