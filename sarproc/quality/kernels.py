"""Compiled kernels of evaluate (numba) for 3D cubes: the orientation density of the support's edges and the
ideal response of a neighbour. Each computes what its numpy reference in :mod:`sarproc.quality.metrics`
computes (``EvaluateParams(exact=True)`` takes those), to rounding. Imported only for 3D images: loading
numba and the cached kernels costs about a second, more than 2D images gain from them.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from sarproc.product.kernel_cache import CACHE, lean_cache_loads


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


@numba.njit(error_model="numpy", cache=CACHE)
def _grid_shape(s: float, q: float, hamming: bool) -> float:  # pragma: no cover - compiled
    """_shape(q) given s = sin(pi q) (sin(pi (q -+ 1)) = -s); near q = 0 from math.sin itself, where s / (pi q)
    would lose digits to the rounding of s."""
    if abs(q) < 1e-3:
        return _shape(q, hamming)
    value = s / (math.pi * q)
    if hamming:
        lo = 1.0 if q == 1.0 else -s / (math.pi * (q - 1.0))
        hi = 1.0 if q == -1.0 else -s / (math.pi * (q + 1.0))
        return 0.54 * value + 0.23 * (lo + hi)
    return value


@numba.njit(error_model="numpy", parallel=True, cache=CACHE)
def ideal_response_box(
    origin: np.ndarray, shape: np.ndarray, position: np.ndarray, ridge: np.ndarray, f_c: np.ndarray, hamming: bool
) -> np.ndarray:  # pragma: no cover - compiled
    """:func:`ideal_response` of a 3D response on the image box origin + (i, j, k), i < shape[0] ...: the
    ridge coordinates are linear on the box, so sin(pi c_a) and the carrier are products of per-axis complex
    exponentials (9 + 3 short tables instead of 4 transcendental calls per sample; equal to rounding)."""
    n0, n1, n2 = shape[0], shape[1], shape[2]
    sizes = (n0, n1, n2)
    longest = max(n0, max(n1, n2))
    rot = np.empty((3, 3, longest), dtype=np.complex128)  # exp(i pi ridge[a, b] d_b)
    lin = np.empty((3, 3, longest))  # ridge[a, b] d_b
    car = np.empty((3, longest), dtype=np.complex128)  # exp(2 pi i f_c[b] d_b)
    for b in range(3):
        for i in range(sizes[b]):
            d = origin[b] + i - position[b]
            car[b, i] = complex(math.cos(2.0 * math.pi * f_c[b] * d), math.sin(2.0 * math.pi * f_c[b] * d))
            for a in range(3):
                lin[a, b, i] = ridge[a, b] * d
                rot[a, b, i] = complex(math.cos(math.pi * lin[a, b, i]), math.sin(math.pi * lin[a, b, i]))
    out = np.empty((n0, n1, n2), dtype=np.complex128)
    for i in numba.prange(n0):
        for j in range(n1):
            for k in range(n2):
                amp = 1.0
                for a in range(3):
                    q = lin[a, 0, i] + lin[a, 1, j] + lin[a, 2, k]
                    s = (rot[a, 0, i] * rot[a, 1, j] * rot[a, 2, k]).imag
                    amp *= _grid_shape(s, q, hamming)
                out[i, j, k] = amp * (car[0, i] * car[1, j] * car[2, k])
    return out


lean_cache_loads(globals())  # cached kernels load without numba's context refresh (kernel_cache)
