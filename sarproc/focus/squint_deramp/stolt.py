"""Two-dimensional spectrum of the preprocessed squint echo and the modified Stolt mapping.

After the nonlinear Doppler correction (eq. 7) a target at (x_n = v t_n, r_0) of the squint frame
has, by exact stationary phase of the hyperbolic range (no Taylor expansion), the 2D spectrum

    SS'(f_r, f_a) ~ exp(-j 2 pi f_a t_n) exp(-j 4 pi f x_n sin(theta) / c) exp(-j r_0 G(f, f_a)),
    G(f, f_a) = (4 pi f / c) [sin^2(theta) + cos(theta) sqrt(1 - sigma^2)] + 2 pi f_a sin(theta) / v,
    sigma = sin(theta) + c f_a / (2 v f),          f = f_c + f_r.

Model ``paper`` is eq. (14) instead: G = (4 pi / c) sqrt(f^2 - (c f_a / (2 v cos(theta)))^2)
- 2 pi sin(theta) f_a^3 / (lambda_c cos(theta) (f_aM^2 - f_a^2)^(3/2)), which drops the odd
terms of order >= 5 of eq. (13). Both have the same Taylor coefficients up to f_a^3.

The modified Stolt mapping (eq. 15 for ``paper``) is f_r' = (c / 4 pi) [G(f_c + f_r, f_a) - G(f_c, f_a)],
after which r_0 G = (4 pi / c) r_0 f_r' + r_0 G_c(f_a): range and azimuth separate (eq. 16).
G_c(f_a) = G(f_c, f_a) is the azimuth phase per metre of range used by the azimuth compression.

Square-root limit: ``exact`` needs |sigma| < 1, ``paper`` needs |f_a| < f_aM (2 v cos(theta) / lambda
at the band edge). Frequencies within ``guard`` of the limit are masked (set to zero) and
counted, never turned into NaN.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from sarproc.dsp.interp import resample_rows
from sarproc.focus.squint_deramp import compiled
from sarproc.product.metadata import C
from sarproc.product.sorted_values import unique_integers

MODELS = ("exact", "paper")


class SpectrumModel:
    """G(f, f_a) and its Stolt inverse for one geometry (v, theta, f_c)."""

    def __init__(
        self, carrier_frequency: float, velocity: float, squint: float, model: str = "exact", guard: float = 1e-3
    ) -> None:
        if model not in MODELS:
            raise ValueError(f"unknown spectrum model {model!r}; known: {MODELS}")
        self.fc, self.v, self.theta, self.model = float(carrier_frequency), float(velocity), float(squint), model
        self.s, self.c = math.sin(squint), math.cos(squint)
        self.lam = C / self.fc
        self.f_aM = 2 * self.v * self.c / self.lam
        self.guard = guard

    # -- phase per metre of range -------------------------------------------------------------
    def _root(self, f: np.ndarray, f_a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(value, valid) of the square root of G (exact: sqrt(1 - sigma^2); paper: sqrt(f^2 - a^2))."""
        if self.model == "exact":
            sigma = self.s + C * f_a / (2 * self.v * f)
            arg = 1 - sigma**2
            lim = 2 * self.guard - self.guard**2
        else:
            arg = 1 - (C * f_a / (2 * self.v * self.c * f)) ** 2
            lim = 2 * self.guard - self.guard**2
        ok = arg > lim
        return np.sqrt(np.where(ok, arg, 1.0)), ok

    def G(self, f: npt.ArrayLike, f_a: npt.ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """Phase per metre of range, rad/m, and the validity mask (f, f_a broadcastable, Hz)."""
        f, f_a = np.asarray(f, float), np.asarray(f_a, float)
        root, ok = self._root(f, f_a)
        if self.model == "exact":
            g = 4 * np.pi * f / C * (self.s**2 + self.c * root) + 2 * np.pi * f_a * self.s / self.v
        else:
            q = np.clip(1 - (f_a / self.f_aM) ** 2, 1e-12, None)
            g = 4 * np.pi * f / C * root - 2 * np.pi * self.s * f_a**3 / (self.lam * self.c * self.f_aM**3 * q**1.5)
        return g, ok

    def rotate(
        self, x: np.ndarray, f: np.ndarray, f_a: np.ndarray, scale: float, pre: np.ndarray | None = None
    ) -> np.ndarray:
        """x[i, j] *= pre[j] where(ok, exp(j scale G(f[j], f_a[i])), 0) in place (x: (len(f_a), len(f)) complex,
        C-contiguous); returns x. One parallel pass: G is evaluated per element in float64 by the same
        operations as :meth:`G` (its f_a-only and f-only parts in numpy), the phasor by
        :func:`sarproc.dsp.phasor.multiply_phase`'s row kernel, so the result equals
        ``multiply_phase(x * pre, *G(f, f_a), scale=scale)``; no phase field is stored."""
        f = np.asarray(f, float)
        f_a = np.asarray(f_a, float)
        if x.shape != (len(f_a), len(f)) or not x.flags.c_contiguous:
            raise ValueError(f"rotate: x {x.shape} must be C-contiguous (len(f_a), len(f)) = ({len(f_a)}, {len(f)})")
        a = C * f_a
        lim = 2 * self.guard - self.guard**2
        if self.model == "exact":
            b = 2 * self.v * f
            p = 4 * np.pi * f / C
            q = 2 * np.pi * f_a * self.s / self.v
            mode = 0
        else:
            b = 2 * self.v * self.c * f
            p = 4 * np.pi * f / C
            qq = np.clip(1 - (f_a / self.f_aM) ** 2, 1e-12, None)
            q = -(2 * np.pi * self.s * f_a**3 / (self.lam * self.c * self.f_aM**3 * qq**1.5))
            mode = 1
        use_pre = pre is not None
        pre = np.asarray(pre, x.dtype) if use_pre else np.ones(1, x.dtype)
        compiled.rotate_G(
            x.view(x.real.dtype).reshape(x.shape[0], -1),
            x,
            pre,
            use_pre,
            a,
            q,
            b,
            p,
            mode,
            self.s,
            self.s**2,
            self.c,
            lim,
            float(scale) * (1.0 / (2 * np.pi)),
        )
        return x

    def Gc(self, f_a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Azimuth phase per metre at the carrier, G(f_c, f_a) - G(f_c, 0), and validity."""
        g, ok = self.G(self.fc, f_a)
        return g - 4 * np.pi * self.fc / C, ok

    def taylor(self) -> tuple[float, float]:
        """(g2, g3): f_a^2 and f_a^3 coefficients of G_c (eq. 19: psi_m = -r_0 g_m)."""
        g2 = -2 * np.pi / (self.lam * self.f_aM**2)
        g3 = -2 * np.pi * self.s / (self.lam * self.c * self.f_aM**3)
        return g2, g3

    # -- Stolt mapping ------------------------------------------------------------------------
    def mapped_frequency(self, f_r: np.ndarray, f_a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """f_r'(f_r, f_a) of the modified Stolt mapping, Hz."""
        g, ok = self.G(self.fc + np.asarray(f_r, float), f_a)
        g0, ok0 = self.G(self.fc, f_a)
        return C / (4 * np.pi) * (g - g0), ok & ok0

    def source_frequency(self, f_rp: np.ndarray, f_a: np.ndarray, iterations: int = 4) -> tuple[np.ndarray, np.ndarray]:
        """Inverse mapping: the f_r that lands on f_r' (Hz), and validity."""
        f_rp, f_a = np.broadcast_arrays(np.asarray(f_rp, float), np.asarray(f_a, float))
        if self.model == "paper":
            a2 = (C * f_a / (2 * self.v * self.c)) ** 2
            ok0 = self.fc**2 - a2 > 0
            root0 = np.sqrt(np.clip(self.fc**2 - a2, 0, None))
            f = np.sqrt((f_rp + root0) ** 2 + a2)
            _, ok = self.mapped_frequency(f - self.fc, f_a)
            return f - self.fc, ok & ok0
        # exact: solve f h(f) = f_r' + f_c h(f_c), h(f) = s^2 + c sqrt(1 - (s + b/f)^2), b = c f_a / 2v
        b = C * f_a / (2 * self.v)

        def h(ff: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
            sig = self.s + b / ff
            arg = 1 - sig**2
            ok = arg > 0
            return self.s**2 + self.c * np.sqrt(np.where(ok, arg, 1.0)), sig, ok

        h0, _, ok0 = h(np.full_like(f_rp, self.fc))
        target = f_rp + self.fc * h0
        f = self.fc + f_rp
        for _ in range(iterations):
            hv, sig, okf = h(f)
            root = np.where(okf, (hv - self.s**2) / self.c, 1.0)
            deriv = hv + f * self.c * sig * b / (f**2 * np.where(root > 1e-9, root, 1e-9))
            f = f - (f * hv - target) / deriv
        _, ok = self.mapped_frequency(f - self.fc, f_a)
        return f - self.fc, ok & ok0


def stolt_resample(
    spec: np.ndarray,
    f_r: np.ndarray,
    f_a: np.ndarray,
    model: SpectrumModel,
    kernel: str = "knab",
    length: int | None = 8,
    oversampling: float = 1.5,
    band: float | None = None,
    out: np.ndarray | None = None,
) -> tuple[np.ndarray, int]:
    """Resample rows of ``spec`` (n_fa, n_fr, range frequency ascending and uniform) onto f_r'.

    spec[i, j] is the spectrum at (f_a[i], f_r[j]); the output has the same f_r grid, now read as
    f_r'. ``band``: keep |f_r| <= band/2 at the source (zero elsewhere). Returns (out, masked) with
    ``masked`` the number of output samples zeroed by the square-root limit. ``out``: a buffer of spec's shape
    to write into (see :func:`sarproc.dsp.interp.resample_rows`).
    """
    df = f_r[1] - f_r[0]
    n = len(f_r)
    step = 32
    if n > 4 * step:
        # the mapping is smooth in f_r' (curvature ~ a^2 / f^3): exact on every 32nd sample, linear between
        # (error below 1e-6 sample for any SAR geometry this chain accepts)
        nodes = unique_integers(np.r_[np.arange(0, n, step), n - 1])
        s_n, ok_n = model.source_frequency(f_r[nodes][None, :], f_a[:, None])
        j = np.arange(n)
        seg = np.clip(np.searchsorted(nodes, j, side="right") - 1, 0, len(nodes) - 2)
        w = (j - nodes[seg]) / (nodes[seg + 1] - nodes[seg])
        pos = np.empty((len(f_a), n))
        half_band = np.inf if band is None else band / 2 + 1e-9 * band
        compiled.node_positions(
            np.ascontiguousarray(s_n), np.ascontiguousarray(ok_n), seg, w, float(f_r[0]), float(df), half_band, pos
        )  # one parallel pass, no temporaries
    else:
        src, ok = model.source_frequency(f_r[None, :], f_a[:, None])
        if band is not None:
            ok &= np.abs(src) <= band / 2 + 1e-9 * band
        pos = np.where(ok, (src - f_r[0]) / df, np.nan)
    out = resample_rows(spec, pos, kernel, length, oversampling=oversampling, out=out)
    # count only in-band samples lost to the square-root limit
    lim_ok = model.mapped_frequency(np.zeros(1), f_a)[1]
    masked = int(np.count_nonzero(~lim_ok)) * spec.shape[1]
    return out, masked
