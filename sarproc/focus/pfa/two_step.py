"""Two-step PFA by beam segmentation (Nie 2016, sec. 3.3, Figs. 3-5, eqs. 7-10).

Step 1 focuses the whole scene with PFA on the rectangle circumscribing the polar support (so
the inverse loses no polar sample). The output grid is cut into tiles ("sub-images") no larger
than eq. (7)'s valid radius; each tile becomes one independent task (:class:`SubImageTask`,
plain arrays, a pure top-level :func:`focus_subimage`), whose working set is its window of the
step-1 image and a decimated polar raster:

1. 2-D spatial filter and decimation: cut the window of the step-1 image that holds the step-1
   responses of the tile (around the *distorted* positions where plain PFA puts the tile's
   points, grown by their defocus spread and the overlap), and take its spectrum relative to the
   window centre x_s' (a low-pass signal, Fig. 4);
2. inverse PFA to the signal domain (azimuth, then range inverse resampling) on pulses and
   frequencies decimated to what the window's extent needs;
3. restore the band-pass carrier exp{+j k . x_s'} of the window centre (sec. 3.3, last
   paragraph) and re-reference the motion compensation to the tile centre s (eq. 8):
   S_n = S exp{j K [r_s(t) - r_0(t)]} (eq. 9);
4. PFA again with s as reference (eq. 10), on one k grid shared by all tiles.

The second pass interpolates onto a rectangle aligned with the mosaic's axes: its polar
interpolation runs along each pulse's line of sight to s, so the rotation of s's line of sight
against the scene centre's (a LOSPI sub-image's rotation) is taken out in the interpolation,
and the translation is the tile's offset in the output grid. Every tile thus lands exactly on
its own pixels of the output grid (seamless mosaic, no image-domain resampling).
"""

from __future__ import annotations

import dataclasses
import math
from typing import Callable, Iterable

import numpy as np
import scipy.fft as sfft
from scipy.interpolate import RectBivariateSpline

from sarproc.dsp.interp import resample_rows
from sarproc.dsp.phasor import unit_phasor
from sarproc.focus.pfa.phase_history import PhaseHistory, reference_ranges
from sarproc.focus.pfa.polar import (Grid, Interpolation, KGrid, Rect, image_to_rect, los_components, make_kgrid,
                                     pfa, polar_support, rect_to_polar, wavenumbers)
from sarproc.product.metadata import C


def valid_radius(azimuth_resolution: float, reference_range: float, wavelength: float, ka: float = 1.3) -> float:
    """eq. (7), Nie 2016: r_0 <= (2 rho_a / K_a) sqrt(R_ac / lambda), m."""
    return 2 * azimuth_resolution / ka * math.sqrt(reference_range / wavelength)


@dataclasses.dataclass(frozen=True)
class Distortion:
    """Where plain PFA (reference O) puts a point, and how far its response spreads, m."""

    azimuth: float
    range: float
    spread_azimuth: float
    spread_range: float


def pfa_distortion(positions, reference, point, e_azimuth, e_range, carrier_frequency, freqs,
                   rect: Rect | None = None, n: int = 11) -> Distortion:
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
    ka, kr = np.meshgrid(np.linspace(rect.ka_lo, rect.ka_hi, n), np.linspace(rect.kr_lo, rect.kr_hi, n))
    ka, kr = ka.ravel(), kr.ravel()
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
    design = np.stack([np.ones_like(x), x, y, 0.5 * x * x, x * y, 0.5 * y * y,
                       x**3 / 6, x * x * y / 2, x * y * y / 2, y**3 / 6], axis=1)
    coef, *_ = np.linalg.lstsq(design, phase, rcond=None)
    wa, wr = rect.ka_hi - rect.ka_lo, rect.kr_hi - rect.kr_lo
    return Distortion(azimuth=float(coef[1]), range=float(coef[2]),
                      spread_azimuth=float(abs(coef[3]) * wa + abs(coef[4]) * wr),
                      spread_range=float(abs(coef[4]) * wa + abs(coef[5]) * wr))


