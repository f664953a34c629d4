"""The not-a-knot cubic spline on a uniform grid, without scipy.interpolate.

``from scipy.interpolate import CubicSpline`` costs a process ~0.25-0.5 s (it brings scipy.linalg, sparse,
special and optimize along; docs/performance.md, "Per-process overhead"), more than the few splines a stage
evaluates. evaluate's cuts (sarproc.quality.metrics) and pfa2's de-aliased platform positions
(sarproc.focus.pfa.dealias) both sample on uniform grids, where the spline is a tridiagonal solve.
"""

from __future__ import annotations

import numpy as np


class UniformCubicSpline:
    """The not-a-knot cubic spline through ``y`` (real or complex; knots along its first axis, any trailing
    axes interpolated alike) at x0 + i h, i = 0 .. n - 1 (n >= 2); called at ``x`` it gives
    scipy.interpolate's CubicSpline(x0 + h arange(n), y)(x) to rounding, outside the knots too (the end pieces
    extended, as its default ``extrapolate=True``; tested).

    Second derivatives M: M[i-1] + 4 M[i] + M[i+1] = 6 (y[i+1] - 2 y[i] + y[i-1]) / h^2 inside; not-a-knot
    (continuous third derivative at the second and the last but one knot) is M[0] - 2 M[1] + M[2] = 0 on a
    uniform grid, which turns the first equation into 6 M[1] = d[1] (the same at the other end); the rest is
    tridiagonal, solved once by elimination. On 2 or 3 knots not-a-knot is the line or parabola through them."""

    def __init__(self, x0: float, h: float, y: np.ndarray) -> None:
        y = np.asarray(y)
        n = len(y)
        if n < 2:
            raise ValueError(f"a cubic spline needs at least 2 knots, got {n}")
        self.x0, self.h, self.y = float(x0), float(h), y
        self.moments = _not_a_knot_moments(y, self.h) if n >= 4 else None

    def __call__(self, x: np.ndarray) -> np.ndarray:
        y, n = self.y, len(self.y)
        t = (np.asarray(x, float) - self.x0) / self.h
        if self.moments is None:  # 2 or 3 knots: Lagrange's polynomial through them
            basis = [np.prod([(t - q) / (p - q) for q in range(n) if q != p], axis=0) for p in range(n)]
            return np.sum([_along(w, y) * y[p] for p, w in enumerate(basis)], axis=0)
        m = self.moments
        j = np.clip(np.floor(t).astype(np.int64), 0, n - 2)
        a = _along(t - j, y)  # position inside the interval: 0 .. 1 between the knots
        b = 1.0 - a
        hh = self.h * self.h / 6.0
        out: np.ndarray = b * y[j] + a * y[j + 1] + hh * ((b**3 - b) * m[j] + (a**3 - a) * m[j + 1])
        return out


def uniform_cubic_spline(x0: float, h: float, y: np.ndarray, x: np.ndarray) -> np.ndarray:
    """:class:`UniformCubicSpline` (x0, h, y) at ``x``."""
    return UniformCubicSpline(x0, h, y)(x)


def _along(w: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Weights per position, broadcast over ``y``'s trailing axes."""
    return w.reshape(w.shape + (1,) * (y.ndim - 1))


def _not_a_knot_moments(y: np.ndarray, h: float) -> np.ndarray:
    n = len(y)
    d = np.zeros_like(y, dtype=np.result_type(y, float))
    d[1:-1] = 6.0 * (y[2:] - 2.0 * y[1:-1] + y[:-2]) / (h * h)
    m = np.zeros_like(d)
    m[1], m[-2] = d[1] / 6.0, d[-2] / 6.0
    k = n - 4  # unknowns M[2] .. M[n-3]
    if k > 0:
        rhs = d[2:-2].copy()
        rhs[0] -= m[1]
        rhs[-1] -= m[-2]
        diag = np.full(k, 4.0)
        for i in range(1, k):  # forward elimination (sub- and super-diagonal 1)
            f = 1.0 / diag[i - 1]
            diag[i] -= f
            rhs[i] -= f * rhs[i - 1]
        sol = np.empty_like(rhs)
        sol[-1] = rhs[-1] / diag[-1]
        for i in range(k - 2, -1, -1):
            sol[i] = (rhs[i] - sol[i + 1]) / diag[i]
        m[2:-2] = sol
    m[0] = 2.0 * m[1] - m[2]
    m[-1] = 2.0 * m[-2] - m[-3]
    return m
