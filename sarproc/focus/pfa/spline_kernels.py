"""The compiled (numba) kernel of :mod:`sarproc.focus.pfa.correction`: a cubic spline read on fixed columns.

Kept apart from the correction's functions so that a process running it compiled ahead of time
(:data:`sarproc.focus.pfa.correction.AOT`) imports no numba.
"""

from __future__ import annotations

import numba
import numpy as np

from sarproc.dsp.kernel_cache import CACHE, lean_cache_loads


@numba.njit(parallel=True, fastmath=False, cache=CACHE)
def _column_spline_kernel(t: np.ndarray, columns: np.ndarray, x: np.ndarray, out: np.ndarray) -> None:
    """out[r, j] = the cubic spline on knots t with coefficients columns[j] at x[r, j] (clamped to the knots);
    the weights by FITPACK's fpbspl recursion written out for degree 3, rows in parallel."""
    n = len(t)
    lo_x, hi_x = t[3], t[n - 4]
    for r in numba.prange(x.shape[0]):
        for j in range(x.shape[1]):
            xv = min(max(x[r, j], lo_x), hi_x)
            lo, hi = 3, n - 5  # the interval l with t[l] <= x < t[l + 1] (the last one includes its end)
            while lo < hi:
                mid = (lo + hi + 1) // 2
                if t[mid] <= xv:
                    lo = mid
                else:
                    hi = mid - 1
            span = lo
            # degree 1
            f = 1.0 / (t[span + 1] - t[span])
            h0 = f * (t[span + 1] - xv)
            h1 = f * (xv - t[span])
            # degree 2
            f = h0 / (t[span + 1] - t[span - 1])
            g0 = f * (t[span + 1] - xv)
            g1 = f * (xv - t[span - 1])
            f = h1 / (t[span + 2] - t[span])
            g1 += f * (t[span + 2] - xv)
            g2 = f * (xv - t[span])
            # degree 3
            f = g0 / (t[span + 1] - t[span - 2])
            w0 = f * (t[span + 1] - xv)
            w1 = f * (xv - t[span - 2])
            f = g1 / (t[span + 2] - t[span - 1])
            w1 += f * (t[span + 2] - xv)
            w2 = f * (xv - t[span - 1])
            f = g2 / (t[span + 3] - t[span])
            w2 += f * (t[span + 3] - xv)
            w3 = f * (xv - t[span])
            c = columns[j]
            i = span - 3
            out[r, j] = w0 * c[i] + w1 * c[i + 1] + w2 * c[i + 2] + w3 * c[i + 3]


lean_cache_loads(globals())  # cached kernels load without numba's context refresh (kernel_cache)
