"""The compiled (numba) phase kernels of :mod:`sarproc.dsp.phasor`: fused phase fields (phase in float64,
reduced to cycles, then a float32 phasor) and the phasor polynomials other kernels inline.

Kept apart from :mod:`sarproc.dsp.phasor`'s functions so that a process running the kernels compiled ahead of
time (:data:`sarproc.dsp.phasor.AOT`) imports no numba.
"""

from __future__ import annotations

import numba
import numpy as np

from sarproc.dsp.kernel_cache import CACHE, lean_cache_loads


@numba.njit(inline="always")
def cmul(a: complex, b: complex) -> tuple[float, float]:
    """(re, im) of a * b (float64) rounded as numpy's SIMD complex64 loop rounds them, for compiled kernels that
    must reproduce a numpy product: re = fma(a_r, b_r, -a_i b_i), im = fma(a_r, b_i, a_i b_r) with the second
    product rounded to the inputs' precision; the fused one is exact in float64 for float32 inputs, so storing
    the pair into a complex64 array rounds once, as the FMA does (complex128 inputs: the plain products)."""
    re = np.float64(a.real) * np.float64(b.real) - np.float64(a.imag * b.imag)
    im = np.float64(a.real) * np.float64(b.imag) + np.float64(a.imag * b.real)
    return re, im


_INV_TWO_PI = 1.0 / (2 * np.pi)


@numba.njit(fastmath=True, error_model="numpy", cache=CACHE)
def cis_cycles32(c: np.float32) -> tuple[np.float32, np.float32]:
    """(cos, sin)(2 pi c) for float32 c with |c| <= 1/2: Taylor polynomials after reduction to a quarter cycle
    (|error| < 2e-7; vectorisable, no libm call)."""
    k = np.floor(c * np.float32(2.0) + np.float32(0.5))  # nearest half cycle: -1, 0 or 1
    r = c - k * np.float32(0.5)  # |r| <= 1/4
    sgn = np.float32(1.0) - np.float32(2.0) * k * k  # (-1)^k
    z = r * np.float32(2 * np.pi)
    z2 = z * z
    s = z * (
        np.float32(1.0)
        - z2
        * np.float32(1 / 6)
        * (
            np.float32(1.0)
            - z2
            * np.float32(1 / 20)
            * (
                np.float32(1.0)
                - z2
                * np.float32(1 / 42)
                * (
                    np.float32(1.0)
                    - z2
                    * np.float32(1 / 72)
                    * (np.float32(1.0) - z2 * np.float32(1 / 110) * (np.float32(1.0) - z2 * np.float32(1 / 156)))
                )
            )
        )
    )
    co = np.float32(1.0) - z2 * np.float32(0.5) * (
        np.float32(1.0)
        - z2
        * np.float32(1 / 12)
        * (
            np.float32(1.0)
            - z2
            * np.float32(1 / 30)
            * (
                np.float32(1.0)
                - z2
                * np.float32(1 / 56)
                * (
                    np.float32(1.0)
                    - z2
                    * np.float32(1 / 90)
                    * (np.float32(1.0) - z2 * np.float32(1 / 132) * (np.float32(1.0) - z2 * np.float32(1 / 182)))
                )
            )
        )
    )
    return co * sgn, s * sgn


# Least-squares minimax fits on a quarter cycle x in [0, 1/4]: sin(2 pi x) = x S(x^2), cos(2 pi x) = C(x^2).
_S1, _S3, _S5, _S7 = (
    np.float32(6.283164041287987),
    np.float32(-41.33714204522236),
    np.float32(81.3407593445843),
    np.float32(-70.99335072437377),
)
_C0, _C2, _C4, _C6, _C8 = (
    np.float32(0.9999999536449741),
    np.float32(-19.739171470711653),
    np.float32(64.9345926398633),
    np.float32(-85.24037245345428),
    np.float32(56.242676066224355),
)


@numba.njit(fastmath=True, error_model="numpy", cache=CACHE)
def cis_cycles32_short(c: np.float32) -> tuple[np.float32, np.float32]:
    """(cos, sin)(2 pi c) for float32 c with |c| <= 1/2 from shorter minimax polynomials (9 multiply-adds, no
    half-cycle rounding): |error| < 1e-6, i.e. -120 dB, for hot loops where that is far below float32 geometry."""
    a = np.abs(c)
    far = a > np.float32(0.25)
    x = np.float32(0.5) - a if far else a  # cos(2 pi (1/2 - x)) = -cos(2 pi x), sin unchanged
    x2 = x * x
    s = x * (_S1 + x2 * (_S3 + x2 * (_S5 + x2 * _S7)))
    co = _C0 + x2 * (_C2 + x2 * (_C4 + x2 * (_C6 + x2 * _C8)))
    return (-co if far else co), (-s if c < np.float32(0.0) else s)


@numba.njit(fastmath=True, error_model="numpy", cache=CACHE)
def _rotate_row(
    xr: np.ndarray,
    a0: float,
    a1: float,
    a2: float,
    a3: float,
    c0: np.ndarray,
    c1: np.ndarray,
    c2: np.ndarray,
    c3: np.ndarray,
    scale: float,
) -> None:
    """xr (2m interleaved re, im) *= exp(j 2 pi scale (a0 c0 + a1 c1 + a2 c2 + a3 c3)); vectorisable."""
    for j in range(len(c0)):
        c = (a0 * c0[j] + a1 * c1[j] + a2 * c2[j] + a3 * c3[j]) * scale
        c -= np.floor(c + 0.5)
        co, si = cis_cycles32(np.float32(c))
        re = xr[2 * j]
        im = xr[2 * j + 1]
        xr[2 * j] = re * co - im * si
        xr[2 * j + 1] = re * si + im * co


@numba.njit(parallel=True, error_model="numpy", cache=CACHE)
def _separable_kernel(xf: np.ndarray, rows: np.ndarray, cols: np.ndarray, scale: float) -> None:
    """Rows of xf (n, 2m) float view of complex data; rows (4, n), cols (4, m) float64."""
    for i in numba.prange(xf.shape[0]):
        _rotate_row(xf[i], rows[0, i], rows[1, i], rows[2, i], rows[3, i], cols[0], cols[1], cols[2], cols[3], scale)


@numba.njit(fastmath=True, error_model="numpy", cache=CACHE)
def _rotate_row_field(xr: np.ndarray, phase: np.ndarray, mask: np.ndarray, use_mask: bool, scale: float) -> None:
    for j in range(len(phase)):
        c = phase[j] * scale
        c -= np.floor(c + 0.5)
        co, si = cis_cycles32(np.float32(c))
        if use_mask and not mask[j]:
            co = np.float32(0.0)
            si = np.float32(0.0)
        re = xr[2 * j]
        im = xr[2 * j + 1]
        xr[2 * j] = re * co - im * si
        xr[2 * j + 1] = re * si + im * co


rotate_row_field = _rotate_row_field
"""Compiled building block of :func:`multiply_phase` for callers' own kernels: one row ``xr`` (float view,
2m interleaved re, im) times where(mask, exp(j 2 pi scale phase), 0) (``use_mask`` False: no mask)."""


@numba.njit(parallel=True, error_model="numpy", cache=CACHE)
def _field_kernel(xf: np.ndarray, phase: np.ndarray, mask: np.ndarray, use_mask: bool, scale: float) -> None:
    for i in numba.prange(xf.shape[0]):
        _rotate_row_field(xf[i], phase[i], mask[i], use_mask, scale)


lean_cache_loads(globals())  # cached kernels load without numba's context refresh (kernel_cache)
