"""Compiled kernels of evaluate (numba): the chip's values along a line, the orientation density of the
support's edges and the ideal response of a neighbour. Each computes what its numpy reference in
:mod:`sarproc.quality.metrics` computes (``EvaluateParams(exact=True)`` takes those), to rounding.

Line values. A chip's trigonometric interpolant on the line ``x0 + t v`` is a sum of complex
exponentials in t with non-uniform frequencies ``w_k = f_k . v`` (one per chip bin); at uniformly spaced
offsets it is a type-1 non-uniform FFT: each bin is spread onto a twice-oversampled uniform grid with
an "exponential of semicircle" kernel (Barnett, Magland, af Klinteberg 2019, the finufft kernel),
one FFT, and the kernel's Fourier transform divided out. With 16 kernel points the error is about
1e-14 of the coefficients' sum, against a direct sum costing chip size x offsets operations.
"""

from __future__ import annotations

import math

import numba
import numpy as np
import scipy.fft

from sarproc.dsp.kernel_cache import CACHE

_SPREAD = 16  # kernel points per bin
_BETA = 2.30 * _SPREAD  # kernel shape (finufft's choice for an oversampling of 2)


@numba.njit(error_model="numpy", fastmath=True, cache=CACHE)
def _spread(
    coef: np.ndarray, x: np.ndarray, grid_size: int, spread: int, beta: float
) -> np.ndarray:  # pragma: no cover - compiled
    """Sum of coef[k] phi((l - x[k] grid_size / 2 pi) / (spread / 2)) on the periodic grid l (phi = 0 for
    |z| >= 1). The grid is padded by spread + 1 points on both sides and folded at the end, so the inner
    loop has no wrap-around."""
    pad = spread + 1
    out = np.zeros(grid_size + 2 * pad, dtype=np.complex128)
    half = spread / 2.0
    weights = np.empty(spread + 1)
    for k in range(coef.size):
        u = x[k] * grid_size / (2.0 * math.pi)
        if u < 0.0:  # x in [-pi, pi): grid position in [0, grid_size)
            u += grid_size
        first = math.ceil(u - half)
        for i in range(spread + 1):
            z = (first + i - u) / half
            z2 = min(z * z, 1.0)
            weights[i] = math.exp(beta * (math.sqrt(1.0 - z2) - 1.0)) if z2 < 1.0 else 0.0
        base = first + pad
        ck = coef[k]
        for i in range(spread + 1):
            out[base + i] += ck * weights[i]
    folded = out[pad : pad + grid_size].copy()
    folded[grid_size - pad :] += out[:pad]
    folded[:pad] += out[pad + grid_size :]
    return folded


def _kernel_transform(m: np.ndarray, grid_size: int) -> np.ndarray:
    """Fourier transform of the spreading kernel at integer frequencies m (Gauss-Legendre quadrature)."""
    z, w = np.polynomial.legendre.leggauss(4 * _SPREAD + 40)
    alpha = math.pi * _SPREAD / grid_size  # kernel half-width, rad
    phi = np.exp(_BETA * (np.sqrt(1.0 - z**2) - 1.0))
    return alpha * (np.cos(np.outer(m, alpha * z)) @ (w * phi))


def exponential_sums(coef: np.ndarray, freq: np.ndarray, first: float, step: float, count: int) -> np.ndarray:
    """sum_k coef[k] exp(2 pi i freq[k] (first + j step)) for j = 0..count-1 (complex128)."""
    coef = np.asarray(coef, dtype=np.complex128).ravel()
    freq = np.asarray(freq, dtype=float).ravel()
    centre = count // 2  # output index m = j - centre runs over [-centre, count - centre)
    grid_size = max(2 * count, 2 * _SPREAD + 2)
    grid_size += grid_size % 2
    x = np.mod(2 * np.pi * freq * step + np.pi, 2 * np.pi) - np.pi  # rad per output step, in [-pi, pi)
    c = coef * np.exp(2j * np.pi * freq * (first + centre * step))
    b = _spread(c, x, grid_size, _SPREAD, _BETA)
    m = np.arange(count) - centre
    # sum_l b_l exp(i m l h), h = 2 pi / grid_size, is (1/h) psi_hat(m) sum_k c_k exp(i m x_k)
    spectrum = scipy.fft.ifft(b, workers=-1)[m % grid_size] * grid_size
    return spectrum * (2 * np.pi / grid_size) / _kernel_transform(m, grid_size)


@numba.njit(error_model="numpy", parallel=True, cache=CACHE)
def orientation_density(
    cand: np.ndarray, u: np.ndarray, weight: np.ndarray, sigma: float
) -> np.ndarray:  # pragma: no cover - compiled
    """sum_j weight[j] exp((cos^2 - 1) / 2 sigma^2) over unit vectors u[j] at each candidate cand[i],
    terms below exp(-40) of their weight left out (the numpy reference's pruning)."""
    out = np.zeros(cand.shape[0])
    floor = 1.0 - 80.0 * sigma * sigma
    scale = 1.0 / (2.0 * sigma * sigma)
    for i in numba.prange(cand.shape[0]):
        s = 0.0
        for j in range(u.shape[0]):
            d = 0.0
            for a in range(u.shape[1]):
                d += cand[i, a] * u[j, a]
            d2 = d * d
            if d2 > floor:
                s += math.exp((d2 - 1.0) * scale) * weight[j]
        out[i] = s
    return out


@numba.njit(error_model="numpy", cache=CACHE)
def _shape(q: float, hamming: bool) -> float:  # pragma: no cover - compiled
    if hamming:
        return 0.54 * _sinc(q) + 0.23 * (_sinc(q - 1.0) + _sinc(q + 1.0))
    return _sinc(q)


@numba.njit(error_model="numpy", cache=CACHE)
def _sinc(q: float) -> float:  # pragma: no cover - compiled
    if q == 0.0:
        return 1.0
    return math.sin(math.pi * q) / (math.pi * q)


@numba.njit(error_model="numpy", cache=CACHE)
def _ideal_at(
    points: np.ndarray, k: int, position: np.ndarray, ridge: np.ndarray, f_c: np.ndarray, hamming: bool
) -> complex:  # pragma: no cover - compiled
    ndim = points.shape[0]
    amp = 1.0
    phase = 0.0
    for a in range(ndim):
        c = 0.0
        for b in range(ndim):
            c += ridge[a, b] * (points[b, k] - position[b])
        amp *= _shape(c, hamming)
        phase += f_c[a] * (points[a, k] - position[a])
    phase *= 2.0 * math.pi
    return complex(amp * math.cos(phase), amp * math.sin(phase))


@numba.njit(error_model="numpy", parallel=True, cache=CACHE)
def ideal_response(
    points: np.ndarray, position: np.ndarray, ridge: np.ndarray, f_c: np.ndarray, hamming: bool
) -> np.ndarray:  # pragma: no cover - compiled
    """prod_a shape((ridge @ (x - position))_a) exp(2 pi i f_c . (x - position)) at each column x of
    points (ndim, N): the ideal response of :func:`sarproc.quality.metrics._ideal_response`, ``ridge``
    the matrix taking image-index offsets to ridge coordinates in nulls."""
    n = points.shape[1]
    out = np.empty(n, dtype=np.complex128)
    for k in numba.prange(n):
        out[k] = _ideal_at(points, k, position, ridge, f_c, hamming)
    return out
