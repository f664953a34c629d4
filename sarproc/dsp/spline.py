"""Cubic B-splines in numpy: the basis on a knot vector, and the bicubic interpolant on a rectangular grid.

:class:`GridSpline` is scipy.interpolate.RectBivariateSpline's default (bicubic, s = 0: interpolating, with
FITPACK's knots) to float rounding (tested), and :func:`bspline_basis` is BSpline.design_matrix as a dense
array; both without importing scipy.interpolate, which costs a `pfa2` process ~0.3-0.5 s (it brings
scipy.linalg, sparse, special, optimize and fft along; docs/performance.md, "Per-process overhead").
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import Any, TypeVar

import numpy as np

F = TypeVar("F", bound=Callable[..., Any])


def _single_blas(func: F) -> F:
    """``func`` run with one BLAS thread. The matrices are small (a grid of points by ~10 coefficients):
    threaded BLAS only adds its start-up and, on a loaded machine or inside worker threads, threads waiting
    for each other (measured ~10x slower on 2 cores). threadpoolctl is imported at the first call: importing
    it sets KMP_DUPLICATE_LIB_OK in the process's environment, which importing sarproc must not do."""
    limited: list[Callable[..., Any]] = []  # threadpoolctl's wrapper of func, made once

    @functools.wraps(func)
    def run(*args: Any, **kwargs: Any) -> Any:
        if not limited:
            from threadpoolctl import threadpool_limits

            limited.append(threadpool_limits.wrap(limits=1, user_api="blas")(func))
        return limited[0](*args, **kwargs)

    return run  # type: ignore[return-value]


def bspline_basis(x: np.ndarray, t: np.ndarray, k: int = 3) -> np.ndarray:
    """The B-splines of degree ``k`` on knots ``t`` at ``x``: (len(x), len(t) - k - 1), each row's k + 1
    non-zero values by the Cox-de Boor recursion. ``x`` must lie in [t[k], t[-k-1]]; the last interval
    includes its end."""
    x = np.asarray(x, float).ravel()
    t = np.asarray(t, float)
    n = len(t) - k - 1
    if n < k + 1:
        raise ValueError(f"bspline_basis: {len(t)} knots are too few for degree {k}")
    lo, hi = t[k], t[n]
    if x.size and (np.min(x) < lo or np.max(x) > hi):
        raise ValueError(f"bspline_basis: points outside the base interval [{lo}, {hi}]")
    # the interval l with t[l] <= x < t[l + 1], k <= l <= n - 1 (x = t[n] in the last one)
    span = np.clip(np.searchsorted(t, x, side="right") - 1, k, n - 1)
    b = np.zeros((len(x), k + 1))
    b[:, 0] = 1.0
    for d in range(1, k + 1):  # b[:, j] is B_{span - d + j, d}(x) after step d
        new = np.zeros_like(b)
        for j in range(d + 1):
            i = span - d + j
            if j > 0:  # rising part of B_{i, d}: (x - t_i) / (t_{i+d} - t_i) B_{i, d-1}
                den = t[i + d] - t[i]
                new[:, j] += np.divide((x - t[i]) * b[:, j - 1], den, out=np.zeros(len(x)), where=den > 0)
            if j < d:  # falling part: (t_{i+d+1} - x) / (t_{i+d+1} - t_{i+1}) B_{i+1, d-1}
                den = t[i + d + 1] - t[i + 1]
                new[:, j] += np.divide((t[i + d + 1] - x) * b[:, j], den, out=np.zeros(len(x)), where=den > 0)
        b = new
    out = np.zeros((len(x), n))
    rows = np.arange(len(x))
    for j in range(k + 1):
        out[rows, span - k + j] = b[:, j]
    return out


def interpolation_knots(x: np.ndarray) -> np.ndarray:
    """FITPACK's knots for the cubic spline through data at ``x`` (s = 0): the ends four times, the data
    points inside but the first and last two (scipy's RectBivariateSpline and splrep alike)."""
    x = np.asarray(x, float)
    return np.concatenate([np.full(4, x[0]), x[2:-2], np.full(4, x[-1])])


class GridSpline:
    """The bicubic spline through ``z`` on the grid ``x`` x ``y`` (each strictly increasing, at least 4 points):
    RectBivariateSpline(x, y, z) to float rounding. Called as f(xs, ys), it gives the (len(xs), len(ys)) grid
    of values, points outside the grid clamped to its edge, as FITPACK does."""

    @_single_blas
    def __init__(self, x: np.ndarray, y: np.ndarray, z: np.ndarray) -> None:
        x, y, z = np.asarray(x, float), np.asarray(y, float), np.asarray(z, float)
        if z.shape != (len(x), len(y)):
            raise ValueError(f"GridSpline: values of shape {z.shape} on a {len(x)} x {len(y)} grid")
        for name, v in (("x", x), ("y", y)):
            if len(v) < 4 or np.any(np.diff(v) <= 0):
                raise ValueError(f"GridSpline: {name} must be strictly increasing with at least 4 points")
        self.tx, self.ty = interpolation_knots(x), interpolation_knots(y)
        bx, by = bspline_basis(x, self.tx), bspline_basis(y, self.ty)  # square collocation matrices
        self.coef = np.linalg.solve(bx, np.linalg.solve(by, z.T).T)  # bx C by^T = z

    @property
    def tck(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(x knots, y knots, coefficients flattened row-major): RectBivariateSpline.tck's layout."""
        return self.tx, self.ty, self.coef.ravel()

    @property
    def degrees(self) -> tuple[int, int]:
        return 3, 3

    @_single_blas
    def __call__(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        x = np.clip(np.asarray(x, float).ravel(), self.tx[0], self.tx[-1])
        y = np.clip(np.asarray(y, float).ravel(), self.ty[0], self.ty[-1])
        return bspline_basis(x, self.tx) @ self.coef @ bspline_basis(y, self.ty).T
