"""The residual's kernels (:mod:`sarproc.quality.residual_kernels`) compiled ahead of time.

Those kernels are serial in numba too (no parallel loops), so the module compiled ahead of time
(:mod:`sarproc.product.aot`) runs them as fast, and an ``evaluate`` of a 2D image, once it is built (in the
background, on the first run), imports no numba: ~0.3 s of numba's start-up and the cached kernels' loading saved
per process. Both compile the same source without fast-math, so the results are equal bit for bit
(tests/quality/test_residual_aot.py). Importing this module imports no numba.
"""

from __future__ import annotations

import sys
from types import ModuleType

import numpy as np

from sarproc.product.aot import Kernels

RESIDUAL = Kernels(
    name="residual",
    module="sarproc.quality.residual_kernels",
    sources=("quality/residual_kernels.py", "quality/residual_aot.py"),
    exports={
        "keystone_columns": "c16[:, ::1](f8[:, ::1], i8[:, ::1], f8[::1], i8)",
        "keystone_box_sum": "c16[:, ::1](f8[::1], f8[::1], f8[::1], i8, i8, i8[:, ::1], c16[::1], f8[::1], i8)",
        "keystone_warped_box_sum": "c16[:, ::1](f8[::1], f8[::1], f8[::1], f8[::1], f8[::1], f8[::1], i8, i8, "
        "i8[:, ::1], c16[::1], f8[::1], i8, f8[::1])",
        "keystone_derivatives": "c16[:, ::1](f8[:, ::1], i8[:, ::1], c16[::1], f8[::1], i8)",
        "spread_bins": "f8[:, ::1](f8[::1], f8[::1], f8[::1], f8[::1], i8, i8, f8, i8)",
    },
    owner="sarproc.quality.residual_aot:RESIDUAL",
)


def kernels() -> ModuleType:
    """The module to call the residual's kernels from: the compiled one where it is built, else numba's.
    No serial budget is spent (:meth:`Kernels.pick` with 0 s): numba's kernels are serial as well, so the
    compiled module is never the slower."""
    return RESIDUAL.pick(0.0)


def spread_kernels() -> ModuleType | None:
    """The module to spread a line sum's terms with (:func:`spread_bins`) where one is at hand without starting
    numba: numba's where its kernels are loaded already, else the compiled one where it is built; else None
    (then :func:`sarproc.quality.linesum._spread_numpy`, the same bits: a cube's evaluate, which needs only the
    quality module's kernels, loads neither)."""
    loaded = sys.modules.get(RESIDUAL.module)
    return loaded if loaded is not None else RESIDUAL.load()


def _f8(x: object) -> np.ndarray:
    return np.ascontiguousarray(x, dtype=np.float64)


def _i8(x: object) -> np.ndarray:
    return np.ascontiguousarray(x, dtype=np.int64)


def _c16(x: object) -> np.ndarray:
    return np.ascontiguousarray(x, dtype=np.complex128)


def keystone_columns(c: np.ndarray, orders: np.ndarray, kappa: np.ndarray, n_strips: int) -> np.ndarray:
    """:func:`sarproc.quality.residual_kernels.keystone_columns` (the same arguments, any layout)."""
    return kernels().keystone_columns(_f8(c), _i8(orders), _f8(kappa), int(n_strips))


def keystone_box_sum(
    c0: np.ndarray,
    d_row: np.ndarray,
    d_col: np.ndarray,
    n_rows: int,
    n_cols: int,
    orders: np.ndarray,
    coef: np.ndarray,
    kappa: np.ndarray,
    n_strips: int,
) -> np.ndarray:
    """:func:`sarproc.quality.residual_kernels.keystone_box_sum` (the same arguments, any layout)."""
    return kernels().keystone_box_sum(
        _f8(c0),
        _f8(d_row),
        _f8(d_col),
        int(n_rows),
        int(n_cols),
        _i8(orders),
        _c16(coef),
        _f8(kappa),
        int(n_strips),
    )


def keystone_warped_box_sum(
    c0: np.ndarray,
    d_row: np.ndarray,
    d_col: np.ndarray,
    w_rr: np.ndarray,
    w_rc: np.ndarray,
    w_cc: np.ndarray,
    n_rows: int,
    n_cols: int,
    orders: np.ndarray,
    coef: np.ndarray,
    kappa: np.ndarray,
    n_strips: int,
    carrier: np.ndarray,
) -> np.ndarray:
    """:func:`sarproc.quality.residual_kernels.keystone_warped_box_sum` (the same arguments, any layout)."""
    return kernels().keystone_warped_box_sum(
        _f8(c0),
        _f8(d_row),
        _f8(d_col),
        _f8(w_rr),
        _f8(w_rc),
        _f8(w_cc),
        int(n_rows),
        int(n_cols),
        _i8(orders),
        _c16(coef),
        _f8(kappa),
        int(n_strips),
        _f8(carrier),
    )


def keystone_derivatives(
    c: np.ndarray, orders: np.ndarray, coef: np.ndarray, kappa: np.ndarray, n_strips: int
) -> np.ndarray:
    """:func:`sarproc.quality.residual_kernels.keystone_derivatives` (the same arguments, any layout)."""
    return kernels().keystone_derivatives(_f8(c), _i8(orders), _c16(coef), _f8(kappa), int(n_strips))


def spread_bins(
    c_re: np.ndarray,
    c_im: np.ndarray,
    u: np.ndarray,
    first: np.ndarray,
    grid_size: int,
    taps: int,
    beta: float,
    block: int,
) -> np.ndarray:
    """:func:`sarproc.quality.residual_kernels.spread_bins` (the same arguments, any layout)."""
    k = spread_kernels() or kernels()
    return k.spread_bins(_f8(c_re), _f8(c_im), _f8(u), _f8(first), int(grid_size), int(taps), float(beta), int(block))
