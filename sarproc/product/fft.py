"""The FFTs every stage uses: scipy.fft's own pocketfft, without importing ``scipy.fft``.

``import scipy.fft`` costs 0.15-0.2 s of a stage's start (its array-API layer clones numpy's namespace,
loading numpy.testing, f2py and friends, and ``scipy.fft._fftlog`` imports scipy.special, whose
``xp_capabilities`` decorator parses 135 docstrings): more than a small product's whole compute
(docs/performance.md, "Per-process overhead"). What a stage calls is one C function,
``scipy.fft._pocketfft.pypocketfft.c2c``. This module loads that extension from scipy's install directly
(0.6 ms; the extension loaded twice, here and by a later ``import scipy.fft``, works as one) and wraps it as
scipy.fft's numpy backend does (``scipy/fft/_pocketfft/basic.py``: the same
argument handling, dtype promotion, padding, normalisation and worker count), so every transform is
scipy.fft's bit for bit (tested: tests/product/test_fft.py). Where the extension cannot be found or loaded
(another scipy layout), the same extension is taken through ``import scipy.fft``.

Covers what sarproc calls: fft, ifft, fft2, ifft2, fftn, ifftn (complex-to-complex, real input allowed),
next_fast_len, and numpy's fftfreq / fftshift / ifftshift (scipy.fft's are numpy's for numpy arrays).
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from types import ModuleType
from typing import Any

import numpy as np
from numpy.fft import fftfreq, fftshift, ifftshift

from sarproc.product.scipy_extension import load_extension

__all__ = [
    "fft",
    "fft2",
    "fftfreq",
    "fftn",
    "fftn_of_box",
    "fftshift",
    "ifft",
    "ifft2",
    "ifftn",
    "ifftshift",
    "Ifft2Rows",
    "next_fast_len",
]

_NORM = {None: 0, "backward": 0, "ortho": 1, "forward": 2}


def _pocketfft() -> ModuleType:
    loaded = load_extension("fft/_pocketfft", "pypocketfft", needs=("c2c", "good_size"))
    if loaded is None:  # pragma: no cover - another scipy layout: the same extension through scipy.fft
        from scipy.fft._pocketfft import pypocketfft

        return pypocketfft
    return loaded


_pfft = _pocketfft()


def _asfarray(x: Any) -> np.ndarray:
    """Float or complex array, native byte order, aligned; float16 -> float32, integers -> float64."""
    if not hasattr(x, "dtype"):
        x = np.asarray(x)
    if x.dtype == np.float16:
        return np.asarray(x, np.float32)
    if x.dtype.kind not in "fc":
        return np.asarray(x, np.float64)
    dtype = x.dtype.newbyteorder("=")
    return np.array(x, dtype=dtype, copy=True if not x.flags["ALIGNED"] else None)


def _datacopied(arr: np.ndarray, original: Any) -> bool:
    if arr is original:
        return False
    if not isinstance(original, np.ndarray) and hasattr(original, "__array__"):
        return False
    return arr.base is None


def _fix_shape(x: np.ndarray, shape: Sequence[int], axes: Sequence[int]) -> tuple[np.ndarray, bool]:
    """``x`` cropped or zero-padded to ``shape`` along ``axes``; whether a copy was made."""
    must_copy = False
    index = [slice(None)] * x.ndim
    for n, ax in zip(shape, axes):
        if x.shape[ax] >= n:
            index[ax] = slice(0, n)
        else:
            index[ax] = slice(0, x.shape[ax])
            must_copy = True
    if not must_copy:
        return x[tuple(index)], False
    s = list(x.shape)
    for n, ax in zip(shape, axes):
        s[ax] = n
    z = np.zeros(s, x.dtype)
    z[tuple(index)] = x[tuple(index)]
    return z, True


def _normalization(norm: str | None, forward: bool) -> int:
    try:
        inorm = _NORM[norm]
    except KeyError:
        raise ValueError(f'Invalid norm value {norm!r}, should be "backward", "ortho" or "forward"') from None
    return inorm if forward else 2 - inorm


def _workers(workers: int | None) -> int:
    count = os.cpu_count() or 1
    if workers is None:
        return 1
    if workers < 0:
        if workers >= -count:
            return workers + 1 + count
        raise ValueError(f"workers value out of range; got {workers}, must not be less than {-count}")
    if workers == 0:
        raise ValueError("workers must not be zero")
    return workers


def _c2c(
    forward: bool,
    x: Any,
    n: int | None = None,
    axis: int = -1,
    norm: str | None = None,
    overwrite_x: bool = False,
    workers: int | None = None,
) -> np.ndarray:
    tmp = _asfarray(x)
    overwrite_x = overwrite_x or _datacopied(tmp, x)
    inorm = _normalization(norm, forward)
    nthreads = _workers(workers)
    if n is not None:
        if n < 1:
            raise ValueError(f"invalid number of data points ({n}) specified")
        tmp, copied = _fix_shape(tmp, (n,), (axis,))
        overwrite_x = overwrite_x or copied
    elif tmp.shape[axis] < 1:
        raise ValueError(f"invalid number of data points ({tmp.shape[axis]}) specified")
    out = tmp if overwrite_x and tmp.dtype.kind == "c" else None
    result: np.ndarray = _pfft.c2c(tmp, (axis,), forward, inorm, out, nthreads)
    return result


def _c2cn(
    forward: bool,
    x: Any,
    s: Sequence[int] | None = None,
    axes: Sequence[int] | None = None,
    norm: str | None = None,
    overwrite_x: bool = False,
    workers: int | None = None,
) -> np.ndarray:
    tmp = _asfarray(x)
    if axes is None:
        ax = list(range(tmp.ndim - len(s), tmp.ndim)) if s is not None else list(range(tmp.ndim))
    else:
        ax = [int(a) + tmp.ndim if int(a) < 0 else int(a) for a in axes]
        if any(a >= tmp.ndim or a < 0 for a in ax):
            raise ValueError("axes exceeds dimensionality of input")
        if len(set(ax)) != len(ax):
            raise ValueError("all axes must be unique")
    if s is not None and len(s) != len(ax):
        raise ValueError("when given, axes and shape arguments have to be of the same length")
    shape = [tmp.shape[a] if s is None or s[i] == -1 else int(s[i]) for i, a in enumerate(ax)]
    if any(n < 1 for n in shape):
        raise ValueError(f"invalid number of data points ({shape}) specified")
    overwrite_x = overwrite_x or _datacopied(tmp, x)
    nthreads = _workers(workers)
    if not ax:
        return np.asarray(x)
    tmp, copied = _fix_shape(tmp, shape, ax)
    overwrite_x = overwrite_x or copied
    inorm = _normalization(norm, forward)
    out = tmp if overwrite_x and tmp.dtype.kind == "c" else None
    result: np.ndarray = _pfft.c2c(tmp, ax, forward, inorm, out, nthreads)
    return result


def fft(
    x: Any,
    n: int | None = None,
    axis: int = -1,
    norm: str | None = None,
    overwrite_x: bool = False,
    workers: int | None = None,
) -> np.ndarray:
    """scipy.fft.fft."""
    return _c2c(True, x, n, axis, norm, overwrite_x, workers)


def ifft(
    x: Any,
    n: int | None = None,
    axis: int = -1,
    norm: str | None = None,
    overwrite_x: bool = False,
    workers: int | None = None,
) -> np.ndarray:
    """scipy.fft.ifft."""
    return _c2c(False, x, n, axis, norm, overwrite_x, workers)


def fftn(
    x: Any,
    s: Sequence[int] | None = None,
    axes: Sequence[int] | None = None,
    norm: str | None = None,
    overwrite_x: bool = False,
    workers: int | None = None,
) -> np.ndarray:
    """scipy.fft.fftn."""
    return _c2cn(True, x, s, axes, norm, overwrite_x, workers)


def fftn_of_box(x: Any, start: Sequence[int], shape: Sequence[int], workers: int | None = None) -> np.ndarray:
    """:func:`fftn` of the array of ``shape`` that holds ``x`` at ``start`` and zeros elsewhere (a windowed chip),
    bit for bit: pocketfft transforms axis 0, then 1, ..., each line on its own, and a line that is zero is zero
    after, so each axis is transformed only on the lines inside the later axes' box. A box of half the chip a
    side (paper 004's windowed chips) takes a third less time than the whole transform. The lines are transformed
    in place, where they lie in the output (pocketfft takes any strides)."""
    x = np.asarray(x)
    out = np.zeros(tuple(shape), dtype=np.result_type(x.dtype, np.complex64))
    box = tuple(slice(int(s), int(s) + n) for s, n in zip(start, x.shape))
    out[box] = x
    for a in range(out.ndim):
        lines = out[(slice(None),) * (a + 1) + box[a + 1 :]]
        done = fft(lines, axis=a, overwrite_x=True, workers=workers)
        if not np.may_share_memory(done, out):  # not in place (scipy.fft's public fallback may copy)
            lines[...] = done
    return out


def ifftn(
    x: Any,
    s: Sequence[int] | None = None,
    axes: Sequence[int] | None = None,
    norm: str | None = None,
    overwrite_x: bool = False,
    workers: int | None = None,
) -> np.ndarray:
    """scipy.fft.ifftn."""
    return _c2cn(False, x, s, axes, norm, overwrite_x, workers)


def fft2(
    x: Any,
    s: Sequence[int] | None = None,
    axes: Sequence[int] = (-2, -1),
    norm: str | None = None,
    overwrite_x: bool = False,
    workers: int | None = None,
) -> np.ndarray:
    """scipy.fft.fft2."""
    return _c2cn(True, x, s, axes, norm, overwrite_x, workers)


def ifft2(
    x: Any,
    s: Sequence[int] | None = None,
    axes: Sequence[int] = (-2, -1),
    norm: str | None = None,
    overwrite_x: bool = False,
    workers: int | None = None,
) -> np.ndarray:
    """scipy.fft.ifft2."""
    return _c2cn(False, x, s, axes, norm, overwrite_x, workers)


ROWS_PER_WORKER = 256  # Ifft2Rows transforms fewer rows than this in one thread


class Ifft2Rows:
    """Rows of :func:`ifft2` of a 2-D array, bit for bit, transforming the second axis only on the rows asked for.

    pocketfft transforms axis 0 then axis 1, each line on its own, and applies the 1 / (n0 n1) of the default
    normalisation once, in the first pass, as a multiplication by that factor in the data's precision after the
    transform (norm_fct: 1 / n0 n1 in long double, rounded to the data's type). So the first pass is taken here
    unnormalised on every column, the factor applied to the wanted rows only, and the second pass taken on them
    (tests/product/test_fft.py, on 2-D shapes of radix-2/3/5, prime and Bluestein lengths). A few rows of a long
    image (reconstruct's null fit compares 25 of 12 000) cost one pass instead of two.
    """

    def __init__(self, x: Any, workers: int | None = None) -> None:
        tmp = _asfarray(x)
        if tmp.ndim != 2 or tmp.dtype.kind != "c":  # a real input takes pocketfft's real-to-complex path
            raise ValueError(f"Ifft2Rows: a 2-D complex array, not {tmp.dtype} of shape {tmp.shape}")
        self.shape = tmp.shape
        self.workers = workers
        self._first = ifft(tmp, axis=0, norm="forward", workers=workers)
        self._scale = self._first.real.dtype.type(1 / np.longdouble(self.shape[0] * self.shape[1]))

    def __getitem__(self, rows: Any) -> np.ndarray:
        """ifft2(x)[rows] (``rows``: an integer index array or a slice along axis 0)."""
        sub = self._first[rows] * self._scale  # a new array: the first pass is kept for other rows
        # a few rows in one thread: starting the pool cost more than the transform (1.6 ms a call for 25 x 33)
        workers = self.workers if len(sub) >= ROWS_PER_WORKER else None
        return ifft(sub, axis=1, norm="forward", overwrite_x=True, workers=workers)


def next_fast_len(target: int, real: bool = False) -> int:
    """scipy.fft.next_fast_len."""
    size: int = _pfft.good_size(target, real)
    return size


def _agrees_with_numpy() -> bool:
    """A few small transforms through the loaded extension against numpy's: False if a scipy release changed
    the private extension's calls or results (then the public scipy.fft is used below)."""
    try:
        x = np.exp(1j * np.arange(60.0) ** 2 / 7).reshape(5, 12).astype(np.complex64)
        return bool(
            np.allclose(fft(x, axis=0), np.fft.fft(x, axis=0), atol=1e-4)
            and np.allclose(ifft(x, 16), np.fft.ifft(x, 16), atol=1e-5)
            and np.allclose(fft2(x, workers=2), np.fft.fft2(x), atol=1e-4)
            and np.allclose(ifftn(x.real), np.fft.ifftn(x.real), atol=1e-5)
            and next_fast_len(97) == 98
        )
    except Exception:
        return False


if not _agrees_with_numpy():  # pragma: no cover - another scipy: its public API, bit for bit what was meant
    from scipy.fft import fft, fft2, fftn, ifft, ifft2, ifftn, next_fast_len  # type: ignore[no-redef]
