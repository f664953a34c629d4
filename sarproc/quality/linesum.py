"""Sums of complex exponentials at uniformly spaced points: a chip's values along a line.

A chip's trigonometric interpolant on the line ``x0 + t v`` is a sum of complex exponentials in t with
non-uniform frequencies ``w_k = f_k . v`` (one per chip bin); at uniformly spaced offsets that is a
type-1 non-uniform FFT: each term is spread onto a twice-oversampled uniform grid with an "exponential
of semicircle" kernel (Barnett, Magland, af Klinteberg 2019, the finufft kernel), one FFT, and the
kernel's Fourier transform divided out. With 16 kernel points the error is about 1e-14 of the terms'
sum (1e-13 of a response's peak), against a direct sum costing terms x points operations.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from sarproc.product import fft as sfft

_SPREAD = 16  # kernel points per term
_BETA = 2.30 * _SPREAD  # kernel shape (finufft's choice for an oversampling of 2)
_BLOCK = 1 << 15  # terms spread at once (bounds the (terms, 17) temporaries)


def _spread(coef: np.ndarray, x: np.ndarray, grid_size: int) -> np.ndarray:
    """sum_k coef[k] phi((l - u_k) / (spread / 2)) on the periodic grid l, u_k = x_k grid_size / 2 pi
    (phi = 0 beyond its support): :func:`_spread_numpy`'s grid bit for bit, compiled
    (:func:`sarproc.quality.residual_kernels.spread_bins`; a campaign scene's cuts spent 3 s of CPU in it)."""
    from sarproc.quality import residual_aot

    if residual_aot.spread_kernels() is None:  # neither built nor loaded: numba is not started for it
        return _spread_numpy(coef, x, grid_size)
    u = np.mod(x * grid_size / (2 * np.pi), grid_size)
    first = np.ceil(u - _SPREAD / 2.0)
    bins = residual_aot.spread_bins(coef.real, coef.imag, u, first, grid_size, _SPREAD, _BETA, _BLOCK)
    return bins[0] + 1j * bins[1]


def _spread_numpy(coef: np.ndarray, x: np.ndarray, grid_size: int) -> np.ndarray:
    """:func:`_spread` in numpy (the reference)."""
    half = _SPREAD / 2.0
    taps = np.arange(_SPREAD + 1)
    re = np.zeros(grid_size)
    im = np.zeros(grid_size)
    for start in range(0, coef.size, _BLOCK):
        c, u = coef[start : start + _BLOCK], np.mod(x[start : start + _BLOCK] * grid_size / (2 * np.pi), grid_size)
        first = np.ceil(u - half)
        z2 = np.minimum(((first[:, None] + taps - u[:, None]) / half) ** 2, 1.0)
        w = _libm_exp(_BETA * (np.sqrt(1.0 - z2) - 1.0)) * (z2 < 1.0)
        idx = ((first.astype(np.int64)[:, None] + taps) % grid_size).ravel()
        re += np.bincount(idx, weights=(c.real[:, None] * w).ravel(), minlength=grid_size)
        im += np.bincount(idx, weights=(c.imag[:, None] * w).ravel(), minlength=grid_size)
    return re + 1j * im


def _libm_exp(x: np.ndarray) -> np.ndarray:
    """exp(x) of real x as libm rounds it, as the compiled kernel's ``math.exp`` does: numpy's own exp of a float64
    array is a SIMD loop on AVX-512 machines that rounds some 5 % of values one ulp otherwise (then the first
    evaluation in a process, spreading here before numba's kernels load, differed from the later ones in the last
    bits). numpy's complex exp calls libm's cexp, whose real part at a zero imaginary part is libm's exp(x) times
    cos(0) = 1: the same bits on every machine (tests/quality/test_evaluate_fast_paths.py)."""
    return np.exp(x.astype(np.complex128)).real


@functools.cache
def _gauss_legendre() -> tuple[np.ndarray, np.ndarray]:
    """The 40 Gauss-Legendre nodes and weights on [-1, 1] (computed once: each costs 0.5 ms)."""
    return np.polynomial.legendre.leggauss(40)


@functools.lru_cache(maxsize=64)
def _kernel_transform(count: int, centre: int, grid_size: int) -> np.ndarray:
    """Fourier transform of the spreading kernel at the integer frequencies m = -centre .. count - centre - 1
    (Gauss-Legendre quadrature, 40 nodes: 3e-14, as with 400; the transform is even, so taken once per |m|;
    cached: the cuts of one image ask for a few sizes)."""
    z, w = _gauss_legendre()
    alpha = math.pi * _SPREAD / grid_size  # kernel half-width, rad
    phi = np.exp(_BETA * (np.sqrt(1.0 - z**2) - 1.0))
    m = np.arange(count) - centre
    half = alpha * (np.cos(np.outer(np.arange(max(centre, count - centre) + 1), alpha * z)) @ (w * phi))
    out = half[np.abs(m)]
    out.flags.writeable = False
    return out


def exponential_sums(
    coef: np.ndarray, freq: np.ndarray, first: float, step: float, count: int, compiled: bool = False
) -> np.ndarray:
    """sum_k coef[k] exp(2 pi i freq[k] (first + j step)) for j = 0..count-1 (complex128). ``compiled``: spread
    with the numba kernel (3D chips, where numba is loaded anyway; twice as fast, the same terms)."""
    coef = np.asarray(coef, dtype=np.complex128).ravel()
    freq = np.asarray(freq, dtype=float).ravel()
    centre = count // 2  # output index m = j - centre runs over [-centre, count - centre)
    grid_size = max(2 * count, 2 * _SPREAD + 2)
    grid_size += grid_size % 2
    x = np.mod(2 * np.pi * freq * step + np.pi, 2 * np.pi) - np.pi  # rad per output step, in [-pi, pi)
    c = coef * np.exp(2j * np.pi * freq * (first + centre * step))
    if compiled:
        from sarproc.quality import kernels_aot

        k = kernels_aot.kernels()
        b = k.spread(c, kernels_aot.f8(x), grid_size, _SPREAD, _BETA, kernels_aot.threads(k))
    else:
        b = _spread(c, x, grid_size)
    m = np.arange(count) - centre
    # sum_l b_l exp(i m l h), h = 2 pi / grid_size, is (1/h) psi_hat(m) sum_k c_k exp(i m x_k)
    spectrum = sfft.ifft(b, workers=-1)[m % grid_size] * grid_size
    return spectrum * (2 * np.pi / grid_size) / _kernel_transform(count, centre, grid_size)
