"""The compiled (numba) kernels of :mod:`sarproc.focus.squint_deramp.stolt`: the fused rotation by G and the
Stolt mapping's node interpolation, rows in parallel.

Kept apart from :mod:`sarproc.focus.squint_deramp.stolt` so that a process running them compiled ahead of time
(:data:`sarproc.focus.squint_deramp.compiled.STOLT`) imports no numba.
"""

from __future__ import annotations

import numba
import numpy as np

from sarproc.dsp.kernel_cache import CACHE, lean_cache_loads
from sarproc.dsp.phasor_kernels import cmul, rotate_row_field


@numba.njit(parallel=True, error_model="numpy", cache=CACHE)
def _rotate_G(
    xf: np.ndarray,
    x: np.ndarray,
    pre: np.ndarray,
    use_pre: bool,
    a: np.ndarray,
    q: np.ndarray,
    b: np.ndarray,
    p: np.ndarray,
    mode: int,
    s: float,
    s2: float,
    c: float,
    lim: float,
    scale: float,
) -> None:
    """Rows of :meth:`SpectrumModel.rotate`; the float64 sums are written in :meth:`SpectrumModel.G`'s order
    (no fastmath: same values): exact sigma = s + a_i / b_j, g = p_j (s^2 + c root) + q_i; paper
    t = a_i / b_j, g = p_j root + q_i (q_i carries the minus sign)."""
    m = len(b)
    for i in numba.prange(x.shape[0]):
        g = np.empty(m)
        ok = np.empty(m, np.bool_)
        ai = a[i]
        qi = q[i]
        for j in range(m):
            if mode == 0:
                sigma = s + ai / b[j]
                arg = 1 - sigma * sigma
            else:
                t = ai / b[j]
                arg = 1 - t * t
            good = arg > lim
            root = np.sqrt(arg if good else 1.0)
            if mode == 0:
                g[j] = p[j] * (s2 + c * root) + qi
            else:
                g[j] = p[j] * root + qi
            ok[j] = good
        if use_pre:
            for j in range(m):
                re, im = cmul(x[i, j], pre[j])  # rounded as numpy's x * pre
                x[i, j] = complex(re, im)
        rotate_row_field(xf[i], g, ok, True, scale)


@numba.njit(parallel=True, error_model="numpy", cache=CACHE)
def _node_positions(
    s_n: np.ndarray,
    ok_n: np.ndarray,
    seg: np.ndarray,
    w: np.ndarray,
    f0: float,
    df: float,
    half_band: float,
    out: np.ndarray,
) -> None:
    """out[i, j]: sample position (f - f0) / df of the source frequency, linear between the exact nodes
    seg[j], seg[j] + 1 (weight w[j]); NaN where a node is invalid or the source is outside the band."""
    for i in numba.prange(out.shape[0]):
        for j in range(out.shape[1]):
            k = seg[j]
            src = s_n[i, k] * (1.0 - w[j]) + s_n[i, k + 1] * w[j]
            if ok_n[i, k] and ok_n[i, k + 1] and abs(src) <= half_band:
                out[i, j] = (src - f0) / df
            else:
                out[i, j] = np.nan


lean_cache_loads(globals())  # cached kernels load without numba's context refresh (kernel_cache)
