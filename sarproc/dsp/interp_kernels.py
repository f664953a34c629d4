"""The compiled (numba) row resampling of :mod:`sarproc.dsp.interp`: each row's taps summed in one loop, rows in
parallel.

Kept apart from :mod:`sarproc.dsp.interp`'s functions so that a process running the kernels compiled ahead of
time (:data:`sarproc.dsp.interp.AOT`) imports no numba.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from sarproc.dsp.kernel_cache import CACHE, lean_cache_loads


@numba.njit(fastmath=True, error_model="numpy", cache=CACHE)
def _resample_row(
    row: np.ndarray,
    pos: np.ndarray,
    out: np.ndarray,
    mode: int,
    taps: int,
    table: np.ndarray,
    steps: int,
    zero: complex,
    lo_pos: float,
    hi_pos: float,
) -> None:
    """One row: out[j] = sum over taps of row[i] w(pos[j] - i); zeros outside the row; pos outside
    [lo_pos, hi_pos] (or NaN) gives ``zero``. Tabulated weights are renormalised to unit sum."""
    n_in = len(row)
    half = taps // 2
    for j in range(len(out)):
        p = pos[j]
        if not (p >= lo_pos and p <= hi_pos):
            out[j] = zero
            continue
        acc = zero
        if mode == 0:
            b = int(math.floor(p + 0.5))
            if b >= 0 and b < n_in:
                acc += row[b]
        elif mode == 1:
            b = int(math.floor(p))
            f = table.dtype.type(p - b)
            if b >= 0 and b < n_in:
                acc += row[b] * (1 - f)
            if b + 1 >= 0 and b + 1 < n_in:
                acc += row[b + 1] * f
        elif mode == 2:
            b = int(math.floor(p))
            for off in range(-1, 3):
                i = b + off
                if i >= 0 and i < n_in:
                    x = abs(table.dtype.type(p - i))  # Keys' cubic convolution, a = -0.5
                    if x <= 1:
                        w = (1.5 * x - 2.5) * x * x + 1
                    elif x < 2:
                        w = ((-0.5 * x + 2.5) * x - 4) * x + 2
                    else:
                        w = 0.0 * x
                    acc += row[i] * w
        else:
            b = int(math.floor(p))
            q = (p - b) * steps
            cell = int(math.floor(q))
            t = table.dtype.type(q - cell)
            wsum = table.dtype.type(0)
            # tap m reads sample b + 1 - half + m; its weights at this cell and the next are contiguous rows
            # of ``table`` (see resample_rows), so the tap loop is a short dot product
            first = b + 1 - half
            if first >= 0 and first + taps <= n_in:
                for m in range(taps):
                    w = table[cell, m] + (table[cell + 1, m] - table[cell, m]) * t
                    wsum += w
                    acc += row[first + m] * w
            else:
                for m in range(taps):
                    w = table[cell, m] + (table[cell + 1, m] - table[cell, m]) * t
                    wsum += w
                    i = first + m
                    if i >= 0 and i < n_in:
                        acc += row[i] * w
            if wsum > 0:
                acc = acc / wsum
        out[j] = acc


@numba.njit(parallel=True, error_model="numpy", cache=CACHE)
def _resample_kernel(
    data: np.ndarray,
    pos: np.ndarray,
    out: np.ndarray,
    mode: int,
    taps: int,
    table: np.ndarray,
    steps: int,
    zero: complex,
    lo_pos: float,
    hi_pos: float,
) -> None:
    """Rows in parallel (the per-row work is a separate function: no accumulator is shared across rows)."""
    for r in numba.prange(data.shape[0]):
        _resample_row(data[r], pos[r], out[r], mode, taps, table, steps, zero, lo_pos, hi_pos)


lean_cache_loads(globals())  # cached kernels load without numba's context refresh (kernel_cache)
