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
Vectorised over rows and output samples; only the (short) loop over taps is in Python.
"""

from __future__ import annotations

import functools

import numpy as np

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


def kernel_weights(d: np.ndarray, kernel: str, length: int, *, oversampling: float = 1.25,
                   beta: float = 6.0) -> np.ndarray:
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
def _weight_table(kernel, taps, oversampling, beta, steps=_TABLE_STEPS):
    d = np.linspace(-taps / 2, taps / 2, taps * steps + 1)
    table = np.r_[kernel_weights(d, kernel, taps, oversampling=oversampling, beta=beta), 0.0]
    table.flags.writeable = False
    return table


def weight_table(kernel: str, taps: int, oversampling: float = 1.25, beta: float = 6.0,
                 steps: int = _TABLE_STEPS) -> np.ndarray:
    """Kernel values at d = -taps/2 + i / steps, i = 0 .. taps * steps, plus one trailing zero so that
    linear interpolation in the table may read one entry past the end (read-only, cached)."""
    return _weight_table(kernel, int(taps), float(oversampling), float(beta), int(steps))


def resample_rows(data: np.ndarray, positions: np.ndarray, kernel: str = "knab", length: int | None = None, *,
                  oversampling: float = 1.25, beta: float = 6.0, out_dtype=None) -> np.ndarray:
    """Interpolate each row of ``data`` at fractional sample ``positions``.

    data: (n_rows, n_in) real or complex, samples at 0 .. n_in-1 along the last axis.
    positions: (n_rows, n_out) or (n_out,) float sample positions (NaN gives 0).
    Returns (n_rows, n_out) of ``out_dtype`` (default: data's dtype). Windowed-sinc weights come
    from a table of 2048 steps per sample, linearly interpolated (relative error below 1e-6); the
    weights are computed in the output's real precision, so complex64 data stay complex64 throughout.
    """
    data = np.asarray(data)
    n_rows, n_in = data.shape
    pos = np.broadcast_to(np.asarray(positions, dtype=float), (n_rows, np.shape(positions)[-1]))
    taps = kernel_length(kernel, length)
    pad = taps + 1
    width = n_in + 2 * pad
    padded = np.zeros((n_rows, width), dtype=np.result_type(data.dtype, np.complex64)
                      if np.iscomplexobj(data) else data.dtype)
    padded[:, pad:pad + n_in] = data
    flat = padded.ravel()
    bad = ~np.isfinite(pos) | (pos < -pad / 2) | (pos > n_in - 1 + pad / 2)
    pos = np.where(bad, -pad / 2, pos)
    if kernel == "nearest":
        base = np.floor(pos + 0.5).astype(np.int64)
        first = 0
    else:
        base = np.floor(pos).astype(np.int64)
        first = -(taps // 2) + 1
    frac = pos - base
    out = np.zeros(pos.shape, dtype=out_dtype or data.dtype)
    wdt = out.real.dtype if np.issubdtype(out.dtype, np.inexact) else np.float64
    # flat index of each output's base sample; one tap is then a constant offset from it
    src = base
    src += (np.arange(n_rows, dtype=np.int64) * width + pad)[:, None]
    idx = np.empty_like(src)
    vals = np.empty(pos.shape, flat.dtype)
    if kernel in TABULATED:
        table = _weight_table(kernel, taps, float(oversampling), float(beta)).astype(wdt)
        # frac - off sits at table index (frac + taps/2 - off) * steps: one split into integer and
        # fraction serves every tap
        q = frac * _TABLE_STEPS
        cell = np.floor(q).astype(np.int64)
        t = (q - cell).astype(wdt)
        wsum = np.zeros(pos.shape, dtype=wdt)
    for j in range(taps):
        off = first + j
        if kernel in TABULATED:
            i = cell + int(round((taps / 2 - off) * _TABLE_STEPS))
            w = table[i]
            w += (table[i + 1] - w) * t
            wsum += w
        else:
            w = kernel_weights(frac - off, kernel, taps).astype(wdt)
        np.add(src, off, out=idx)
        np.take(flat, idx, out=vals)
        vals *= w
        out += vals
    if kernel in TABULATED:
        out /= np.where(wsum > 0, wsum, 1)
    out[bad] = 0
    return out


def resample(data: np.ndarray, positions: np.ndarray, kernel: str = "knab", length: int | None = None,
             **kwargs) -> np.ndarray:
    """:func:`resample_rows` for ``data`` (..., n_in) with ``positions`` broadcasting to (..., n_out)."""
    data = np.asarray(data)
    pos = np.asarray(positions, dtype=float)
    lead = np.broadcast_shapes(data.shape[:-1], pos.shape[:-1])
    rows = np.broadcast_to(data, lead + data.shape[-1:]).reshape(-1, data.shape[-1])
    pos = np.broadcast_to(pos, lead + pos.shape[-1:]).reshape(-1, pos.shape[-1])
    return resample_rows(rows, pos, kernel, length, **kwargs).reshape(lead + pos.shape[-1:])
