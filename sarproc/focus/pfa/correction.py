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
from typing import TYPE_CHECKING

import numpy as np

from sarproc.dsp.interp import resample_rows
from sarproc.dsp.phasor import unit_phasor
from sarproc.dsp.spline import GridSpline, bspline_basis
from sarproc.focus.pfa.polar import Grid, Interpolation, KGrid, Rect, los_components, polar_support, rotate_axes
from sarproc.product.aot import Kernels

if TYPE_CHECKING:
    from collections.abc import Sequence

    import numpy.typing as npt


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
    return pfa_distortions(positions, reference, [point], e_azimuth, e_range, carrier_frequency, freqs, rect, n)[0]


def pfa_distortions(
    positions: npt.ArrayLike,
    reference: npt.ArrayLike,
    points: Sequence[npt.ArrayLike] | np.ndarray,
    e_azimuth: np.ndarray,
    e_range: np.ndarray,
    carrier_frequency: float,
    freqs: npt.ArrayLike,
    rect: Rect | None = None,
    n: int = 11,
) -> list[Distortion]:
    """:func:`pfa_distortion` of each of ``points`` (m, 3): the lattice, its pulses and the fit's design
    are the same for every point, so they are computed once and the fits solved together."""
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
    pts = np.asarray(points, float).reshape(-1, 3)
    r_p = np.linalg.norm(p[:, None, :] - pts[None, :, :], axis=2)  # (lattice, points)
    phase = k[:, None] * (np.linalg.norm(d, axis=1)[:, None] - r_p)
    ca, cr = (rect.ka_lo + rect.ka_hi) / 2, (rect.kr_lo + rect.kr_hi) / 2
    x, y = ka - ca, kr - cr
    design = np.stack(
        [np.ones_like(x), x, y, 0.5 * x * x, x * y, 0.5 * y * y, x**3 / 6, x * x * y / 2, x * y * y / 2, y**3 / 6],
        axis=1,
    )
    # least squares through the pseudo-inverse: LAPACK's gelsd takes ~0.1 s for 81 right-hand sides, this 0.1 ms
    coef = np.linalg.pinv(design) @ phase  # (10, points)
    wa, wr = rect.ka_hi - rect.ka_lo, rect.kr_hi - rect.kr_lo
    return [
        Distortion(
            azimuth=float(c[1]),
            range=float(c[2]),
            spread_azimuth=float(abs(c[3]) * wa + abs(c[4]) * wr),
            spread_range=float(abs(c[4]) * wa + abs(c[5]) * wr),
        )
        for c in coef.T
    ]


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
    geo: PfaGeometry, kg: KGrid, core: Grid, n: int = 9, angle: float = 0.0
) -> tuple[GridSpline, GridSpline]:
    """Displacement D(p) - p over ``core`` (offsets from s), m: two bicubic splines (azimuth, range).

    Sampled by :func:`pfa_distortion` on an n x n lattice over the core and the k grid's rectangle.
    ``angle``: the PFA image's axes are the core's turned by it (:func:`.polar.rotate_axes`); D(p) is then
    in the image's coordinates, p in the core's.
    """
    la = np.linspace(core.a[0], core.a[-1], n)
    lr = np.linspace(core.r[0], core.r[-1], n)
    a, r = np.meshgrid(la, lr, indexing="ij")
    points = geo.center + a.ravel()[:, None] * geo.e_azimuth + r.ravel()[:, None] * geo.e_range
    e_a, e_r = rotate_axes(geo.e_azimuth, geo.e_range, angle)
    fits = pfa_distortions(geo.positions, geo.center, points, e_a, e_r, geo.carrier_frequency, geo.band, kgrid_rect(kg))
    da = np.array([d.azimuth for d in fits]).reshape(n, n) - a
    dr = np.array([d.range for d in fits]).reshape(n, n) - r
    return GridSpline(la, lr, da), GridSpline(la, lr, dr)


def extended_grid(core: Grid, warp: tuple[GridSpline, GridSpline]) -> Grid:
    """``core`` grown by the largest displacement plus 8 pixels of kernel support on every side."""
    fa, fr = warp
    m_a = 8 + int(math.ceil(np.max(np.abs(fa(core.a, core.r))) / core.da))
    m_r = 8 + int(math.ceil(np.max(np.abs(fr(core.a, core.r))) / core.dr))
    return Grid(
        core.a0 - m_a * core.da, core.da, core.n_a + 2 * m_a, core.r0 - m_r * core.dr, core.dr, core.n_r + 2 * m_r
    )


