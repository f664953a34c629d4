"""Fine focusing's compiled kernels, numba's or compiled ahead of time (:mod:`sarproc.product.aot`).

The block copies (:mod:`sarproc.focus.squint_deramp.block_copies`) and the Stolt kernels
(:mod:`sarproc.focus.squint_deramp.stolt_kernels`) are numba kernels; a small product's calls (complex64,
C-contiguous) run them compiled ahead of time, serially, without importing numba, once the modules are built (in
the background, on the first small run): :meth:`sarproc.product.aot.Kernels.pick` decides per call within the
process's budget of serial work. Same source either way (prange as range, each row's values computed alike), so
the images are equal (tests/focus/test_fine_focus_aot.py). Importing this module imports no numba.
"""

from __future__ import annotations

from types import ModuleType

import numpy as np
import numpy.typing as npt

from sarproc.product.aot import Kernels

_BLOCK_SIG = "void(c8[:, ::1], c8[:, ::1], i8)"
BLOCKS = Kernels(
    name="block_copies",
    module="sarproc.focus.squint_deramp.block_copies",
    sources=("focus/squint_deramp/block_copies.py", "dsp/phasor_kernels.py", "focus/squint_deramp/compiled.py"),
    exports={
        "pad_rows": _BLOCK_SIG,
        "copy_rows": _BLOCK_SIG,
        "scale_rows": "void(c8[:, ::1], c8[::1], i8)",
        "negate_alternate_2d": "void(c8[:, ::1], i8, i8)",
        "_crop_rows": "void(c8[:, ::1], i8, c8[:, ::1], b1[::1])",
    },
    owner="sarproc.focus.squint_deramp.compiled:BLOCKS",
)
STOLT = Kernels(
    name="stolt",
    module="sarproc.focus.squint_deramp.stolt_kernels",
    sources=("focus/squint_deramp/stolt_kernels.py", "dsp/phasor_kernels.py", "focus/squint_deramp/compiled.py"),
    exports={
        "_rotate_G": "void(f4[:, ::1], c8[:, ::1], c8[::1], b1, f8[::1], f8[::1], f8[::1], f8[::1], i8, f8, f8, f8, "
        "f8, f8)",
        "_node_positions": "void(f8[:, ::1], b1[:, ::1], i8[::1], f8[::1], f8, f8, f8, f8[:, ::1])",
    },
    owner="sarproc.focus.squint_deramp.compiled:STOLT",
)
# Serial elements per second (estimates, not measurements: docs/performance.md, fifth round): the copies, the
# rotation by G (a square root and a phasor each), the node interpolation.
COPY_SERIAL_RATE = 5e8
ROTATE_SERIAL_RATE = 1e8
NODES_SERIAL_RATE = 3e8


def _c8(*arrays: np.ndarray) -> bool:
    return all(a.dtype == np.complex64 and a.flags.c_contiguous for a in arrays)


def _blocks(elements: int, *arrays: np.ndarray) -> ModuleType:
    return BLOCKS.pick(elements / COPY_SERIAL_RATE, usable=_c8(*arrays))


def pad_rows(src: np.ndarray, dst: np.ndarray, start: int) -> None:
    """:func:`sarproc.focus.squint_deramp.block_copies.pad_rows`."""
    _blocks(dst.size, src, dst).pad_rows(src, dst, int(start))


def scale_rows(x: np.ndarray, factor: np.ndarray, start: int) -> None:
    """:func:`sarproc.focus.squint_deramp.block_copies.scale_rows`."""
    _blocks(x.size, x, factor).scale_rows(x, factor, int(start))


def copy_rows(src: np.ndarray, dst: np.ndarray, start: int) -> None:
    """:func:`sarproc.focus.squint_deramp.block_copies.copy_rows`."""
    _blocks(dst.size, src, dst).copy_rows(src, dst, int(start))


def negate_alternate_2d(x: np.ndarray, axis: int, start: int) -> None:
    """:func:`sarproc.focus.squint_deramp.block_copies.negate_alternate_2d`."""
    _blocks(x.size, x).negate_alternate_2d(x, int(axis), int(start))


def pad_spectrum(src: np.ndarray, dst: np.ndarray, factor: np.ndarray, start: int) -> None:
    """:func:`sarproc.focus.squint_deramp.block_copies.pad_spectrum` (numba's)."""
    BLOCKS.numba().pad_spectrum(src, dst, factor, start)


def gather_columns(src: np.ndarray, cols: np.ndarray, dst: np.ndarray, offset: int) -> None:
    """:func:`sarproc.focus.squint_deramp.block_copies.gather_columns` (numba's)."""
    BLOCKS.numba().gather_columns(src, cols, dst, offset)


def crop_columns(src: np.ndarray, lo: int, hi: int, dtype: npt.DTypeLike = np.complex64) -> tuple[np.ndarray, bool]:
    """(src[:, lo:hi] as a new C-contiguous ``dtype`` array, whether every value is finite), one parallel pass."""
    dst = np.empty((src.shape[0], hi - lo), dtype)
    bad = np.zeros(src.shape[0], np.bool_)
    if dst.size:
        _blocks(dst.size, src, dst)._crop_rows(src, int(lo), dst, bad)
    return dst, not bad.any()


def rotate_G(
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
    """:func:`sarproc.focus.squint_deramp.stolt_kernels._rotate_G` (the arguments of
    :meth:`sarproc.focus.squint_deramp.stolt.SpectrumModel.rotate`)."""
    a, q, b, p = (np.ascontiguousarray(v, float) for v in (a, q, b, p))
    usable = _c8(x, pre) and all(v.ndim == 1 for v in (a, q, b, p))
    k = STOLT.pick(x.size / ROTATE_SERIAL_RATE, usable=usable)
    k._rotate_G(
        xf, x, pre, bool(use_pre), a, q, b, p, int(mode), float(s), float(s2), float(c), float(lim), float(scale)
    )


def node_positions(
    s_n: np.ndarray,
    ok_n: np.ndarray,
    seg: np.ndarray,
    w: np.ndarray,
    f0: float,
    df: float,
    half_band: float,
    out: np.ndarray,
) -> None:
    """:func:`sarproc.focus.squint_deramp.stolt_kernels._node_positions`."""
    usable = (
        s_n.dtype == np.float64
        and ok_n.dtype == np.bool_
        and seg.dtype == np.int64
        and w.dtype == np.float64
        and out.dtype == np.float64
        and all(v.flags.c_contiguous for v in (s_n, ok_n, seg, w, out))
    )
    k = STOLT.pick(out.size / NODES_SERIAL_RATE, usable=usable)
    k._node_positions(s_n, ok_n, seg, w, float(f0), float(df), float(half_band), out)
