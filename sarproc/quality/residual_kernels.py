"""Compiled kernel (numba) of the residual's keystoned response: every order's strip sum at each point.

Computes what :func:`sarproc.quality.residual._keystone_columns` (numpy, the reference) computes, to
rounding (tests/quality/test_residual_reach.py): per point the sines and cosines are taken once per sign and
each order costs a few multiplications (angle addition), without numpy's temporaries. Imported only when
the residual is asked for.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from sarproc.product.kernel_cache import CACHE, lean_cache_loads


@numba.njit(error_model="numpy", cache=CACHE)
def _product_at(x: np.ndarray, kappa: np.ndarray, n_strips: int) -> complex:  # pragma: no cover - compiled
    """The strip sum at shifted coordinates x (ndim,): :func:`sarproc.quality.residual._keystone_product`."""
    ndim = x.shape[0]
    width = 1.0 / n_strips
    u0 = 0.5 * width - 0.5
    last = x[ndim - 1]
    total = 0j
    for s in range(1 << (ndim - 1)):
        theta = 2.0 * math.pi * width * last
        phase = 2.0 * math.pi * u0 * last
        sign = 1.0
        for a in range(ndim - 1):
            sg = 1.0 - 2.0 * ((s >> a) & 1)
            sign *= sg
            xa = x[a] if abs(x[a]) >= 1e-7 else 1e-7
            theta += math.pi * width * sg * kappa[a] * xa
            phase += math.pi * sg * (1.0 + kappa[a] * u0) * xa
        half = 0.5 * theta
        sn = math.sin(half)
        if abs(sn) < 1e-9:
            dirichlet = n_strips * math.cos(n_strips * half) / math.cos(half)
        else:
            dirichlet = math.sin(n_strips * half) / sn
        angle = phase + (n_strips - 1) * half
        total += sign * dirichlet * complex(math.cos(angle), math.sin(angle))
    arg = width * last
    sinc = 1.0 if arg == 0.0 else math.sin(math.pi * arg) / (math.pi * arg)
    den = 1.0 + 0j
    for a in range(ndim - 1):
        xa = x[a] if abs(x[a]) >= 1e-7 else 1e-7
        den *= 2j * math.pi * xa
    return total * width * sinc / den


@numba.njit(error_model="numpy", cache=CACHE)
def keystone_columns(
    c: np.ndarray, orders: np.ndarray, kappa: np.ndarray, n_strips: int
) -> np.ndarray:  # pragma: no cover - compiled
    """(K, N) complex: the strip sum of order ``orders[k]`` at each column of ``c`` ((ndim, N) ridge
    coordinates in nulls), a keystone ``kappa`` (ndim - 1) and ``n_strips`` strips."""
    ndim, n = c.shape
    n_orders = orders.shape[0]
    n_signs = 1 << (ndim - 1)
    width = 1.0 / n_strips
    u0 = 0.5 * width - 0.5
    # per sign and order: the constant angle shifts of :func:`residual._keystone_columns`
    cos_dh = np.empty((n_signs, n_orders))
    sin_dh = np.empty((n_signs, n_orders))
    cos_sdh = np.empty((n_signs, n_orders))
    sin_sdh = np.empty((n_signs, n_orders))
    shift = np.empty((n_signs, n_orders), dtype=np.complex128)
    signs = np.empty((n_signs, ndim))
    for s in range(n_signs):
        prod = 1.0
        for a in range(ndim - 1):
            signs[s, a] = 1.0 - 2.0 * ((s >> a) & 1)
            prod *= signs[s, a]
        signs[s, ndim - 1] = prod
        for q in range(n_orders):
            n_l = orders[q, ndim - 1]
            d_half = 0.5 * math.pi * width * n_l
            d_phase = math.pi * u0 * n_l
            for a in range(ndim - 1):
                d_half += 0.25 * math.pi * width * signs[s, a] * kappa[a] * orders[q, a]
                d_phase += 0.5 * math.pi * signs[s, a] * (1.0 + kappa[a] * u0) * orders[q, a]
            d_phase += (n_strips - 1) * d_half
            cos_dh[s, q], sin_dh[s, q] = math.cos(d_half), math.sin(d_half)
            cos_sdh[s, q], sin_sdh[s, q] = math.cos(n_strips * d_half), math.sin(n_strips * d_half)
            shift[s, q] = prod * complex(math.cos(d_phase), math.sin(d_phase))
    cos_l = np.empty(n_orders)
    sin_l = np.empty(n_orders)
    for q in range(n_orders):
        cos_l[q] = math.cos(0.5 * math.pi * width * orders[q, ndim - 1])
        sin_l[q] = math.sin(0.5 * math.pi * width * orders[q, ndim - 1])
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
        if near:  # within 1e-7 of a removable singularity: the direct product evaluates the limit
            for q in range(n_orders):
                for a in range(ndim):
                    x[a] = c[a, i] + 0.5 * orders[q, a]
                out[q, i] = _product_at(x, kappa, n_strips)
            continue
        last = c[ndim - 1, i]
        for q in range(n_orders):
            acc[q] = 0j
        for s in range(n_signs):
            half = math.pi * width * last
            phase = 2.0 * math.pi * u0 * last
            for a in range(ndim - 1):
                half += 0.5 * math.pi * width * signs[s, a] * kappa[a] * c[a, i]
                phase += math.pi * signs[s, a] * (1.0 + kappa[a] * u0) * c[a, i]
            phase += (n_strips - 1) * half
            sh, ch = math.sin(half), math.cos(half)
            ssh, csh = math.sin(n_strips * half), math.cos(n_strips * half)
            rot = complex(math.cos(phase), math.sin(phase))
            for q in range(n_orders):
                den = sh * cos_dh[s, q] + ch * sin_dh[s, q]
                if abs(den) < 1e-9:  # sin(S h) / sin(h) -> S cos(S h) / cos(h)
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
            # width sinc(width x_l) / prod_a (2 j pi x_a): one real division; 1 / (2 j pi)^(ndim - 1) is
            # (-j / (2 pi))^(ndim - 1)
            den = 1.0
            for a in range(ndim - 1):
                den *= c[a, i] + 0.5 * orders[q, a]
            den *= two_pi_pow
            factor = width / den if small else (s_l * cos_l[q] + c_l * sin_l[q]) / (math.pi * x_l * den)
            out[q, i] = acc[q] * factor * j_pow
    return out


lean_cache_loads(globals())  # cached kernels load without numba's context refresh (kernel_cache)
