"""Fast unit phasors from float64 phase kept in cycles."""

from __future__ import annotations

import numba
import numpy as np

_TWO_PI32 = np.float32(2 * np.pi)


def unit_phasor(cycles: np.ndarray) -> np.ndarray:
    """exp(j 2 pi cycles) as complex64 for cycles already reduced to [0, 1) (or any unit interval).

    The float64 phase is reduced to cycles by the caller (that is where float64 matters: 4 pi R / lambda
    reaches 1e8 rad); the reduced value is then carried in float32 and float32 cos/sin write straight
    into the output: error below 1e-6 rad, several times faster than numpy's complex exponential.
    """
    ph = np.array(cycles, dtype=np.float32)
    ph *= _TWO_PI32
    out = np.empty(ph.shape, np.complex64)
    np.cos(ph, out=out.real)
    np.sin(ph, out=out.imag)
    return out


# ---- compiled, fused phase fields (numba): phase in float64, reduced to cycles, then float32 -------------------

_INV_TWO_PI = 1.0 / (2 * np.pi)


@numba.njit(fastmath=True, error_model="numpy", cache=True)
def cis_cycles32(c):
    """(cos, sin)(2 pi c) for float32 c with |c| <= 1/2: Taylor polynomials after reduction to a quarter cycle
    (|error| < 2e-7; vectorisable, no libm call)."""
    k = np.floor(c * np.float32(2.0) + np.float32(0.5))                  # nearest half cycle: -1, 0 or 1
    r = c - k * np.float32(0.5)                                           # |r| <= 1/4
    sgn = np.float32(1.0) - np.float32(2.0) * k * k                       # (-1)^k
    z = r * np.float32(2 * np.pi)
    z2 = z * z
    s = z * (np.float32(1.0) - z2 * np.float32(1 / 6) * (np.float32(1.0) - z2 * np.float32(1 / 20) * (
        np.float32(1.0) - z2 * np.float32(1 / 42) * (np.float32(1.0) - z2 * np.float32(1 / 72) * (
            np.float32(1.0) - z2 * np.float32(1 / 110) * (np.float32(1.0) - z2 * np.float32(1 / 156)))))))
    co = np.float32(1.0) - z2 * np.float32(0.5) * (np.float32(1.0) - z2 * np.float32(1 / 12) * (
        np.float32(1.0) - z2 * np.float32(1 / 30) * (np.float32(1.0) - z2 * np.float32(1 / 56) * (
            np.float32(1.0) - z2 * np.float32(1 / 90) * (np.float32(1.0) - z2 * np.float32(1 / 132) * (
                np.float32(1.0) - z2 * np.float32(1 / 182)))))))
    return co * sgn, s * sgn


@numba.njit(parallel=True, fastmath=True, error_model="numpy", cache=True)
def _separable_kernel(x, rows, cols, scale):
    n, m = x.shape
    k_terms = rows.shape[0]
    for i in numba.prange(n):
        for j in range(m):
            ph = 0.0
            for k in range(k_terms):
                ph += rows[k, i] * cols[k, j]
            c = ph * scale
            c -= np.floor(c + 0.5)
            co, si = cis_cycles32(np.float32(c))
            v = x[i, j]
            x[i, j] = complex(v.real * co - v.imag * si, v.real * si + v.imag * co)


@numba.njit(parallel=True, fastmath=True, error_model="numpy", cache=True)
def _field_kernel(x, phase, mask, use_mask, scale):
    n, m = x.shape
    for i in numba.prange(n):
        for j in range(m):
            if use_mask and not mask[i, j]:
                x[i, j] = 0
                continue
            c = phase[i, j] * scale
            c -= np.floor(c + 0.5)
            co, si = cis_cycles32(np.float32(c))
            v = x[i, j]
            x[i, j] = complex(v.real * co - v.imag * si, v.real * si + v.imag * co)


def multiply_separable_phase(x: np.ndarray, rows, cols, *, cycles: bool = False) -> np.ndarray:
    """x[i, j] *= exp(j sum_k rows[k][i] cols[k][j]) in place (x: 2D complex); returns x.

    The phase field is never stored: each element's phase is summed in float64, reduced to cycles and
    turned into a float32 phasor inside one parallel loop. ``cycles``: the sum is in cycles, not radians.
    """
    rows = np.ascontiguousarray(np.atleast_2d(np.asarray(rows, float)))
    cols = np.ascontiguousarray(np.atleast_2d(np.asarray(cols, float)))
    if rows.shape != (len(cols), x.shape[0]) or cols.shape[1] != x.shape[1]:
        raise ValueError(f"rows {rows.shape} / cols {cols.shape} do not match x {x.shape}")
    _separable_kernel(x, rows, cols, 1.0 if cycles else _INV_TWO_PI)
    return x


def multiply_phase(x: np.ndarray, phase: np.ndarray, mask: np.ndarray | None = None, *, scale: float = 1.0,
                   cycles: bool = False) -> np.ndarray:
    """x *= where(mask, exp(j scale phase), 0) in place (x, phase, mask: same 2D shape; phase float64)."""
    phase = np.broadcast_to(np.asarray(phase, float), x.shape)
    m = np.broadcast_to(mask if mask is not None else np.ones((1, 1), bool), x.shape)
    _field_kernel(x, phase, m, mask is not None, scale * (1.0 if cycles else _INV_TWO_PI))
    return x