# The column spline kernel compiled ahead of time (sarproc.product.aot): a small two-step PFA reads its warps
# without importing numba (the numba kernel: sarproc.focus.pfa.spline_kernels). The callers' arrays are
# C-contiguous float64 (ColumnSpline makes them so).
AOT = Kernels(
    name="pfa_spline",
    module="sarproc.focus.pfa.spline_kernels",
    sources=("focus/pfa/spline_kernels.py", "focus/pfa/correction.py"),
    exports={"_column_spline_kernel": "void(f8[::1], f8[:, ::1], f8[:, ::1], f8[:, ::1])"},
    owner="sarproc.focus.pfa.correction:AOT",
)
# Serial points per second of the column spline kernel (a binary search over the knots and FITPACK's
# recursion per point), for AOT.pick: 5.1e7 measured on nie2016_small (6.1 M points, one thread; docs/performance.md,
# sixth round).
COLUMN_SPLINE_SERIAL_RATE = 5e7


class ColumnSpline:
    """A bicubic :class:`~sarproc.dsp.spline.GridSpline` f(x, y) read at any x on fixed columns y_j:
    (n, n_cols) -> values.

    Scattered points one by one (as FITPACK reads them) would take most of a sub-image's time; on fixed columns f is a
    cubic spline in x whose coefficients are computed once per column, and the compiled
    :func:`~sarproc.focus.pfa.spline_kernels._column_spline_kernel` reads it at every x with FITPACK's own
    recursion (fpbspl), rows in parallel. Points outside the knots are clamped to them, as FITPACK does.
    """

    def __init__(self, spline: GridSpline, y: np.ndarray) -> None:
        tx, ty, c = spline.tck
        kx, ky = spline.degrees
        if kx != 3:
            raise ValueError(f"ColumnSpline: a cubic spline in x is needed, not degree {kx}")
        self.tx = np.asarray(tx, float)
        n_cx, n_cy = len(tx) - kx - 1, len(ty) - ky - 1
        ty = np.asarray(ty, float)
        y = np.clip(np.asarray(y, float), ty[ky], ty[n_cy])  # clamped, as FITPACK does
        weights_y = bspline_basis(y, ty, ky)  # (n_cols, n_coef_y)
        # column j's coefficients in x: sum_l weights_y[j, l] coef[:, l]; stored (n_cols, n_coef_x)
        self.columns = np.ascontiguousarray(weights_y @ np.asarray(c, float).reshape(n_cx, n_cy).T)

    def __call__(self, x: np.ndarray) -> np.ndarray:
        x = np.ascontiguousarray(x, dtype=float)
        out = np.empty(x.shape)
        if x.size:
            k = AOT.pick(x.size / COLUMN_SPLINE_SERIAL_RATE, usable=x.ndim == 2 and self.tx.flags.c_contiguous)
            k._column_spline_kernel(self.tx, self.columns, x, out)
        return out


def warp_to_truth(
    img: np.ndarray,
    grid: Grid,
    core: Grid,
    warp: tuple[GridSpline, GridSpline],
    geo: PfaGeometry,
    kg: KGrid,
    interp: Interpolation,
    angle: float = 0.0,
) -> np.ndarray:
    """Read the PFA image ``img`` (on ``grid``) at D(p) for every pixel p of ``core``: (n_a, n_r) complex64.

    ``angle``: the image's axes (``grid``, ``kg``) are the core's turned by it (:func:`distortion_field`).
    """
    fa, fr = warp
    kc_a, kc_r = kg.ka0 + (kg.n_ka - 1) / 2 * kg.dka, kg.kr0 + (kg.n_kr - 1) / 2 * kg.dkr
    base = img * _carrier(grid.a, grid.r, kc_a, kc_r, +1)  # to baseband: the rectangle's centre
    c, s = math.cos(angle), math.sin(angle)
    kc_a, kc_r = c * kc_a + s * kc_r, c * kc_r - s * kc_a  # the same k_c on the core's axes
    os_a = 2 * math.pi / (kg.n_ka * kg.dka * core.da)
    os_r = 2 * math.pi / (kg.n_kr * kg.dkr * core.dr)
    # pass 1 (range): row a_i of the image holds the points p = (a, r) with D_a(p) = a_i; read D_r(p)
    ga, gr = ColumnSpline(fa, core.r), ColumnSpline(fr, core.r)  # every point of pass 1 lies on a column r_j
    A = np.broadcast_to(grid.a[:, None], (grid.n_a, core.n_r))
    a_true = A - ga(A)
    a_true = A - ga(a_true)
    pos_r = (core.r[None, :] + gr(a_true) - grid.r0) / core.dr  # (n_a_ext, n_r)
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
        out[s : s + 256] = unit_phasor(np.mod(-eps / (2 * math.pi), 1.0))
    return out


def _carrier(a: np.ndarray, r: np.ndarray, ka: float, kr: float, sign: int) -> np.ndarray:
    """exp{sign j (k_a a + k_r r)} on the grid a x r, complex64 (float64 phases)."""
    pa = np.exp(sign * 1j * np.mod(np.asarray(a) * ka, 2 * math.pi)).astype(np.complex64)
    pr = np.exp(sign * 1j * np.mod(np.asarray(r) * kr, 2 * math.pi)).astype(np.complex64)
    return pa[:, None] * pr[None, :]
