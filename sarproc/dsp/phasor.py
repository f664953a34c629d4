"""Fast unit phasors from float64 phase kept in cycles."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numba
import numpy as np

from sarproc.dsp.kernel_cache import CACHE, lean_cache_loads
from sarproc.dsp.numpy_phasor import unit_phasor as unit_phasor  # re-exported: the kernels' callers use it too

if TYPE_CHECKING:
    import numpy.typing as npt


@numba.njit(inline="always")
def cmul(a: complex, b: complex) -> tuple[float, float]:
    """(re, im) of a * b (float64) rounded as numpy's SIMD complex64 loop rounds them, for compiled kernels that
    must reproduce a numpy product: re = fma(a_r, b_r, -a_i b_i), im = fma(a_r, b_i, a_i b_r) with the second
    product rounded to the inputs' precision; the fused one is exact in float64 for float32 inputs, so storing
    the pair into a complex64 array rounds once, as the FMA does (complex128 inputs: the plain products)."""
    re = np.float64(a.real) * np.float64(b.real) - np.float64(a.imag * b.imag)
    im = np.float64(a.real) * np.float64(b.imag) + np.float64(a.imag * b.real)
    return re, im


# ---- compiled, fused phase fields (numba): phase in float64, reduced to cycles, then float32 -------------------

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


def multiply_separable_phase(
    x: np.ndarray, rows: npt.ArrayLike, cols: npt.ArrayLike, *, cycles: bool = False
) -> np.ndarray:
    """x[i, j] *= exp(j sum_k rows[k][i] cols[k][j]) in place (x: 2D complex); returns x.

    The phase field is never stored: each element's phase is summed in float64, reduced to cycles and
    turned into a float32 phasor inside one parallel loop. ``cycles``: the sum is in cycles, not radians.
    """
    rows, cols = (np.ascontiguousarray(np.atleast_2d(np.asarray(v, float))) for v in (rows, cols))
    if rows.shape != (len(cols), x.shape[0]) or cols.shape[1] != x.shape[1] or len(rows) > 4:
        raise ValueError(f"rows {rows.shape} / cols {cols.shape} do not match x {x.shape} (at most 4 terms)")
    if len(rows) < 4:  # the kernel takes exactly four terms
        rows = np.concatenate([rows, np.zeros((4 - len(rows), rows.shape[1]))])
        cols = np.concatenate([cols, np.zeros((4 - len(cols), cols.shape[1]))])
    flat = x if x.flags.c_contiguous else np.ascontiguousarray(x)
    _separable_kernel(flat.view(flat.real.dtype).reshape(x.shape[0], -1), rows, cols, 1.0 if cycles else _INV_TWO_PI)
    if flat is not x:
        x[...] = flat
    return x


def multiply_phase(
    x: np.ndarray, phase: np.ndarray, mask: np.ndarray | None = None, *, scale: float = 1.0, cycles: bool = False
) -> np.ndarray:
    """x *= where(mask, exp(j scale phase), 0) in place (x, phase, mask: same 2D shape; phase float64)."""
    phase = np.broadcast_to(np.asarray(phase, float), x.shape)
    m = np.broadcast_to(mask if mask is not None else np.ones((1, 1), bool), x.shape)
    flat = x if x.flags.c_contiguous else np.ascontiguousarray(x)
    _field_kernel(
        flat.view(flat.real.dtype).reshape(x.shape[0], -1),
        phase,
        m,
        mask is not None,
        scale * (1.0 if cycles else _INV_TWO_PI),
    )
    if flat is not x:
        x[...] = flat
    return x


lean_cache_loads(globals())  # cached kernels load without numba's context refresh (kernel_cache)
