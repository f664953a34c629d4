"""Geometric correction of polar-format images: where PFA puts a point, and reading it back there.

The planar wavefront of eq. (5), Nie 2016, misplaces a point p (offset from the reference s) by a
smooth displacement D(p) - p that grows with |p - s|^2 / R, and gives its response a carrier phase
whose non-planar part depends on s. Both follow from the exact geometry: :func:`pfa_distortion`
fits the exact phase K (r_s - r_p) over the processed (k_a, k_r) rectangle; its linear coefficients
are D(p). :func:`warp_to_truth` then reads the image at D(p) for every true pixel p (two 1-D
band-limited passes on the baseband image) and removes the residual carrier phase, so responses
sit at their true positions with phase 0 at the peak, as backprojection's do. Used per sub-image by
the two-step PFA and, on request, on the whole plain PFA image.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import numpy.typing as npt
from scipy.interpolate import RectBivariateSpline

from sarproc.dsp.interp import resample_rows
from sarproc.focus.pfa.polar import Grid, Interpolation, KGrid, Rect, los_components, polar_support


@dataclasses.dataclass(frozen=True)
class Distortion:
    """Where plain PFA (reference O) puts a point, and how far its response spreads, m."""

    azimuth: float
    range: float
    spread_azimuth: float
    spread_range: float


def pfa_distortion(
    positions: np.ndarray,
    reference: npt.ArrayLike,
    point: npt.ArrayLike,
    e_azimuth: np.ndarray,
    e_range: np.ndarray,
    carrier_frequency: float,
    freqs: npt.ArrayLike,
    rect: Rect | None = None,
    n: int = 11,
) -> Distortion:
    """Least-squares cubic fit of the exact phase K (r_O - r_p) over (k_a, k_r) (eqs. 4-5).

    The samples are an n x n lattice over ``rect`` (default: the inscribed polar support), each
    mapped back to its pulse (antenna position interpolated) and wavenumber. The linear
    coefficients at the rectangle's centre are where PFA puts the point; the quadratic ones,
    times the rectangle's extent, the spread of its defocus.
    """
    pos = np.asarray(positions, float)
    ua, ur = los_components(pos, reference, e_azimuth, e_range)
    if rect is None:
        rect = polar_support(ua, ur, carrier_frequency, np.asarray(freqs), "inscribed")
    ka_grid, kr_grid = np.meshgrid(np.linspace(rect.ka_lo, rect.ka_hi, n), np.linspace(rect.kr_lo, rect.kr_hi, n))
    ka, kr = ka_grid.ravel(), kr_grid.ravel()
    ratio = ua / ur
    order = np.argsort(ratio)
    t = np.interp(ka / kr, ratio[order], np.arange(len(pos), dtype=float)[order])
    lo = np.clip(np.floor(t).astype(int), 0, len(pos) - 2)
    w = (t - lo)[:, None]
    p = pos[lo] * (1 - w) + pos[lo + 1] * w
    d = p - np.asarray(reference, float)
    u = d / np.linalg.norm(d, axis=1, keepdims=True)
    k = kr / (u @ np.asarray(e_range, float))
    phase = k * (np.linalg.norm(d, axis=1) - np.linalg.norm(p - np.asarray(point, float), axis=1))
    ca, cr = (rect.ka_lo + rect.ka_hi) / 2, (rect.kr_lo + rect.kr_hi) / 2
    x, y = ka - ca, kr - cr
    design = np.stack(
        [np.ones_like(x), x, y, 0.5 * x * x, x * y, 0.5 * y * y, x**3 / 6, x * x * y / 2, x * y * y / 2, y**3 / 6],
        axis=1,
    )
    coef, *_ = np.linalg.lstsq(design, phase, rcond=None)
    wa, wr = rect.ka_hi - rect.ka_lo, rect.kr_hi - rect.kr_lo
    return Distortion(
        azimuth=float(coef[1]),
        range=float(coef[2]),
        spread_azimuth=float(abs(coef[3]) * wa + abs(coef[4]) * wr),
        spread_range=float(abs(coef[4]) * wa + abs(coef[5]) * wr),
    )


@dataclasses.dataclass(frozen=True)
class PfaGeometry:
    """Antenna positions (n, 3), reference point s (3,), image axes e_a, e_r, carrier and band (Hz)."""

    positions: np.ndarray
    center: np.ndarray
    e_azimuth: np.ndarray
    e_range: np.ndarray
    carrier_frequency: float
    band: tuple[float, float]


def kgrid_rect(kg: KGrid) -> Rect:
    return Rect(kg.ka0, kg.ka0 + (kg.n_ka - 1) * kg.dka, kg.kr0, kg.kr0 + (kg.n_kr - 1) * kg.dkr)


def distortion_field(
    geo: PfaGeometry, kg: KGrid, core: Grid, n: int = 9
) -> tuple[RectBivariateSpline, RectBivariateSpline]:
    """Displacement D(p) - p over ``core`` (offsets from s), m: two bicubic splines (azimuth, range).

    Sampled by :func:`pfa_distortion` on an n x n lattice over the core and the k grid's rectangle.
    """
    la = np.linspace(core.a[0], core.a[-1], n)
    lr = np.linspace(core.r[0], core.r[-1], n)
    rect = kgrid_rect(kg)
    da = np.empty((n, n))
    dr = np.empty((n, n))
    for i, a in enumerate(la):
        for j, r in enumerate(lr):
            point = geo.center + a * geo.e_azimuth + r * geo.e_range
            d = pfa_distortion(
                geo.positions, geo.center, point, geo.e_azimuth, geo.e_range, geo.carrier_frequency, geo.band, rect
            )
            da[i, j], dr[i, j] = d.azimuth - a, d.range - r
    return RectBivariateSpline(la, lr, da), RectBivariateSpline(la, lr, dr)


def extended_grid(core: Grid, warp: tuple[RectBivariateSpline, RectBivariateSpline]) -> Grid:
    """``core`` grown by the largest displacement plus 8 pixels of kernel support on every side."""
    fa, fr = warp
    m_a = 8 + int(math.ceil(np.max(np.abs(fa(core.a, core.r))) / core.da))
    m_r = 8 + int(math.ceil(np.max(np.abs(fr(core.a, core.r))) / core.dr))
    return Grid(
        core.a0 - m_a * core.da, core.da, core.n_a + 2 * m_a, core.r0 - m_r * core.dr, core.dr, core.n_r + 2 * m_r
    )


def warp_to_truth(
    img: np.ndarray,
    grid: Grid,
    core: Grid,
    warp: tuple[RectBivariateSpline, RectBivariateSpline],
    geo: PfaGeometry,
    kg: KGrid,
    interp: Interpolation,
) -> np.ndarray:
    """Read the PFA image ``img`` (on ``grid``) at D(p) for every pixel p of ``core``: (n_a, n_r) complex64."""
    fa, fr = warp
    kc_a, kc_r = kg.ka0 + (kg.n_ka - 1) / 2 * kg.dka, kg.kr0 + (kg.n_kr - 1) / 2 * kg.dkr
    base = img * _carrier(grid.a, grid.r, kc_a, kc_r, +1)  # to baseband: the rectangle's centre
    os_a = 2 * math.pi / (kg.n_ka * kg.dka * core.da)
    os_r = 2 * math.pi / (kg.n_kr * kg.dkr * core.dr)
    # pass 1 (range): row a_i of the image holds the points p = (a, r) with D_a(p) = a_i; read D_r(p)
    A, R = np.meshgrid(grid.a, core.r, indexing="ij")
    a_true = A - fa(A, R, grid=False)
    a_true = A - fa(a_true, R, grid=False)
    pos_r = (R + fr(a_true, R, grid=False) - grid.r0) / core.dr  # (n_a_ext, n_r)
    tmp = resample_rows(base, pos_r, interp.range_kernel, interp.range_length, oversampling=os_r)
    # pass 2 (azimuth): the true pixel (a, r) sits in row D_a(a, r) of pass 1's output
    pos_a = (core.a[:, None] + fa(core.a, core.r) - grid.a0) / core.da  # (n_a, n_r)
    out = resample_rows(
        np.ascontiguousarray(tmp.T),
        np.ascontiguousarray(pos_a.T),
        interp.azimuth_kernel,
        interp.azimuth_length,
        oversampling=os_a,
    ).T
    out = out * _carrier(core.a, core.r, kc_a, kc_r, -1)
    out *= residual_phase(geo, core.a, core.r, kc_a, kc_r)
    return np.ascontiguousarray(out, dtype=np.complex64)


def residual_phase(geo: PfaGeometry, a_rel: np.ndarray, r_rel: np.ndarray, kc_a: float, kc_r: float) -> np.ndarray:
    """exp{-j [Phi_p(k_c) - k_c . (p - s)]} (n_a, n_r) complex64 over pixels p (offsets from s).

    A response's phase is the data's phase at the rectangle's centre k_c, K_c (r_s - r_p) at the
    pulse and frequency that map to k_c; its non-planar part differs from sub-image to sub-image,
    so it is removed exactly (every response then has phase 0 at its peak, as backprojection's,
    and a mosaic is continuous in phase across seams).
    """
    e_a, e_r = geo.e_azimuth, geo.e_range
    ua, ur = los_components(geo.positions, geo.center, e_a, e_r)
    idx = np.arange(len(ua), dtype=float)
    ratio = ua / ur
    order = np.argsort(ratio)
    t_c = float(np.interp(kc_a / kc_r, ratio[order], idx[order]))
    lo = int(min(max(math.floor(t_c), 0), len(idx) - 2))
    w = t_c - lo
    p_c = geo.positions[lo] * (1 - w) + geo.positions[lo + 1] * w
    u = (p_c - geo.center) / np.linalg.norm(p_c - geo.center)
    k_c = kc_r / float(u @ e_r)
    out = np.empty((len(a_rel), len(r_rel)), np.complex64)
    r_s = float(np.linalg.norm(p_c - geo.center))
    for s in range(0, len(a_rel), 256):  # rows in blocks: bounded memory
        a = np.asarray(a_rel[s : s + 256])
        pts = geo.center + a[:, None, None] * e_a + np.asarray(r_rel)[None, :, None] * e_r
        r_p = np.linalg.norm(pts - p_c, axis=-1)
        eps = k_c * (r_s - r_p) - (kc_a * a[:, None] + kc_r * np.asarray(r_rel)[None, :])
        out[s : s + 256] = np.exp(-1j * np.mod(eps, 2 * math.pi))
    return out


def _carrier(a: np.ndarray, r: np.ndarray, ka: float, kr: float, sign: int) -> np.ndarray:
    """exp{sign j (k_a a + k_r r)} on the grid a x r, complex64 (float64 phases)."""
    pa = np.exp(sign * 1j * np.mod(np.asarray(a) * ka, 2 * math.pi)).astype(np.complex64)
    pr = np.exp(sign * 1j * np.mod(np.asarray(r) * kr, 2 * math.pi)).astype(np.complex64)
    return pa[:, None] * pr[None, :]
