"""The median and the distinct values of an array, as numpy computes them, without importing ``numpy.ma``.

``np.median`` checks its result for NaN and ``np.unique`` its input for a mask through ``numpy.ma``, whose
import the first call pays: 10-25 ms of a process's start here (``-X importtime``), for the median spacing of a
few hundred samples (backproject's response theory, pfa2's k spacing) or the distinct indices of a few dozen
survey rows (simulate, backproject, fine-focus) (docs/performance.md, fourteenth round).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt


def median(values: npt.ArrayLike) -> float:
    """``float(np.median(values))`` bit for bit: the middle value of the sorted values, or ``np.mean`` of the
    two middle ones (in the values' own dtype, as np.median's), NaN where any value is NaN."""
    v = np.sort(np.asarray(values).ravel())
    n = v.size
    if n == 0:
        raise ValueError("median of no values")
    if v.dtype.kind in "fc" and np.isnan(v[-1]):  # sorting puts NaN last
        return float("nan")
    return float(np.mean(v[(n - 1) // 2 : n // 2 + 1]))


def unique_integers(values: npt.ArrayLike) -> np.ndarray:
    """``np.unique(values)`` of integers: the distinct values, sorted, in the values' dtype."""
    v = np.sort(np.asarray(values).ravel())
    if v.dtype.kind not in "iub":
        raise TypeError(f"unique_integers of {v.dtype} values")
    keep = np.empty(v.size, dtype=bool)
    keep[:1] = True
    np.not_equal(v[1:], v[:-1], out=keep[1:])
    return v[keep]
