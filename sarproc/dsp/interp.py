"""Interpolation kernels for uniformly sampled signals (shared by the Stolt, RCMC and resampling steps).

All kernels interpolate a signal known at integer sample positions 0 .. n-1 at fractional
positions. Kernels (``length`` = number of taps):

  nearest      1 tap, the closest sample.
  linear       2 taps, triangle.
  cubic        4 taps, Keys' cubic convolution (a = -0.5).
  sinc         ``length`` taps of sinc(d) times a Kaiser window of shape ``beta``.
  lanczos      ``length`` taps of sinc(d) sinc(2d / length).
  knab         ``length`` taps of Knab's kernel: sinc(d) cosh(pi nu (L/2) sqrt(1 - (2d/L)^2)) / cosh(pi nu L/2),
               nu = 1 - 1/oversampling, optimal for a signal oversampled by ``oversampling``
               (Knab 1979; the usual choice for SAR frequency-domain interpolation).

Weights of the windowed-sinc kernels are normalised to sum to one (exact for a constant).
Neighbours outside 0 .. n-1 count as zero (the band edges of a zero-padded spectrum).
The sums run in one compiled loop (numba), rows in parallel on all cores; weights of the windowed-sinc
kernels come from a table linearly interpolated, in the output's real precision.
"""

from __future__ import annotations

import functools
from typing import TYPE_CHECKING

import numpy as np

from sarproc.product.aot import Kernels

if TYPE_CHECKING:
    from typing import Any

    import numpy.typing as npt

KERNELS = ("nearest", "linear", "cubic", "sinc", "lanczos", "knab")
DEFAULT_LENGTH = {"nearest": 1, "linear": 2, "cubic": 4, "sinc": 8, "lanczos": 8, "knab": 8}
TABULATED = ("sinc", "lanczos", "knab")  # weights from a table, renormalised to unit DC gain


def kernel_length(kernel: str, length: int | None = None) -> int:
    """Number of taps a kernel uses (fixed for nearest/linear/cubic)."""
    if kernel not in KERNELS:
        raise ValueError(f"unknown interpolation kernel {kernel!r}; known: {KERNELS}")
    if kernel in ("nearest", "linear", "cubic"):
        return DEFAULT_LENGTH[kernel]
    n = DEFAULT_LENGTH[kernel] if length is None else int(length)
    if n < 2 or n % 2:
        raise ValueError(f"{kernel} kernel length must be an even number >= 2, got {length}")
    return n


def kernel_weights(
    d: np.ndarray, kernel: str, length: int, *, oversampling: float = 1.25, beta: float = 6.0
) -> np.ndarray:
    """Unnormalised kernel value at distance ``d`` (samples) from the interpolation point."""
    d = np.asarray(d, dtype=float)
    if kernel == "nearest":
        return (np.abs(d) <= 0.5).astype(float)
    if kernel == "linear":
        return np.clip(1.0 - np.abs(d), 0.0, None)
    if kernel == "cubic":
        a = -0.5
        x = np.abs(d)
        return np.where(
            x <= 1,
            (a + 2) * x**3 - (a + 3) * x**2 + 1,
            np.where(x < 2, a * x**3 - 5 * a * x**2 + 8 * a * x - 4 * a, 0.0),
        )
    half = length / 2.0
    arg = np.clip(1.0 - (d / half) ** 2, 0.0, None)
    if kernel == "sinc":
        win = np.i0(beta * np.sqrt(arg)) / np.i0(beta)
    elif kernel == "lanczos":
        win = np.sinc(d / half)
    elif kernel == "knab":
        nu = 1.0 - 1.0 / max(float(oversampling), 1.0 + 1e-6)
        win = np.cosh(np.pi * nu * half * np.sqrt(arg)) / np.cosh(np.pi * nu * half)
    else:
        raise ValueError(f"unknown interpolation kernel {kernel!r}; known: {KERNELS}")
    return np.sinc(d) * win * (np.abs(d) < half)


_TABLE_STEPS = 2048


@functools.lru_cache(maxsize=32)
def _weight_table(kernel: str, taps: int, oversampling: float, beta: float, steps: int = _TABLE_STEPS) -> np.ndarray:
    d = np.linspace(-taps / 2, taps / 2, taps * steps + 1)
    table = np.r_[kernel_weights(d, kernel, taps, oversampling=oversampling, beta=beta), 0.0]
    table.flags.writeable = False
    return table


@functools.lru_cache(maxsize=32)
def _tap_table(
    kernel: str, taps: int, oversampling: float, beta: float, dtype: npt.DTypeLike, steps: int = _TABLE_STEPS
) -> np.ndarray:
    flat = _weight_table(kernel, taps, oversampling, beta, steps)
    c = np.arange(steps + 1)[:, None]
    m = np.arange(taps)[None, :]
    table = np.ascontiguousarray(flat[c + (taps - 1 - m) * steps], dtype=dtype)
    table.flags.writeable = False
    return table


def tap_table(
    kernel: str,
    taps: int,
    oversampling: float = 1.25,
    dtype: npt.DTypeLike = np.float64,
    beta: float = 6.0,
    steps: int = _TABLE_STEPS,
) -> np.ndarray:
    """(steps + 1, taps), read-only, cached: row c holds the weights of taps m = 0 .. taps-1 (sample
    floor(p) + 1 - taps/2 + m) for the fraction p - floor(p) = c / steps, i.e. the kernel at distance
    c / steps + taps/2 - 1 - m; interpolate linearly between rows c and c + 1."""
    return _tap_table(kernel, int(taps), float(oversampling), float(beta), np.dtype(dtype), int(steps))


