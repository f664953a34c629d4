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
4. PFA again with s as reference (eq. 10), on k grids of one spacing for all tiles.

The second pass interpolates onto the rectangle inscribed in s's own polar support, on axes turned
onto the bisector of s's lines of sight (:func:`own_support`): seen from any point p of the tile
those are the same pulses and frequencies, so a point on a seam gets the same response from both
tiles (a rectangle on the mosaic's axes holds samples turned by theta_p - theta_s instead, whose band
centre jumps at the seam: -27 dB between the two halves of a response, tests/focus/test_pfa_seams.py).
The planar-wavefront distortion and that turn are taken out together when each tile is read back at
the distorted place of its own pixels of the output grid (:func:`focus_subimage`).

A sub-image that returns its core alone cuts every response's far ridges at the seams: only a target's own
sub-image holds its spectrum, and a neighbour's rectangle passes none of its step-1 side lobes. With blended
seams (``pfa2.subimage_reach`` > 0) the step-1 image is cut into a partition of unity instead
(:func:`partition_weights`: each core's distorted box, raised-cosine edges in the windows' overlap), each piece
is focused by its own sub-image onto its core grown by the reach (:func:`grown_slices`) and the pieces are
added (:func:`mosaic`): linear, so each content is focused once, by the sub-image that holds it, and its
ridges run on to the grown core's edge.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Iterable, Sequence
from typing import TYPE_CHECKING

import numpy as np

from sarproc.dsp.phasor import unit_phasor
from sarproc.focus.pfa.correction import PfaGeometry, distortion_field, extended_grid, pfa_distortion, warp_to_truth
from sarproc.focus.pfa.phase_history import PhaseHistory, reference_ranges
from sarproc.focus.pfa.polar import (
    Grid,
    Interpolation,
    KGrid,
    Rect,
    image_to_rect,
    inscribed_support,
    los_components,
    make_kgrid,
    pfa,
    rect_to_polar,
    rectangle_range_theory,
    rotate_axes,
    wavenumbers,
)
from sarproc.product import beam, fft as sfft
from sarproc.product.metadata import SINC_IRW_FACTOR, C

if TYPE_CHECKING:
    import numpy.typing as npt

    from sarproc.product.metadata import RadarMetadata
    from sarproc.product.theory import ResponseTheory


def valid_radius(azimuth_resolution: float, reference_range: float, wavelength: float, ka: float = 1.3) -> float:
    """eq. (7), Nie 2016: r_0 <= (2 rho_a / K_a) sqrt(R_ac / lambda), m."""
    return 2 * azimuth_resolution / ka * math.sqrt(reference_range / wavelength)


# A sinc's first side lobe, relative to its peak: a paired echo of relative amplitude e / 2 on it raises the
# PSLR by at most 20 log10(1 + e / (2 x 0.2172)) dB.
FIRST_SIDELOBE = 0.2172


def track_residual(
    positions: np.ndarray, reference: npt.ArrayLike, e_azimuth: np.ndarray, e_range: np.ndarray
) -> float:
    """Largest part of the range r(t) to ``reference`` that no cubic in the line-of-sight angle follows, m.

    On a straight track r is a smooth function of the polar angle theta = atan(u_a / u_r) (mm from a
    cubic on the reduced Table 1 scene); a curved track (platform motion) adds wiggles that no
    low-order polynomial in theta takes up, and these are what the planar wavefront of eq. (5)
    cannot absorb into its distortion and defocus (see :func:`track_radius`).
    """
    ua, ur = los_components(positions, reference, e_azimuth, e_range)
    if len(ua) < 5:
        return 0.0
    theta = np.arctan(ua / ur)
    x = (theta - theta.mean()) / max(float(np.ptp(theta)), 1e-30)
    r = reference_ranges(positions, reference)
    fit = np.polynomial.Polynomial.fit(x, r, 3)
    return float(np.max(np.abs(r - fit(x))))


def track_radius(residual: float, reference_range: float, k_max: float, phase: float) -> float:
    """Distance from a sub-image centre s within which a curved track's planar-wavefront residual stays under ``phase``.

    For p = s + d the exact path difference is r_s - r_p = u . d - (|d|^2 - (u . d)^2) / (2 r) + O(d^3 / r^2);
    PFA's k (eqs. 5-6) follows u(t) exactly, but the second term also depends on r(t), whose
    non-polynomial wiggle dr(t) (:func:`track_residual`) leaves the phase error
    K |d|^2 dr / (2 r^2) at most: paired echoes around each response. Bounded by ``phase``:
    |d| <= r sqrt(2 phase / (K_max dr)). Infinite for a track without wiggles.
    """
    if residual <= 0:
        return math.inf
    return reference_range * math.sqrt(2 * phase / (k_max * residual))