@dataclasses.dataclass(frozen=True)
class SubImageTask:
    """Everything one sub-image needs, as plain arrays (picklable; no product, no file).

    window: (n_wa, n_wr) complex64 cut of the step-1 image on ``window_grid`` (offsets from the
    scene reference O); forward: the step-1 k grid; window_center: x_s' (m, offsets from O);
    center: s (3,) m; core: the output pixels (offsets from O); kgrid: the shared step-2 k grid.
    """

    window: np.ndarray
    window_grid: Grid
    forward: KGrid
    forward_rect: Rect
    window_center: tuple[float, float]
    center: np.ndarray
    center_offset: tuple[float, float]
    core: Grid
    kgrid: KGrid
    positions: np.ndarray
    reference: np.ndarray
    e_azimuth: np.ndarray
    e_range: np.ndarray
    carrier_frequency: float
    band: tuple[float, float]
    content_extent: tuple[float, float]
    oversampling: float
    interp: Interpolation


def subimage_phase_history(task: SubImageTask) -> PhaseHistory:
    """Steps 1-3: window -> low-pass spectrum -> decimated polar raster -> carrier + eq. (8) MoCo."""
    g = task.window_grid
    xa, xr = task.window_center
    rel = Grid(g.a0 - xa, g.da, g.n_a, g.r0 - xr, g.dr, g.n_r)      # window relative to its centre x_s'
    os_ = task.oversampling
    wa, wr = task.content_extent
    kg, _ = make_kgrid(task.forward_rect, 2 * math.pi / (os_ * g.n_a * g.da), 2 * math.pi / (os_ * g.n_r * g.dr),
                       g.da, g.dr, g.n_a, g.n_r)
    low = image_to_rect(task.window, rel, kg, task.forward)            # L(k) = S(k) exp(-j k . x_s')
    # decimated polar raster: the window's content needs spacings 2 pi / (os x extent)
    ua, ur = los_components(task.positions, task.reference, task.e_azimuth, task.e_range)
    k_max = float(wavenumbers(task.carrier_frequency, task.band[1]))
    # phase step between pulses over the content: K (du_a a + du_r r) must stay below 2 pi / os
    per_pulse = k_max * float(np.max(np.abs(np.diff(ua)) * wa + np.abs(np.diff(ur)) * wr))
    decim = max(1, int(2 * math.pi / (os_ * per_pulse)))
    keep = np.arange((len(ua) - 1) % decim // 2, len(ua), decim)   # uniform, centred on the aperture
    depth = float(np.max(np.abs(ua))) * wa + float(np.max(np.abs(ur))) * wr   # slant extent of the content
    df = C / (2 * os_ * depth)
    n_f = int(math.floor((task.band[1] - task.band[0]) / df)) + 1
    freqs = (task.band[0] + task.band[1]) / 2 + (np.arange(n_f) - (n_f - 1) / 2) * df
    sig = rect_to_polar(low, kg, ua[keep], ur[keep], task.carrier_frequency, freqs, task.interp, os_)
    pos = task.positions[keep]
    # band-pass carrier of x_s' and eq. (8), Nie 2016: K [r_s(t) - r_0(t)], in float64 cycles
    path = ua[keep] * xa + ur[keep] * xr + reference_ranges(pos, task.center) - reference_ranges(pos, task.reference)
    cyc = np.outer(path, 2 * (task.carrier_frequency + freqs) / C)
    cyc -= np.floor(cyc)
    sig *= unit_phasor(cyc)
    span = 2 * depth / C
    return PhaseHistory(data=sig, freqs=freqs, carrier_frequency=task.carrier_frequency, positions=pos,
                        reference=np.asarray(task.center, float), times=keep.astype(float),
                        delay_center=np.zeros(len(keep)), delay_span=np.full(len(keep), span))


def focus_subimage(task: SubImageTask) -> np.ndarray:
    """One sub-image of the two-step PFA: its core pixels (n_a, n_r) complex64 (step 4, eq. 10).

    The second PFA still has eq. (5)'s planar-wavefront distortion, small near s but up to a
    cell or so at a core's corners; it is known from the geometry (:func:`pfa_distortion`), so
    the sub-image is read back at the distorted place of each true pixel position (the
    "translation" correction done per pixel).
    """
    ph = subimage_phase_history(task)
    sa, sr = task.center_offset
    c, kg = task.core, task.kgrid
    fa, fr = distortion_field(task, c)
    a_core, r_core = c.a - sa, c.r - sr
    warp_a = fa(a_core, r_core)
    warp_r = fr(a_core, r_core)
    margin_a = 8 + int(math.ceil(np.max(np.abs(warp_a)) / c.da))
    margin_r = 8 + int(math.ceil(np.max(np.abs(warp_r)) / c.dr))
    grid = Grid(a_core[0] - margin_a * c.da, c.da, c.n_a + 2 * margin_a,
                r_core[0] - margin_r * c.dr, c.dr, c.n_r + 2 * margin_r)       # relative to s, with margins
    interp = dataclasses.replace(task.interp, azimuth_oversampling=task.oversampling)
    img, _ = pfa(ph, task.e_azimuth, task.e_range, grid, kgrid=kg, interp=interp, workers=1)
    # to baseband (the rectangle's centre carrier), read at the distorted positions, back to band-pass
    kc_a, kc_r = kg.ka0 + (kg.n_ka - 1) / 2 * kg.dka, kg.kr0 + (kg.n_kr - 1) / 2 * kg.dkr
    img *= _carrier(grid.a, grid.r, kc_a, kc_r, +1)
    os_a = 2 * math.pi / (kg.n_ka * kg.dka * c.da)
    os_r = 2 * math.pi / (kg.n_kr * kg.dkr * c.dr)
    # pass 1 (range): row a_i of the image holds the points p = (a, r) with D_a(p) = a_i; read D_r(p)
    A, R = np.meshgrid(grid.a, r_core, indexing="ij")
    a_true = A - fa(A, R, grid=False)
    a_true = A - fa(a_true, R, grid=False)
    pos_r = (R + fr(a_true, R, grid=False) - grid.r0) / c.dr                        # (n_a_ext, n_r)
    tmp = resample_rows(img, pos_r, interp.range_kernel, interp.range_length, oversampling=os_r)
    # pass 2 (azimuth): the true pixel (a, r) sits in row D_a(a, r) of pass 1's output
    pos_a = (a_core[:, None] + warp_a - grid.a0) / c.da                              # (n_a, n_r)
    out = resample_rows(np.ascontiguousarray(tmp.T), np.ascontiguousarray(pos_a.T), interp.azimuth_kernel,
                        interp.azimuth_length, oversampling=os_a).T
    out = out * _carrier(a_core, r_core, kc_a, kc_r, -1)
    out *= residual_phase(task, a_core, r_core, kc_a, kc_r)
    return np.ascontiguousarray(out, dtype=np.complex64)


def residual_phase(task: SubImageTask, a_rel, r_rel, kc_a: float, kc_r: float) -> np.ndarray:
    """exp{-j [Phi_p(k_c) - k_c . (p - s)]} (n_a, n_r) complex64 over core pixels p (offsets from s).

    A response's phase is the data's phase at the rectangle's centre k_c, K_c (r_s - r_p) at the
    pulse and frequency that map to k_c; its non-planar part differs from sub-image to sub-image,
    so it is removed exactly (every response then has phase 0 at its peak, as backprojection's,
    and the mosaic is continuous in phase across seams).
    """
    e_a, e_r = np.asarray(task.e_azimuth), np.asarray(task.e_range)
    ua, ur = los_components(task.positions, task.center, e_a, e_r)
    idx = np.arange(len(ua), dtype=float)
    ratio = ua / ur
    order = np.argsort(ratio)
    t_c = float(np.interp(kc_a / kc_r, ratio[order], idx[order]))
    lo = int(min(max(math.floor(t_c), 0), len(idx) - 2))
    w = t_c - lo
    p_c = task.positions[lo] * (1 - w) + task.positions[lo + 1] * w
    u = (p_c - task.center) / np.linalg.norm(p_c - task.center)
    k_c = kc_r / float(u @ e_r)
    pts = task.center + a_rel[:, None, None] * e_a + r_rel[None, :, None] * e_r
    r_p = np.linalg.norm(pts - p_c, axis=-1)
    r_s = float(np.linalg.norm(p_c - task.center))
    eps = k_c * (r_s - r_p) - (kc_a * a_rel[:, None] + kc_r * r_rel[None, :])
    return np.exp(-1j * np.mod(eps, 2 * math.pi)).astype(np.complex64)


def _carrier(a, r, ka, kr, sign) -> np.ndarray:
    ph = (np.outer(np.asarray(a) * ka, np.ones(len(r))) + np.asarray(r)[None, :] * kr) * sign
    return np.exp(1j * (ph % (2 * math.pi))).astype(np.complex64)


def distortion_field(task: SubImageTask, core: Grid, n: int = 9):
    """Displacement D(p) - p of the second PFA over the core (offsets from s), m: two splines (a, r).

    Sampled by :func:`pfa_distortion` on an n x n lattice and interpolated by bicubic splines.
    """
    sa, sr = task.center_offset
    la = np.linspace(core.a[0], core.a[-1], n) - sa
    lr = np.linspace(core.r[0], core.r[-1], n) - sr
    e_a, e_r = np.asarray(task.e_azimuth), np.asarray(task.e_range)
    kg = task.kgrid
    rect = Rect(kg.ka0, kg.ka0 + (kg.n_ka - 1) * kg.dka, kg.kr0, kg.kr0 + (kg.n_kr - 1) * kg.dkr)
    da = np.empty((n, n))
    dr = np.empty((n, n))
    for i, a in enumerate(la):
        for j, r in enumerate(lr):
            point = task.center + a * e_a + r * e_r
            d = pfa_distortion(task.positions, task.center, point, e_a, e_r, task.carrier_frequency, task.band, rect)
            da[i, j], dr[i, j] = d.azimuth - a, d.range - r
    return RectBivariateSpline(la, lr, da), RectBivariateSpline(la, lr, dr)


@dataclasses.dataclass(frozen=True)
class Tile:
    """One sub-image: its output pixels (slices of the output grid) and its step-1 window."""

    rows: slice
    cols: slice
    center_offset: tuple[float, float]
    window: tuple[float, float, float, float]       # a_min, a_max, r_min, r_max, m from O
    window_center: tuple[float, float]


def plan_tiles(out: Grid, core_size: tuple[float, float], overlap: float, positions, reference, e_azimuth,
               e_range, carrier_frequency, band) -> list[Tile]:
    """Cut the output grid into tiles of at most ``core_size`` (m) and size their step-1 windows.

    A window holds the distorted step-1 responses of the tile's corners and centre, grown by half
    their defocus spread and by ``overlap`` x the core size on each side.
    """
    n_ta = max(1, math.ceil(out.n_a * out.da / core_size[0]))
    n_tr = max(1, math.ceil(out.n_r * out.dr / core_size[1]))
    edges_a = np.linspace(0, out.n_a, n_ta + 1).round().astype(int)
    edges_r = np.linspace(0, out.n_r, n_tr + 1).round().astype(int)
    ref = np.asarray(reference, float)
    tiles = []
    for i in range(n_ta):
        for j in range(n_tr):
            ia, ib, ja, jb = edges_a[i], edges_a[i + 1], edges_r[j], edges_r[j + 1]
            a_lo, a_hi = out.a0 + ia * out.da, out.a0 + (ib - 1) * out.da
            r_lo, r_hi = out.r0 + ja * out.dr, out.r0 + (jb - 1) * out.dr
            ca, cr = (a_lo + a_hi) / 2, (r_lo + r_hi) / 2
            pts = [(ca, cr), (a_lo, r_lo), (a_lo, r_hi), (a_hi, r_lo), (a_hi, r_hi)]
            dist = [pfa_distortion(positions, ref, ref + a * np.asarray(e_azimuth) + r * np.asarray(e_range),
                                   e_azimuth, e_range, carrier_frequency, band) for a, r in pts]
            ga = overlap * (a_hi - a_lo) / 2
            gr = overlap * (r_hi - r_lo) / 2
            win = (min(d.azimuth - d.spread_azimuth / 2 for d in dist) - ga,
                   max(d.azimuth + d.spread_azimuth / 2 for d in dist) + ga,
                   min(d.range - d.spread_range / 2 for d in dist) - gr,
                   max(d.range + d.spread_range / 2 for d in dist) + gr)
            tiles.append(Tile(slice(int(ia), int(ib)), slice(int(ja), int(jb)), (ca, cr), win,
                              (dist[0].azimuth, dist[0].range)))
    return tiles


def window_slices(grid: Grid, window) -> tuple[slice, slice]:
    """Pixel slices of ``grid`` covering ``window`` (a_min, a_max, r_min, r_max), FFT-friendly lengths."""
    out = []
    for lo, hi, start, step, n in ((window[0], window[1], grid.a0, grid.da, grid.n_a),
                                   (window[2], window[3], grid.r0, grid.dr, grid.n_r)):
        i0 = int(math.floor((lo - start) / step))
        length = sfft.next_fast_len(int(math.ceil((hi - lo) / step)) + 2)
        i0 = min(max(0, i0 - (length - int(math.ceil((hi - lo) / step)) - 2) // 2), max(0, n - length))
        out.append(slice(i0, min(n, i0 + length)))
    return out[0], out[1]


def tile_rects(tiles: Iterable[Tile], positions, reference, e_azimuth, e_range, carrier_frequency,
               band) -> list[Rect]:
    """Each tile centre's inscribed polar support (its own resolution and carrier).

    After the distortion warp a response at p is resolved by this support mapped through the
    warp's Jacobian, i.e. p's own support: both tiles of a seam give p its natural response.
    """
    ref = np.asarray(reference, float)
    rects = []
    for t in tiles:
        s = ref + t.center_offset[0] * np.asarray(e_azimuth) + t.center_offset[1] * np.asarray(e_range)
        ua, ur = los_components(positions, s, e_azimuth, e_range)
        r = polar_support(ua, ur, carrier_frequency, np.asarray(band), "inscribed")
        if not r.valid:
            raise ValueError("two-step PFA: a sub-image centre has no inscribed polar support")
        rects.append(r)
    return rects


def local_irw(positions, point, e_azimuth, e_range, carrier_frequency, band, factor: float = 0.886):
    """Theoretical (azimuth, range) IRW, m, of a point's own inscribed polar support (varies over a wide scene)."""
    ua, ur = los_components(positions, point, e_azimuth, e_range)
    r = polar_support(ua, ur, carrier_frequency, np.asarray(band), "inscribed")
    return factor * 2 * math.pi / (r.ka_hi - r.ka_lo), factor * 2 * math.pi / (r.kr_hi - r.kr_lo)


def mosaic(shape, tiles: list[Tile], results: Iterable[np.ndarray]) -> np.ndarray:
    """Place each tile's core into the output image."""
    img = np.zeros(shape, np.complex64)
    for t, sub in zip(tiles, results):
        img[t.rows, t.cols] = sub
    return img


def run_tasks(tasks: Iterable[SubImageTask], mapper: Callable | None = None) -> Iterable[np.ndarray]:
    """Map :func:`focus_subimage` over the tasks (``mapper``: any map-like; default the builtin)."""
    return (mapper or map)(focus_subimage, tasks)