_MODES = {"nearest": 0, "linear": 1, "cubic": 2}  # any other kernel: tabulated (3)

# The resampling kernel compiled ahead of time for complex64 rows and float32 weights (sarproc.product.aot);
# a small call runs it without importing numba (the numba kernels: sarproc.dsp.interp_kernels). One export per
# layout (C, F or A, as numba types an array) of data and positions: numba compiles each layout apart and its
# fast-math loops may round differently between them, so the compiled call takes the layouts numba's would.
_LAYOUT = {"C": ":, ::1", "F": "::1, :", "A": ":, :"}
AOT = Kernels(
    name="interp",
    module="sarproc.dsp.interp_kernels",
    sources=("dsp/interp_kernels.py", "dsp/interp.py"),
    exports={
        f"resample_{d}{p}": (
            "_resample_kernel",
            f"void(c8[{_LAYOUT[d]}], f8[{_LAYOUT[p]}], c8[:, ::1], i8, i8, f4[:, ::1], i8, c8, f8, f8)",
        )
        for d in _LAYOUT
        for p in _LAYOUT
    },
    owner="sarproc.dsp.interp:AOT",
)


def _layout(a: np.ndarray) -> str:
    """numba's layout of ``a`` (numba.np.numpy_support.map_layout)."""
    return "C" if a.flags.c_contiguous else "F" if a.flags.f_contiguous else "A"


# Serial output samples x taps per second of the resampling kernel (complex64), for AOT.pick: the compiled module's
# rate measured over whole stages, pfa2 nie2016_small 3.4-4.0e8 (117 calls), array3d du2010 6-7.8e8 (28 calls;
# fine-focus an2012_exp1_small's 5 tiny calls 1.2e8, 0.02 s); was an estimate of 2e8 (docs/performance.md, sixth
# round).
RESAMPLE_SERIAL_RATE = 3.5e8


def resample_rows(
    data: np.ndarray,
    positions: np.ndarray,
    kernel: str = "knab",
    length: int | None = None,
    *,
    oversampling: float = 1.25,
    beta: float = 6.0,
    out_dtype: npt.DTypeLike | None = None,
    out: np.ndarray | None = None,
) -> np.ndarray:
    """Interpolate each row of ``data`` at fractional sample ``positions``.

    data: (n_rows, n_in) real or complex, samples at 0 .. n_in-1 along the last axis.
    positions: (n_rows, n_out) or (n_out,) float sample positions (NaN gives 0).
    Returns (n_rows, n_out) of ``out_dtype`` (default: data's dtype), written into ``out`` when given (a
    C-contiguous array of that shape, not overlapping ``data``: reused buffers). Windowed-sinc weights come
    from a table of 2048 steps per sample, linearly interpolated (relative error below 1e-6); the
    weights are computed in the output's real precision, so complex64 data stay complex64 throughout.
    """
    data = np.asarray(data)
    n_rows, n_in = data.shape
    pos = np.broadcast_to(np.asarray(positions, dtype=float), (n_rows, np.shape(positions)[-1]))
    taps = kernel_length(kernel, length)
    pad = taps + 1
    if out is None:
        out = np.empty(pos.shape, dtype=out_dtype or data.dtype)
    elif out.shape != pos.shape or not out.flags.c_contiguous or np.shares_memory(out, data):
        raise ValueError(f"resample_rows: out must be a C-contiguous {pos.shape} array apart from data")
    wdt = out.real.dtype if np.issubdtype(out.dtype, np.inexact) else np.dtype(np.float64)
    mode = _MODES.get(kernel, 3)
    table = _tap_table(kernel, taps, float(oversampling), float(beta), wdt) if mode == 3 else np.zeros((2, 1), wdt)
    if not np.issubdtype(data.dtype, np.inexact):
        data = data.astype(np.float64)
    if n_rows and pos.shape[1]:
        usable = data.dtype == out.dtype == np.complex64
        k = AOT.pick(pos.size * taps / RESAMPLE_SERIAL_RATE, usable=usable)
        name = f"resample_{_layout(data)}{_layout(pos)}" if AOT.is_compiled(k) else "_resample_kernel"
        getattr(k, name)(
            data, pos, out, mode, taps, table, _TABLE_STEPS, out.dtype.type(0), -pad / 2, n_in - 1 + pad / 2
        )
    return out


def resample(
    data: np.ndarray, positions: np.ndarray, kernel: str = "knab", length: int | None = None, **kwargs: Any
) -> np.ndarray:
    """:func:`resample_rows` for ``data`` (..., n_in) with ``positions`` broadcasting to (..., n_out)."""
    data = np.asarray(data)
    pos = np.asarray(positions, dtype=float)
    lead = np.broadcast_shapes(data.shape[:-1], pos.shape[:-1])
    rows = np.broadcast_to(data, lead + data.shape[-1:]).reshape(-1, data.shape[-1])
    pos = np.broadcast_to(pos, lead + pos.shape[-1:]).reshape(-1, pos.shape[-1])
    return resample_rows(rows, pos, kernel, length, **kwargs).reshape(lead + pos.shape[-1:])