def pslr_rise_db(phase: float) -> float:
    """Largest PSLR rise, dB, that a sinusoidal phase error of amplitude ``phase`` (rad) can cause."""
    return 20 * math.log10(1 + phase / (2 * FIRST_SIDELOBE))


def track_corner_phase(residual: float, reference_range: float, k_max: float, core: float) -> float:
    """Planar-wavefront phase error, rad, that a track's wiggle ``residual`` (m) leaves at the corners of a
    sub-image ``core`` (m) wide: K_max (core / sqrt 2)^2 dr / (2 r^2) (:func:`track_radius`)."""
    return k_max * (core / math.sqrt(2)) ** 2 * residual / (2 * reference_range**2)


def track_pslr_rise_db(residual: float, reference_range: float, k_max: float, core: float) -> float:
    """Largest PSLR rise, dB, that a track's wiggle ``residual`` (m) can cause on sub-images ``core`` (m) wide:
    :func:`pslr_rise_db` of :func:`track_corner_phase`."""
    return pslr_rise_db(track_corner_phase(residual, reference_range, k_max, core))


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
    support_angle: float = 0.0  # the second PFA's axes: e_a, e_r turned by this angle (:class:`TileSupport`)


def subimage_phase_history(task: SubImageTask) -> PhaseHistory:
    """Steps 1-3: window -> low-pass spectrum -> decimated polar raster -> carrier + eq. (8) MoCo."""
    g = task.window_grid
    xa, xr = task.window_center
    rel = Grid(g.a0 - xa, g.da, g.n_a, g.r0 - xr, g.dr, g.n_r)  # window relative to its centre x_s'
    os_ = task.oversampling
    wa, wr = task.content_extent
    kg, _ = make_kgrid(
        task.forward_rect,
        2 * math.pi / (os_ * g.n_a * g.da),
        2 * math.pi / (os_ * g.n_r * g.dr),
        g.da,
        g.dr,
        g.n_a,
        g.n_r,
    )
    low = image_to_rect(task.window, rel, kg, task.forward)  # L(k) = S(k) exp(-j k . x_s')
    # decimated polar raster: the window's content needs spacings 2 pi / (os x extent)
    ua, ur = los_components(task.positions, task.reference, task.e_azimuth, task.e_range)
    k_max = float(wavenumbers(task.carrier_frequency, task.band[1]))
    # phase step between pulses over the content: K (du_a a + du_r r) must stay below 2 pi / os
    per_pulse = k_max * float(np.max(np.abs(np.diff(ua)) * wa + np.abs(np.diff(ur)) * wr))
    decim = max(1, int(2 * math.pi / (os_ * per_pulse)))
    keep = np.arange((len(ua) - 1) % decim // 2, len(ua), decim)  # uniform, centred on the aperture
    depth = float(np.max(np.abs(ua))) * wa + float(np.max(np.abs(ur))) * wr  # slant extent of the content
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
    return PhaseHistory(
        data=sig,
        freqs=freqs,
        carrier_frequency=task.carrier_frequency,
        positions=pos,
        reference=np.asarray(task.center, float),
        times=keep.astype(float),
        delay_center=np.zeros(len(keep)),
        delay_span=np.full(len(keep), span),
    )


def focus_subimage(task: SubImageTask) -> np.ndarray:
    """One sub-image of the two-step PFA: its core pixels (n_a, n_r) complex64 (step 4, eq. 10).

    The second PFA still has eq. (5)'s planar-wavefront distortion, small near s but up to a
    cell or so at a core's corners; it is known from the geometry, so the sub-image is read back
    at the distorted place of each true pixel (:mod:`.correction`; the "translation" correction
    done per pixel) and each response's non-planar carrier phase is removed.
    """
    ph = subimage_phase_history(task)
    sa, sr = task.center_offset
    c = task.core
    core = Grid(c.a0 - sa, c.da, c.n_a, c.r0 - sr, c.dr, c.n_r)  # relative to s
    geo = PfaGeometry(
        task.positions,
        np.asarray(task.center, float),
        np.asarray(task.e_azimuth),
        np.asarray(task.e_range),
        task.carrier_frequency,
        task.band,
    )
    angle = task.support_angle
    warp = distortion_field(geo, task.kgrid, core, angle=angle)
    grid = extended_grid(core, warp)
    interp = dataclasses.replace(task.interp, azimuth_oversampling=task.oversampling)
    e_a, e_r = rotate_axes(task.e_azimuth, task.e_range, angle)
    img, _ = pfa(ph, e_a, e_r, grid, kgrid=task.kgrid, interp=interp, workers=1)
    return warp_to_truth(img, grid, core, warp, geo, task.kgrid, interp, angle=angle)


@dataclasses.dataclass(frozen=True)
class Tile:
    """One sub-image: its output pixels (slices of the output grid) and its step-1 window."""

    rows: slice
    cols: slice
    center_offset: tuple[float, float]
    window: tuple[float, float, float, float]  # a_min, a_max, r_min, r_max, m from O
    window_center: tuple[float, float]
    # the core's bounds in the step-1 image (its edges' distorted places), a_min, a_max, r_min, r_max, m from O;
    # infinite on the grid's outer sides: the cells of the step-1 image's partition (:func:`partition_weights`)
    box: tuple[float, float, float, float] = (-math.inf, math.inf, -math.inf, math.inf)


def plan_tiles(
    out: Grid,
    core_size: tuple[float, float],
    overlap: float,
    positions: np.ndarray,
    reference: npt.ArrayLike,
    e_azimuth: np.ndarray,
    e_range: np.ndarray,
    carrier_frequency: float,
    band: tuple[float, float],
) -> list[Tile]:
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
            dist = [
                pfa_distortion(
                    positions,
                    ref,
                    ref + a * np.asarray(e_azimuth) + r * np.asarray(e_range),
                    e_azimuth,
                    e_range,
                    carrier_frequency,
                    band,
                )
                for a, r in pts
            ]
            ga = overlap * (a_hi - a_lo) / 2
            gr = overlap * (r_hi - r_lo) / 2
            # the core's edges lie half a pixel beyond its outer pixels (the seam between two tiles' pixels)
            edge = [(d.azimuth, d.range) for d in dist[1:]]
            box = (
                min(e[0] for e in edge) - out.da / 2 if i > 0 else -math.inf,
                max(e[0] for e in edge) + out.da / 2 if i < n_ta - 1 else math.inf,
                min(e[1] for e in edge) - out.dr / 2 if j > 0 else -math.inf,
                max(e[1] for e in edge) + out.dr / 2 if j < n_tr - 1 else math.inf,
            )
            win = (
                min(d.azimuth - d.spread_azimuth / 2 for d in dist) - ga,
                max(d.azimuth + d.spread_azimuth / 2 for d in dist) + ga,
                min(d.range - d.spread_range / 2 for d in dist) - gr,
                max(d.range + d.spread_range / 2 for d in dist) + gr,
            )
            tiles.append(
                Tile(
                    slice(int(ia), int(ib)),
                    slice(int(ja), int(jb)),
                    (ca, cr),
                    win,
                    (dist[0].azimuth, dist[0].range),
                    box,
                )
            )
    return tiles


def _whole(rounding: Callable[[float], int], x: float) -> int:
    """``rounding(x)``, but ``x`` within 1e-9 (relative) of a whole number is that number."""
    w = round(x)
    return int(w) if abs(x - w) <= 1e-9 * max(1.0, abs(x)) else int(rounding(x))


def window_slices(grid: Grid, window: tuple[float, float, float, float]) -> tuple[slice, slice]:
    """Pixel slices of ``grid`` covering ``window`` (a_min, a_max, r_min, r_max), FFT-friendly lengths.

    Offsets and widths that are whole numbers of pixels up to rounding are taken as those numbers: the
    step-1 grid starts 4 pixels before the lowest window (chain._first_step_grid), so that window's offset is
    4 by construction, and floor of 3.9999999999 would move its slice by a pixel on a 1e-10 m change of the
    antenna positions (the ECF round trip of a CPHD file: a -77 dB different two-step image of the
    band-limited nie2016_small, tests/formats/test_cphd_import.py).
    """
    out = []
    for lo, hi, start, step, n in (
        (window[0], window[1], grid.a0, grid.da, grid.n_a),
        (window[2], window[3], grid.r0, grid.dr, grid.n_r),
    ):
        i0 = _whole(math.floor, (lo - start) / step)
        width = _whole(math.ceil, (hi - lo) / step)
        length = sfft.next_fast_len(width + 2)
        i0 = min(max(0, i0 - (length - width - 2) // 2), max(0, n - length))
        out.append(slice(i0, min(n, i0 + length)))
    return out[0], out[1]


@dataclasses.dataclass(frozen=True)
class TileSupport:
    """A sub-image's polar support: the rectangle ``rect`` inscribed in its centre's polar support, on the
    axes e_a, e_r turned by ``angle`` (rad, from e_r towards e_a) onto the bisector of the centre's lines of
    sight (:func:`rotate_axes`)."""

    angle: float
    rect: Rect


def own_support(
    positions: np.ndarray,
    point: npt.ArrayLike,
    e_azimuth: np.ndarray,
    e_range: np.ndarray,
    carrier_frequency: float,
    band: tuple[float, float],
    lit: np.ndarray | None = None,
) -> TileSupport:
    """The rectangle inscribed in a point's polar support, aligned with the bisector of its lines of sight
    (of the pulses ``lit``, bool (n,), that illuminate it, where a beam sweeps: :func:`lit_pulses`).

    Seen from any point p, the same pulses and frequencies fill a sector turned by p's own line-of-sight
    angle theta_p. Aligned with that angle, the inscribed rectangle holds (to first order in |p - s| / R)
    the same pulses and frequencies whatever its centre s: a point on a seam gets the same response from
    both sub-images. A rectangle aligned with the image axes instead holds a set of samples turned by
    theta_p - theta_s, whose band centre and edges differ from one side of a seam to the other.
    A point lit by part of the aperture only (sliding spotlight, stripmap) has a narrow strip of that
    sector along its lit lines of sight, whose ends the rectangle then cuts square.
    """
    ua, ur = los_components(positions, point, e_azimuth, e_range)
    theta = np.arctan(ua / ur)  # from the e_r axis (u_r < 0: the antenna is on the near side)
    if lit is not None and np.count_nonzero(lit) > 1:
        theta = theta[lit]
    angle = float((theta.min() + theta.max()) / 2)
    ua, ur = los_components(positions, point, *rotate_axes(e_azimuth, e_range, angle))
    return TileSupport(angle, inscribed_support(ua, ur, carrier_frequency, np.asarray(band)))


def tile_rects(
    tiles: Iterable[Tile],
    positions: np.ndarray,
    reference: npt.ArrayLike,
    e_azimuth: np.ndarray,
    e_range: np.ndarray,
    carrier_frequency: float,
    band: tuple[float, float],
    radar: RadarMetadata | None = None,
) -> list[TileSupport]:
    """Each tile centre's own polar support (:func:`own_support`: its resolution, carrier and orientation)."""
    ref = np.asarray(reference, float)
    supports = []
    for t in tiles:
        s = ref + t.center_offset[0] * np.asarray(e_azimuth) + t.center_offset[1] * np.asarray(e_range)
        lit = lit_pulses(radar, positions, s)
        supports.append(own_support(positions, s, e_azimuth, e_range, carrier_frequency, band, lit))
    return supports


def lit_pulses(radar: RadarMetadata | None, positions: np.ndarray, point: npt.ArrayLike) -> np.ndarray | None:
    """The pulses whose -3 dB azimuth beam holds ``point`` (bool (n,)); None: every pulse (spotlight, no beam)."""
    if radar is None or radar.mode == "spotlight" or radar.azimuth_beamwidth <= 0:
        return None
    return beam.illuminated(radar, positions, np.asarray(point, float))


def local_irw(
    positions: np.ndarray,
    point: npt.ArrayLike,
    e_azimuth: np.ndarray,
    e_range: np.ndarray,
    carrier_frequency: float,
    band: tuple[float, float],
    factor: float = SINC_IRW_FACTOR,
    lit: np.ndarray | None = None,
) -> tuple[float, float]:
    """Theoretical (azimuth, range) IRW, m, of a point's own polar support (:func:`own_support`; along its
    side-lobe ridges, turned by the support's angle; varies over a wide scene)."""
    r = own_support(positions, point, e_azimuth, e_range, carrier_frequency, band, lit).rect
    return factor * 2 * math.pi / (r.ka_hi - r.ka_lo), factor * 2 * math.pi / (r.kr_hi - r.kr_lo)


def own_range_theory(
    positions: np.ndarray,
    point: npt.ArrayLike,
    e_azimuth: np.ndarray,
    e_range: np.ndarray,
    carrier_frequency: float,
    band: tuple[float, float],
    bandwidth: float,
    window: str,
    lit: np.ndarray | None = None,
    samples: int = 257,
) -> ResponseTheory:
    """A point's range theory under a ``window`` taper on each pulse's chirp band, over its own inscribed
    rectangle (:func:`own_support`, on its turned axes), which keeps the middle of the band only
    (:func:`rectangle_range_theory`)."""
    sup = own_support(positions, point, e_azimuth, e_range, carrier_frequency, band, lit)
    ua, ur = los_components(positions, point, *rotate_axes(e_azimuth, e_range, sup.angle))
    r = sup.rect
    kg = KGrid(
        r.ka_lo, (r.ka_hi - r.ka_lo) / (samples - 1), samples, r.kr_lo, (r.kr_hi - r.kr_lo) / (samples - 1), samples
    )
    return rectangle_range_theory(kg, ua, ur, carrier_frequency, bandwidth, window)


def _ramp(x: np.ndarray, lo: float, hi: float, half: float) -> np.ndarray:
    """1 inside [lo, hi], 0 beyond, a raised cosine over +-``half`` (m) about each finite bound."""
    out = np.ones(len(x))
    for edge, side in ((lo, 1.0), (hi, -1.0)):
        if math.isfinite(edge):
            s = np.clip(side * (x - edge) / (2 * half) + 0.5, 0.0, 1.0)
            out *= 0.5 - 0.5 * np.cos(math.pi * s)
    return out


def partition_weights(tiles: Sequence[Tile], index: int, grid: Grid, half: tuple[float, float]) -> np.ndarray:
    """Tile ``index``'s piece of a partition of unity of the step-1 image, on ``grid`` (n_a, n_r) float32.

    Each tile's cell is its :attr:`Tile.box` with raised-cosine edges +-``half`` (m, azimuth and range) wide;
    normalised by the sum over all cells, the pieces add up to one wherever a cell reaches (the boxes of
    neighbours meet at their seam, up to the distortion's variation along it, far less than ``half``).
    """
    a, r = grid.a, grid.r
    num = np.outer(_ramp(a, *tiles[index].box[:2], half[0]), _ramp(r, *tiles[index].box[2:], half[1]))
    total = np.zeros_like(num)
    for t in tiles:
        wa, wr = _ramp(a, *t.box[:2], half[0]), _ramp(r, *t.box[2:], half[1])
        if wa.any() and wr.any():
            total += np.outer(wa, wr)
    return np.divide(num, total, out=np.zeros_like(num), where=total > 0).astype(np.float32)


def grown_slices(tile: Tile, shape: tuple[int, int], margin: tuple[int, int]) -> tuple[slice, slice]:
    """The tile's core grown by ``margin`` pixels (azimuth, range) on every side, clipped to the grid."""
    return (
        slice(max(0, tile.rows.start - margin[0]), min(shape[0], tile.rows.stop + margin[0])),
        slice(max(0, tile.cols.start - margin[1]), min(shape[1], tile.cols.stop + margin[1])),
    )


def mosaic(
    shape: tuple[int, int],
    tiles: list[Tile],
    results: Iterable[np.ndarray],
    margin: tuple[int, int] | None = None,
) -> np.ndarray:
    """Place each tile's core into the output image; with ``margin``, add each tile's grown core
    (:func:`grown_slices`: the focused pieces of a partition of unity, which overlap)."""
    img = np.zeros(shape, np.complex64)
    for t, sub in zip(tiles, results):
        if margin is None:
            img[t.rows, t.cols] = sub
        else:
            img[grown_slices(t, shape, margin)] += sub
    return img


def run_tasks(tasks: Iterable[SubImageTask], mapper: Callable | None = None) -> Iterable[np.ndarray]:
    """Map :func:`focus_subimage` over the tasks (``mapper``: any map-like; default the builtin)."""
    return (mapper or map)(focus_subimage, tasks)
