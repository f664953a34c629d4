"""Interpolation kernels for uniformly sampled signals (shared by the Stolt, RCMC and resampling steps).

All kernels interpolate a signal known at integer sample positions 0 .. n-1 at fractional
positions. Kernels (``length`` = number of taps):

  nearest      1 tap, the closest sample.
  linear       2 taps, triangle.
  cubic        4 taps, Keys' cubic convolution (a = -0.5).
  sinc         ``length`` taps of sinc(d) times a Kaiser window of shape ``beta``.
  knab         ``length`` taps of Knab's kernel: sinc(d) cosh(pi nu sqrt(1 - (2d/L)^2)) / cosh(pi nu),
               nu = 1 - 1/oversampling, optimal for a signal oversampled by ``oversampling``
               (Knab 1979; the usual choice for SAR frequency-domain interpolation).

Weights of the windowed-sinc kernels are normalised to sum to one (exact for a constant).
Neighbours outside 0 .. n-1 count as zero (the band edges of a zero-padded spectrum).
Vectorised over rows and output samples; only the (short) loop over taps is in Python.
"""

from __future__ import annotations

import numpy as np

KERNELS = ("nearest", "linear", "cubic", "sinc", "knab")
DEFAULT_LENGTH = {"nearest": 1, "linear": 2, "cubic": 4, "sinc": 8, "knab": 8}


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


def kernel_weights(d: np.ndarray, kernel: str, length: int, *, oversampling: float = 1.25,
                   beta: float = 2.5) -> np.ndarray:
    """Unnormalised kernel value at distance ``d`` (samples) from the interpolation point."""
    d = np.asarray(d, dtype=float)
    if kernel == "nearest":
        return (np.abs(d) <= 0.5).astype(float)
    if kernel == "linear":
        return np.clip(1.0 - np.abs(d), 0.0, None)
    if kernel == "cubic":
        a = -0.5
        x = np.abs(d)
        return np.where(x <= 1, (a + 2) * x**3 - (a + 3) * x**2 + 1,
                        np.where(x < 2, a * x**3 - 5 * a * x**2 + 8 * a * x - 4 * a, 0.0))
    half = length / 2.0
    arg = np.clip(1.0 - (d / half) ** 2, 0.0, None)
    if kernel == "sinc":
        win = np.i0(beta * np.sqrt(arg)) / np.i0(beta)
    elif kernel == "knab":
        nu = 1.0 - 1.0 / max(float(oversampling), 1.0 + 1e-6)
        win = np.cosh(np.pi * nu * np.sqrt(arg)) / np.cosh(np.pi * nu)
    else:
        raise ValueError(f"unknown interpolation kernel {kernel!r}; known: {KERNELS}")
    return np.sinc(d) * win * (np.abs(d) < half)


def resample_rows(data: np.ndarray, positions: np.ndarray, kernel: str = "knab", length: int | None = None, *,
                  oversampling: float = 1.25, beta: float = 2.5, out_dtype=None) -> np.ndarray:
    """Interpolate each row of ``data`` at fractional sample ``positions``.

    data: (n_rows, n_in) real or complex, samples at 0 .. n_in-1 along the last axis.
    positions: (n_rows, n_out) or (n_out,) float sample positions (NaN gives 0).
    Returns (n_rows, n_out) of ``out_dtype`` (default: data's dtype).
    """
    data = np.asarray(data)
    n_rows, n_in = data.shape
    pos = np.broadcast_to(np.asarray(positions, dtype=float), (n_rows, np.shape(positions)[-1]))
    taps = kernel_length(kernel, length)
    bad = ~np.isfinite(pos)
    pos = np.where(bad, -1e9, pos)
    if kernel == "nearest":
        base = np.floor(pos + 0.5).astype(np.int64)
        first = 0
    else:
        base = np.floor(pos).astype(np.int64)
        first = -(taps // 2) + 1
    out = np.zeros(pos.shape, dtype=out_dtype or data.dtype)
    wsum = np.zeros(pos.shape, dtype=float)
    rows = np.arange(n_rows)[:, None]
    for j in range(taps):
        idx = base + first + j
        w = kernel_weights(pos - idx, kernel, taps, oversampling=oversampling, beta=beta)
        wsum += w
        inside = (idx >= 0) & (idx < n_in)
        w = np.where(inside, w, 0.0)
        vals = data[rows, np.clip(idx, 0, n_in - 1)]
        out += (w * vals).astype(out.dtype, copy=False)
    if kernel in ("sinc", "knab"):
        out /= np.where(wsum > 0, wsum, 1.0).astype(out.real.dtype)
    out[bad] = 0
    return out
