"""Fast unit phasors from float64 phase kept in cycles.

The compiled kernels live in :mod:`sarproc.dsp.phasor_kernels` (numba); a small complex64 field runs them
compiled ahead of time (:data:`AOT`, :mod:`sarproc.product.aot`) without importing numba.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from sarproc.dsp.numpy_phasor import unit_phasor as unit_phasor  # re-exported: the kernels' callers use it too
from sarproc.product.aot import Kernels

if TYPE_CHECKING:
    import numpy.typing as npt

_INV_TWO_PI = 1.0 / (2 * np.pi)

AOT = Kernels(
    name="phasor",
    module="sarproc.dsp.phasor_kernels",
    sources=("dsp/phasor_kernels.py", "dsp/phasor.py"),
    exports={"_separable_kernel": "void(f4[:, ::1], f8[:, ::1], f8[:, ::1], f8)"},
    owner="sarproc.dsp.phasor:AOT",
)
# Serial elements per second of the separable kernel (complex64), for AOT.pick: an estimate, not a measurement
# (docs/performance.md, fifth round); it only moves where the process's serial budget runs out.
SEPARABLE_SERIAL_RATE = 1.5e8


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
    k = AOT.pick(x.size / SEPARABLE_SERIAL_RATE, usable=flat.dtype == np.complex64)
    k._separable_kernel(flat.view(flat.real.dtype).reshape(x.shape[0], -1), rows, cols, 1.0 if cycles else _INV_TWO_PI)
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
    from sarproc.dsp import phasor_kernels

    phasor_kernels._field_kernel(
        flat.view(flat.real.dtype).reshape(x.shape[0], -1),
        phase,
        m,
        mask is not None,
        scale * (1.0 if cycles else _INV_TWO_PI),
    )
    if flat is not x:
        x[...] = flat
    return x
