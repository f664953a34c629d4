"""Compiled copies around the FFTs of fine focusing (rows in parallel, one pass each).

Each kernel replaces a numpy sequence of the block loops of :mod:`sarproc.focus.squint_deramp.fine_focus`
(zero padding, a (-1)^n modulation, a per-row or per-column factor, a transposed write-back) by one
parallel pass that computes the same values: negation is exact and the complex multiplies round as numpy's
SIMD loop does (:func:`sarproc.dsp.phasor_kernels.cmul`), so the image does not change.

"Alternate" means x[..., j] negated for j % 2 == ``start`` (the (-1)^n modulation that turns an
fftshift of an even-length axis into a sign flip, see ``fine_focus._centred``); ``start`` < 0: none.
"""

from __future__ import annotations

import numba
import numpy as np

from sarproc.dsp.kernel_cache import CACHE, lean_cache_loads
from sarproc.dsp.phasor_kernels import cmul


@numba.njit(inline="always", cache=CACHE)
def _alternate(v: complex, j: int, start: int) -> complex:
    """v negated where j % 2 == start (the (-1)^n modulation)."""
    return -v if j % 2 == start else v


@numba.njit(inline="always", cache=CACHE)
def _spectrum_entry(src: np.ndarray, i: int, j: int, factor: np.ndarray, start: int, scaled: bool) -> complex:
    """alternate(src[i, j]) times factor[j] when ``scaled``, rounded as numpy's complex multiply."""
    v = _alternate(src[i, j], j, start)
    if scaled:
        re, im = cmul(v, factor[j])
        v = complex(re, im)
    return v


@numba.njit(parallel=True, cache=CACHE)
def pad_rows(src: np.ndarray, dst: np.ndarray, start: int) -> None:
    """dst[i, :n] = alternate(src[i]), dst[i, n:] = 0 (n = src.shape[1] <= dst.shape[1])."""
    n = src.shape[1]
    m = dst.shape[1]
    if src.shape[0] != dst.shape[0] or n > m:
        raise ValueError("pad_rows: dst needs src's rows and at least its columns")
    for i in numba.prange(dst.shape[0]):
        for j in range(n):
            dst[i, j] = _alternate(src[i, j], j, start)
        for j in range(n, m):
            dst[i, j] = 0


@numba.njit(parallel=True, cache=CACHE)
def scale_rows(x: np.ndarray, factor: np.ndarray, start: int) -> None:
    """x[i, j] = alternate(x[i, j] * factor[i]) in place."""
    for i in numba.prange(x.shape[0]):
        f = factor[i]
        for j in range(x.shape[1]):
            re, im = cmul(x[i, j], f)
            if j % 2 == start:
                re, im = -re, -im
            x[i, j] = complex(re, im)


@numba.njit(parallel=True, cache=CACHE)
def copy_rows(src: np.ndarray, dst: np.ndarray, start: int) -> None:
    """dst[i, j] = alternate(src[i, j]) (same shapes)."""
    if src.shape[0] != dst.shape[0] or src.shape[1] != dst.shape[1]:
        raise ValueError("copy_rows: src and dst must have the same shape")
    for i in numba.prange(src.shape[0]):
        for j in range(src.shape[1]):
            dst[i, j] = _alternate(src[i, j], j, start)


@numba.njit(parallel=True, cache=CACHE)
def pad_spectrum(src: np.ndarray, dst: np.ndarray, factor: np.ndarray, start: int) -> None:
    """Zero-pad FFT-ordered rows: dst[i] holds the first (n+1)//2 and the last n//2 samples of
    f(src[i]) (f(v)_j = alternate(v_j) * factor[j], factor of src's length; ``factor`` of length 0: none) at
    the two ends of its longer axis, zeros between. src (rows, n), dst (rows, m), m >= n."""
    n = src.shape[1]
    m = dst.shape[1]
    hi = (n + 1) // 2
    lo = n // 2
    scaled = factor.shape[0] > 0
    if src.shape[0] != dst.shape[0] or n > m or (scaled and factor.shape[0] != n):
        raise ValueError("pad_spectrum: dst needs src's rows and at least its columns, factor src's length or none")
    for i in numba.prange(dst.shape[0]):
        for j in range(hi):
            dst[i, j] = _spectrum_entry(src, i, j, factor, start, scaled)
        for j in range(hi, m - lo):
            dst[i, j] = 0
        for jj in range(lo):
            dst[i, m - lo + jj] = _spectrum_entry(src, i, n - lo + jj, factor, start, scaled)


@numba.njit(parallel=True, cache=CACHE)
def gather_columns(src: np.ndarray, cols: np.ndarray, dst: np.ndarray, offset: int) -> None:
    """dst[k, offset + i] = src[i, cols[k]]: selected columns of src written back as rows (transposed)."""
    n = src.shape[0]
    if len(cols) > dst.shape[0] or offset < 0 or offset + n > dst.shape[1]:
        raise ValueError("gather_columns: dst[:len(cols), offset:offset + src rows] is out of bounds")
    for k in range(len(cols)):
        if cols[k] < 0 or cols[k] >= src.shape[1]:
            raise ValueError("gather_columns: a column index is outside src")
    for k in numba.prange(len(cols)):
        c = cols[k]
        for i in range(n):
            dst[k, offset + i] = src[i, c]


@numba.njit(parallel=True, cache=CACHE)
def _crop_rows(src: np.ndarray, lo: int, dst: np.ndarray, bad: np.ndarray) -> None:
    n = dst.shape[1]
    for i in numba.prange(dst.shape[0]):
        b = False
        for j in range(n):
            v = src[i, lo + j]
            dst[i, j] = v
            if not (np.isfinite(v.real) and np.isfinite(v.imag)):
                b = True
        bad[i] = b


@numba.njit(parallel=True, cache=CACHE)
def negate_alternate_2d(x: np.ndarray, axis: int, start: int) -> None:
    """x negated on every second row (axis 0) or column (axis 1), from ``start``, in place."""
    n, m = x.shape
    if axis == 0:
        for i in numba.prange(n):
            if i % 2 == start:
                for j in range(m):
                    x[i, j] = -x[i, j]
    else:
        for i in numba.prange(n):
            for j in range(start, m, 2):
                x[i, j] = -x[i, j]


lean_cache_loads(globals())  # cached kernels load without numba's context refresh (kernel_cache)
