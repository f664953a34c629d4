"""Fast factorised backprojection (Ulander, Hellsten and Stenstrom 2003): the exact sum of
:mod:`sarproc.focus.backprojection` in O(N^2 log N).

The aperture is split recursively: the single pulses are the first subapertures, the first level merges
``first_factor`` consecutive pulses and each further level ``factor`` consecutive subapertures into one. A
subaperture's image is kept on a polar grid around its centre (range from the centre, in-plane angle about its foot
on the image plane), demodulated by the carrier of that range so it is band-limited: in range by the pulse
bandwidth B (spacing c / (2 B q)), in angle by the subaperture's length L (spacing lambda_min / (2 L q), lambda_min
at the band's top frequency); q is the oversampling knob. A parent's polar sample is the sum of its children's
images read at the same plane point (Knab, cubic Lagrange or linear in range and angle, as two 1D passes along the
parent's rows: :func:`sarproc.focus.ffbp_kernel.merge_level`) with their carrier phase re-referenced to the
parent's range; the first level reads the upsampled pulses exactly as the exact engine does. The last polar image
is read at the output points with their exact range's carrier restored; a regular output grid finer than the
image's bandwidth is read on a coarse grid and upsampled (:func:`_cartesian_grid`). Antenna positions are taken
pulse by pulse (curved tracks); the output points must lie on a plane (every frame's grid does), and the platform
must not pass over the image.

Error against the exact image (power, relative): every read of a polar image (one per level above the first, and
the final one) adds the interpolator's mean-square error on a band filling 1/q of its sampling rate, in range
and in angle (:func:`read_error`, :func:`predicted_error`; where the reads fall on a geometry's tree,
:func:`predicted_image_error`).
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np

from sarproc.product.metadata import C

INTERPOLATIONS = ("knab", "cubic", "linear")
_PULSE_READS = ("linear", "cubic")  # the first level reads the upsampled pulses as the exact engine does
DEFAULT_TAPS = 6  # Knab reads of the polar subimages
# fractions per sample of the tabulated weights, read at the nearest: the fraction off by 1 / 8192 at most, a phase
# error below 2e-4 rad at the band edge of 2x oversampling (-79 dB)
_TABLE_STEPS = 4096


def taps_of(interpolation: str, taps: int = DEFAULT_TAPS) -> int:
    """Samples per axis a read uses: 2 (linear), 4 (cubic Lagrange) or ``taps`` (Knab, even)."""
    if interpolation == "linear":
        return 2
    if interpolation == "cubic":
        return 4
    if interpolation == "knab":
        if taps < 2 or taps % 2:
            raise ValueError(f"ffbp knab reads need an even number of taps >= 2, got {taps}")
        return int(taps)
    raise ValueError(f"unknown ffbp interpolation {interpolation!r}; known: {INTERPOLATIONS}")


def _exact_weights(t: np.ndarray, interpolation: str, oversample: float, taps: int) -> np.ndarray:
    """(taps, len(t)) weights of samples floor(p) + 1 - taps/2 + m at fractions t = p - floor(p)."""
    n = taps_of(interpolation, taps)
    if interpolation == "linear":
        return np.stack([1 - t, t])
    if interpolation == "cubic":
        return np.stack(
            [
                -t * (t - 1) * (t - 2) / 6,
                (t + 1) * (t - 1) * (t - 2) / 2,
                -(t + 1) * t * (t - 2) / 2,
                (t + 1) * t * (t - 1) / 6,
            ]
        )
    from sarproc.dsp.interp import kernel_weights

    d = t[None, :] - (np.arange(n)[:, None] + 1 - n // 2)  # distance of the point from each tap
    w = kernel_weights(d, "knab", n, oversampling=oversample)
    return w / w.sum(axis=0)  # unit gain at DC, as the windowed-sinc kernels elsewhere


def read_table(interpolation: str, oversample: float, taps: int = DEFAULT_TAPS) -> np.ndarray:
    """(steps + 1, taps) float32: row c the weights at fraction c / steps (the kernels read the nearest row);
    Knab's kernel is designed for a signal ``oversample`` times oversampled (nu = 1 - 1/q)."""
    t = np.arange(_TABLE_STEPS + 1) / _TABLE_STEPS
    return np.ascontiguousarray(_exact_weights(t, interpolation, oversample, taps).T, dtype=np.float32)


def _table_weights(t: np.ndarray, table: np.ndarray) -> np.ndarray:
    """The weights the kernels use at fractions t: the table's nearest rows, (taps, len(t))."""
    return table[np.floor(t * (len(table) - 1) + 0.5).astype(int)].T


def read_error(
    f: np.ndarray, interpolation: str, oversample: float = 2.0, taps: int = DEFAULT_TAPS
) -> tuple[float, complex]:
    """Reading tones at frequencies ``f`` (cycles per sample, equally weighted) by ``interpolation`` (as the
    kernels tabulate it, :func:`read_table`) at uniformly random fractions t: the mean-square error p = E|e|^2
    and the mean m = E[e conj(g)] of the error e = read - g relative to the true tone g = exp(j 2 pi f t) (m makes
    the range and angle errors of one 2D read add partly coherently: both are mostly a loss of gain towards the
    band edge)."""
    t = (np.arange(128) + 0.5) / 128
    f = np.asarray(f, float)
    w = _table_weights(t, read_table(interpolation, oversample, taps)).astype(float)
    n = w.shape[0]
    taps_at = np.exp(2j * np.pi * np.outer(np.arange(n) + 1 - n // 2, f))  # (taps, n_f)
    truth = np.exp(2j * np.pi * np.outer(t, f))  # (n_t, n_f)
    err = np.einsum("mt,mf->tf", w, taps_at) - truth
    return float(np.mean(np.abs(err) ** 2)), complex(np.mean(err * truth.conj()))


def interpolation_error(q: float, interpolation: str, taps: int = DEFAULT_TAPS) -> float:
    """Mean-square relative error of reading a signal with a flat spectrum over |f| < 1 / (2 q) cycles per sample
    (q times oversampled) by ``interpolation`` at a uniformly random fraction."""
    return read_error((np.arange(512) + 0.5) / 512 / q - 1 / (2 * q), interpolation, q, taps)[0]


def subaperture_lengths(n_pulses: int, factor: int, first_factor: int | None = None) -> list[int]:
    """Pulses per subaperture at each merge level: the first level merges ``first_factor`` pulses (default
    ``factor``; merging pulses is cheap, 1D reads, so a larger first factor saves a level), each further level
    ``factor`` subapertures, until one covers the aperture."""
    out, m = [], 1
    n, f = int(n_pulses), int(first_factor or factor)
    while n > 1:
        n = -(-n // f)
        m = min(m * f, int(n_pulses))
        out.append(m)
        f = factor
    return out


def levels(n_pulses: int, factor: int, first_factor: int | None = None) -> int:
    """Merge levels from single pulses to the whole aperture."""
    return len(subaperture_lengths(n_pulses, factor, first_factor))


def predicted_error(
    n_pulses: int,
    factor: int,
    oversample: float,
    interpolation: str,
    taps: int = DEFAULT_TAPS,
    first_factor: int | None = None,
    pulse_oversample: float | None = None,
    pulse_interpolation: str = "linear",
) -> float:
    """Predicted relative mean-square error (power) of the ffbp image against the exact one.

    Each level's polar images are read once (by the next level, the last by the output grid). In range their
    spectrum is flat over the band (q = oversample); in angle a subaperture of m equally spaced pulses holds m
    tones at frequencies proportional to the pulses' offsets from its centre, the outermost at the grid's band
    edge 1 / (2 q) (a straight track at broadside, the widest case). A read's error is the range and angle
    errors' sum (:func:`read_error`), the levels' errors add in power. With ``pulse_oversample`` (the upsampled
    pulses' rate over the bandwidth) the pulse reads' artefacts are added too (:func:`pulse_artefacts`). Needs no
    geometry (the plan's); :func:`predicted_image_error` follows the tree ffbp builds for a geometry."""
    q = oversample
    rng_p, rng_m = read_error((np.arange(512) + 0.5) / 512 / q - 1 / (2 * q), interpolation, q, taps)
    total = 0.0
    for m in subaperture_lengths(n_pulses, factor, first_factor):
        u = (np.arange(m) - (m - 1) / 2) / max((m - 1) / 2, 1e-9)
        ang_p, ang_m = read_error(u / (2 * q), interpolation, q, taps)
        total += rng_p + ang_p + 2 * (rng_m * ang_m.conjugate()).real
    if pulse_oversample:
        total += 2 * pulse_artefacts(pulse_interpolation, pulse_oversample)
    return total


def pulse_oversample(n_range: int, upsample: int, sampling_rate: float, bandwidth: float) -> float:
    """The upsampled pulses' sampling rate over the bandwidth (as both engines upsample them)."""
    from sarproc.focus.backprojection import upsampled_length

    return upsampled_length(n_range, upsample) / n_range * sampling_rate / bandwidth


def pulse_artefacts(interpolation: str, oversample: float) -> float:
    """The part of a pulse read's error that is not a gain of its frequency: reading tones over a flat band
    |f| < 1 / (2 q) at uniformly random fractions, E|read - G(f) g|^2 with G(f) the mean gain at f. Exact and
    ffbp images both read the pulses so (ffbp onto its first polar grids): the gain is common to both, the rest
    is not band-limited, so each image carries its own (twice this against each other: -51.9 dB for linear x8
    at 1.2 x sampling, q = 9.6, where ffbp's error against the exact image floors whatever its own reads)."""
    t = (np.arange(256) + 0.5) / 256
    f = (np.arange(512) + 0.5) / 512 / oversample - 1 / (2 * oversample)
    w = _table_weights(t, read_table(interpolation, oversample, 2 if interpolation == "linear" else 4)).astype(float)
    n = w.shape[0]
    truth = np.exp(2j * np.pi * np.outer(t, f))
    read = np.einsum("mt,mf->tf", w, np.exp(2j * np.pi * np.outer(np.arange(n) + 1 - n // 2, f)))
    gain = np.mean(read * truth.conj(), axis=0)
    return float(np.mean(np.abs(read - gain * truth) ** 2))


def _tone_responses(f: np.ndarray, table: np.ndarray, t: np.ndarray | None = None) -> np.ndarray:
    """R(t, f) = read / truth of tones ``f`` (cycles per sample) read through ``table`` at fractions ``t``
    (default 128 uniform ones): (len(t), len(f)) complex."""
    if t is None:
        t = (np.arange(128) + 0.5) / 128
    w = _table_weights(np.asarray(t, float), table).astype(float)
    n = w.shape[0]
    at_taps = w.T @ np.exp(2j * np.pi * np.outer(np.arange(n) + 1 - n // 2, f))
    return at_taps * np.exp(-2j * np.pi * np.outer(t, f))


def predicted_image_error(
    pos: np.ndarray,
    points: np.ndarray,
    carrier_frequency: float,
    bandwidth: float,
    *,
    grid_shape: tuple[int, int] | None = None,
    factor: int = 4,
    first_factor: int | None = None,
    oversample: float = 2.0,
    ffbp_interpolation: str = "knab",
    ffbp_taps: int = DEFAULT_TAPS,
    pulse_oversample: float | None = None,
    pulse_interpolation: str = "linear",
    n_points: int = 3,
) -> float:
    """:func:`predicted_error` for the tree :func:`ffbp_points` builds for these antenna positions and points
    (same arguments): each read where the engine makes it. At n_points^2 image points, per pulse and range tone
    (flat over the band): in angle, each level's tone from the pulse's offset from its subaperture's centre as
    seen from the point (slant-plane squint, curved tracks, the tone's RF frequency: a 30 deg squint fills ~87 %
    of the band the grid is sized for, where the broadside model puts the edge pulses at the band edge and Knab's
    error peaks); in range, each level's images read by their parent at the fraction the grids leave (the child's
    grid starts at its parent's sector's near edge, so a short subaperture's grid nearly coincides with its
    parent's in range and is read near its samples), the output's read at a uniform one; in angle at uniform
    fractions. The levels' responses multiply (a tone's gain losses add level by level in amplitude), averaged
    over the fractions left random; the pulse reads' artefacts added as there (measured: BOUND_MARGIN's comment)."""
    taps = _checked_taps(pulse_interpolation, ffbp_interpolation, ffbp_taps, factor, first_factor, oversample)
    pos = np.asarray(pos, float)
    plane = _image_plane(np.asarray(points, float).reshape(-1, 3), grid_shape, carrier_frequency)
    ant = pos - plane.origin
    reads = _polar_reads(ffbp_interpolation, taps, bandwidth, oversample, None)
    spans = _subaperture_spans(len(pos), factor, first_factor)
    f_max = carrier_frequency + 0.5 * bandwidth
    tree = _polar_grids(spans, ant, plane, reads.dr, f_max, oversample)
    _fit_extents(tree, plane.boundary, reads.dr, reads.margin)
    q = oversample
    xy = _lattice_points(plane)[0] if plane.xy is None else plane.xy
    s = (np.arange(n_points) + 0.5) / n_points
    lo, hi = xy.min(axis=0), xy.max(axis=0)
    at = np.stack(np.meshgrid(lo[0] + s * (hi[0] - lo[0]), lo[1] + s * (hi[1] - lo[1]), indexing="ij"), -1)
    f_r = (np.arange(32) + 0.5) / 32 / q - 1 / (2 * q)  # range tones (cycles per sample)
    rf = (carrier_frequency + f_r * q * bandwidth) / f_max  # their RF frequency over the grid's
    # angle reads at uniform fractions: mean gain and power, tabulated over frequency
    f_tab = np.linspace(-0.5, 0.5, 2049)
    r_tab = _tone_responses(f_tab, reads.tab_t)
    g_tab, p_tab = r_tab.mean(axis=0), (np.abs(r_tab) ** 2).mean(axis=0)
    r_out = _tone_responses(f_r, reads.tab_r)
    ant_xy = np.stack([ant @ plane.e1, ant @ plane.e2], axis=-1)
    total = 0.0
    for p in at.reshape(-1, 2):
        gain, power = np.ones((len(pos), len(f_r)), complex), np.ones((len(pos), len(f_r)))
        r_j = np.sqrt(((p - ant_xy) ** 2).sum(axis=1) + (ant @ plane.nrm) ** 2)  # each pulse's range to p
        for lev in range(1, tree.n_levels + 1):
            g, e = tree.geos[lev - 1], spans[lev]
            child = np.repeat(np.arange(len(e) - 1), np.diff(e))
            d = p - g[:, :2]
            rho = np.hypot(d[:, 0], d[:, 1])
            r = np.hypot(rho, g[:, 2])
            half = C / (f_max * 4.0 * q * g[:, 7])
            # angle tone of each pulse: d(range)/d(angle) at fixed range from its subaperture's centre, over half
            tang = np.stack([-d[:, 1], d[:, 0]], axis=-1) / rho[:, None]
            off = ant_xy - g[child, :2]
            u = -rho[child] * (off * tang[child]).sum(axis=1) / (r_j * half[child])
            f_a = np.clip(np.outer(u, rf) / (2 * q), -0.5, 0.5)
            ga = np.interp(f_a, f_tab, g_tab.real) + 1j * np.interp(f_a, f_tab, g_tab.imag)
            pa = np.interp(f_a, f_tab, p_tab)
            if lev == tree.n_levels:  # the output's read: uniform fractions
                gr, pr = r_out.mean(axis=0)[None, :], (np.abs(r_out) ** 2).mean(axis=0)[None, :]
            else:
                gp = tree.geos[lev]
                parent = np.searchsorted(spans[lev + 1], e[:-1], side="right") - 1
                r_p = np.hypot(np.hypot(*(p - gp[parent, :2]).T), gp[parent, 2])
                t = np.mod((gp[parent, 3] + r - r_p - g[:, 3]) / reads.dr, 1.0)
                rr = _tone_responses(f_r, reads.tab_r, t)[child]
                gr, pr = rr, np.abs(rr) ** 2
            gain, power = gain * gr * ga, power * pr * pa
        total += float(np.mean(power - 2 * gain.real + 1))
    total /= n_points * n_points
    if pulse_oversample:
        total += 2 * pulse_artefacts(pulse_interpolation, pulse_oversample)
    return total


# The models against the measured error (tests/focus/test_ffbp.py's scenes: broadside stripmap, 30 deg squinted
# spotlight, a wobbling track; cubic at q = 2 .. 4 (first factor 4), Knab 8, 10, 12 at q = 1.5 .. 2, linear x8
# pulse reads; the commit adding predicted_image_error has the table): predicted_image_error from 1.3 dB
# optimistic to 0.5 dB pessimistic where the polar reads dominate; where the linear pulse reads' artefacts (-52 dB)
# dominate it is up to 4.6 dB pessimistic on the squinted scene (their "twice" holds at broadside: within 0.2 dB on
# the stripmap, 1.7 dB on the wobbling track). predicted_error (the plan's: broadside, uniform fractions, levels in
# power) from 3.2 dB optimistic (cubic: the levels' gain losses add in amplitude) to 5.7 dB pessimistic (a 30 deg
# squint puts no pulse at the band's edge, where Knab's error peaks). The bound adds 4 dB.
BOUND_MARGIN = 10**0.4


def error_bound(predicted: float) -> float:
    """The error the ffbp image stays below (power, relative to the exact image): the model + 4 dB."""
    return BOUND_MARGIN * predicted


def _plane(points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Origin, in-plane axes e1, e2 and normal of the points' best-fitting plane."""
    sample = points[:: max(1, len(points) // 4096)]
    origin = sample.mean(axis=0)  # any point near the plane: the fit is the sample's
    if len(sample) < 3:
        return origin, np.eye(3)[0], np.eye(3)[1], np.eye(3)[2]
    _, _, vt = np.linalg.svd(sample - origin, full_matrices=False)
    return origin, vt[0], vt[1], vt[2]


def _lattice(
    points: np.ndarray, grid_shape: tuple[int, int] | None
) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """(first point, step along axis 0, step along axis 1) when the points are that regular (n0, n1) lattice,
    every point within a millionth of a step of it (checked on all points, compiled: a few ms a million points);
    else None."""
    from sarproc.focus import ffbp_kernel as fk

    if grid_shape is None or min(grid_shape) < 2 or grid_shape[0] * grid_shape[1] != len(points):
        return None
    n0, n1 = grid_shape
    p0 = points[0].copy()
    a = (points[(n0 - 1) * n1] - p0) / (n0 - 1)
    b = (points[n1 - 1] - p0) / (n1 - 1)
    la, lb = np.linalg.norm(a), np.linalg.norm(b)
    if not (la > 0 and lb > 0) or np.linalg.norm(np.cross(a, b)) < 1e-6 * la * lb:
        return None
    if fk.lattice_deviation(np.ascontiguousarray(points), p0, a, b, n1) > 1e-6 * min(la, lb):
        return None
    return p0, a, b


def _boundary(xy: np.ndarray, grid_shape: tuple[int, int] | None) -> np.ndarray:
    """Points on the image's boundary in plane coordinates: the grid's edges, else the convex hull."""
    if grid_shape is not None:
        g = xy.reshape(*grid_shape, 2)
        return np.concatenate([g[0], g[-1], g[:, 0], g[:, -1]])
    if len(xy) < 4:
        return xy
    from scipy.spatial import ConvexHull

    try:
        return xy[ConvexHull(xy).vertices]
    except Exception:  # degenerate (collinear) points: all of them bound themselves
        return xy


# the upsampling's reads: -80 dB each (interpolation_error), far below the polar reads' and the pulses' floor
CARTESIAN_TAPS, CARTESIAN_OVERSAMPLE = 12, 1.75
CARTESIAN_FILL = 0.75  # the coarse grid is used when it has at most this many points per output point


@dataclasses.dataclass(frozen=True)
class _CoarseGrid:
    """A coarse grid along the output lattice's axes (:func:`_cartesian_grid`): its first point and steps in plane
    coordinates, its shape, and the output rows' and columns' positions in its samples."""

    origin: np.ndarray
    step_a: np.ndarray
    step_b: np.ndarray
    shape: tuple[int, int]
    pos_a: np.ndarray
    pos_b: np.ndarray


def _cartesian_grid(
    xy0: np.ndarray,
    a: np.ndarray,
    b: np.ndarray,
    grid_shape: tuple[int, int],
    top_geo: np.ndarray,
    oversample: float,
    range_oversample: float,
    boundary: np.ndarray,
) -> _CoarseGrid | None:
    """A coarse grid along the axes of the output lattice (first point xy0, steps a and b in plane coordinates)
    that samples the top image (demodulated by the carrier of the range from its centre: a baseband image)
    CARTESIAN_OVERSAMPLE times its bandwidth along each axis, when the output grid is at least 1 / CARTESIAN_FILL
    times as dense; else None. Returns its origin and steps (plane coordinates), shape, and the output rows' and
    columns' positions in its samples."""
    n0, n1 = grid_shape
    # band half-widths (cycles per metre) of the top polar image: B/c radially, 1 / (2 q dtheta rho) across
    fx, fy, _, _, dr, th_mid, _, dth = top_geo[:8]
    d = boundary - [fx, fy]
    rho = np.hypot(d[:, 0], d[:, 1])
    if rho.min() <= 0:
        return None
    u_r = d / rho[:, None]
    u_t = np.stack([-u_r[:, 1], u_r[:, 0]], axis=1)
    # the radial band is the range grid's (dr sampled range_oversample times it), the angular the angle grid's
    b_r, b_t = 1.0 / (2 * range_oversample * dr), 1.0 / (2 * oversample * dth * rho)
    steps, counts, pos = [], [], []
    margin = CARTESIAN_TAPS // 2 + 1
    for v, n in ((a, n0), (b, n1)):
        length = np.hypot(*v)
        u = v / length
        width = (np.abs(u_r @ u) * b_r + np.abs(u_t @ u) * b_t).max() * 1.02
        step = min(1.0 / (2 * CARTESIAN_OVERSAMPLE * width), length * n)
        steps.append(u * step)
        counts.append(int(np.ceil((n - 1) * length / step)) + 2 * margin + 1)
        pos.append(margin + np.arange(n) * length / step)
    if counts[0] * counts[1] > CARTESIAN_FILL * n0 * n1:
        return None
    origin = xy0 - margin * (steps[0] + steps[1])
    return _CoarseGrid(origin, steps[0], steps[1], (counts[0], counts[1]), pos[0], pos[1])


def _upsampling_weights(pos: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """First sample and (len(pos), CARTESIAN_TAPS) float32 Knab weights (unit sum) of reading n samples at
    positions ``pos``; taps outside 0 .. n-1 weigh zero (their index clamped)."""
    first = np.floor(pos).astype(np.int64) + 1 - CARTESIAN_TAPS // 2
    w = _exact_weights(pos - np.floor(pos), "knab", CARTESIAN_OVERSAMPLE, CARTESIAN_TAPS).T
    shift = np.clip(first, 0, n - CARTESIAN_TAPS) - first  # taps past an edge: move the window, zero them
    idx = np.arange(CARTESIAN_TAPS)[None, :] + shift[:, None]  # new tap m is old tap m + shift
    ok = (idx >= 0) & (idx < CARTESIAN_TAPS)
    moved = np.where(ok, np.take_along_axis(w, np.clip(idx, 0, CARTESIAN_TAPS - 1), axis=1), 0.0)
    return first + shift, np.ascontiguousarray(moved, dtype=np.float32)


def _extents(
    foot: np.ndarray, h: np.ndarray, boundary: np.ndarray, theta_mid: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Per subimage (rows of foot, h, theta_mid), the min/max range and relative angle over boundary (n_sub, m, 2)."""
    d = boundary - foot[:, None, :]
    r = np.sqrt(np.einsum("smk,smk->sm", d, d) + (h**2)[:, None])
    th = np.arctan2(d[..., 1], d[..., 0]) - theta_mid[:, None]
    th -= 2 * np.pi * np.floor(th / (2 * np.pi) + 0.5)
    return r.min(axis=1), r.max(axis=1), th.min(axis=1), th.max(axis=1)


def _sector_boundary(geo: np.ndarray, ints: np.ndarray, n_edge: int = 24) -> np.ndarray:
    """Plane points on the boundary of each polar grid's sector (n_sub, 4 n_edge, 2)."""
    fx, fy, h, r0, dr, th_mid, th_lo, dth = geo.T[:8]
    n_t, n_r = ints[:, 0], ints[:, 1]
    r1 = r0 + (n_r - 1) * dr
    t0 = th_mid + th_lo
    t1 = t0 + (n_t - 1) * dth
    u = np.linspace(0.0, 1.0, n_edge)
    rr = np.concatenate(
        [
            np.outer(r0, np.ones(n_edge)),
            np.outer(r1, np.ones(n_edge)),
            r0[:, None] + np.outer(r1 - r0, u),
            r0[:, None] + np.outer(r1 - r0, u),
        ],
        axis=1,
    )
    tt = np.concatenate(
        [
            t0[:, None] + np.outer(t1 - t0, u),
            t0[:, None] + np.outer(t1 - t0, u),
            np.outer(t0, np.ones(n_edge)),
            np.outer(t1, np.ones(n_edge)),
        ],
        axis=1,
    )
    rho = np.sqrt(np.maximum(rr**2 - (h**2)[:, None], 0.0))
    return np.stack([fx[:, None] + rho * np.cos(tt), fy[:, None] + rho * np.sin(tt)], axis=-1)


@dataclasses.dataclass
class _ImagePlane:
    """The output points' plane: origin, in-plane axes e1, e2 and normal nrm; the image's boundary in plane
    coordinates; the points' plane coordinates xy and heights pz off the plane (None for a regular lattice until
    its points are needed); for a regular lattice its first point xy0, steps a_xy, b_xy and shape."""

    origin: np.ndarray
    e1: np.ndarray
    e2: np.ndarray
    nrm: np.ndarray
    boundary: np.ndarray
    xy: np.ndarray | None = None
    pz: np.ndarray | None = None
    xy0: np.ndarray | None = None
    a_xy: np.ndarray | None = None
    b_xy: np.ndarray | None = None
    shape: tuple[int, int] | None = None


@dataclasses.dataclass
class _Tree:
    """The subaperture tree: spans[lev] the first pulse of each level-lev subaperture (and n_az); per level >= 1
    its polar grids' float geometry geos[lev - 1] (n_sub, 12) and integer layout ints[lev - 1] (n_sub, 3) as
    :func:`sarproc.focus.ffbp_kernel.merge_level` reads them."""

    spans: list[np.ndarray]
    geos: list[np.ndarray]
    ints: list[np.ndarray]

    @property
    def n_levels(self) -> int:
        return len(self.spans) - 1


@dataclasses.dataclass
class _Image:
    """One level's images in the kernels' layout: flat complex64 samples, float geometry (n, 12), integer layout
    (n, 3) and the weights table of reading them in range."""

    buf: np.ndarray
    geo: np.ndarray
    ints: np.ndarray
    table: np.ndarray


def _checked_taps(
    interpolation: str,
    ffbp_interpolation: str,
    ffbp_taps: int,
    factor: int,
    first_factor: int | None,
    oversample: float,
) -> int:
    """The polar reads' taps, after refusing pulse reads, factors or oversampling ffbp cannot use."""
    if interpolation not in _PULSE_READS:
        raise ValueError(f"ffbp reads the pulses 'linear' or 'cubic', not {interpolation!r}")
    taps = taps_of(ffbp_interpolation, ffbp_taps)
    if factor < 2 or oversample < 1 or (first_factor or factor) < 2:
        raise ValueError(
            f"ffbp needs factors >= 2 and oversample >= 1 (got {factor}, first {first_factor}, {oversample})"
        )
    return taps


def _image_plane(points: np.ndarray, grid_shape: tuple[int, int] | None, carrier_frequency: float) -> _ImagePlane:
    """The points' plane, their plane coordinates and boundary; refuses points off a plane."""
    lattice = _lattice(points, grid_shape)
    if lattice is not None:
        # a regular grid (every frame's plane grids): its plane and plane coordinates from the lattice itself, no
        # pass over all points (~1.5 s at 4096^2)
        p0, la, lb = lattice
        n0, n1 = grid_shape  # type: ignore[misc]
        e1 = la / np.linalg.norm(la)
        nrm = np.cross(la, lb)
        nrm /= np.linalg.norm(nrm)
        e2 = np.cross(nrm, e1)
        origin = p0 + 0.5 * ((n0 - 1) * la + (n1 - 1) * lb)
        xy0 = np.array([(p0 - origin) @ e1, (p0 - origin) @ e2])
        a_xy, b_xy = np.array([la @ e1, la @ e2]), np.array([lb @ e1, lb @ e2])
        rows, cols = np.arange(n0), np.arange(n1)
        edge_ij = [(0 * cols, cols), (0 * cols + n0 - 1, cols), (rows, 0 * rows), (rows, 0 * rows + n1 - 1)]
        boundary = np.concatenate([xy0 + i[:, None] * a_xy + j[:, None] * b_xy for i, j in edge_ij])
        return _ImagePlane(origin, e1, e2, nrm, boundary, xy0=xy0, a_xy=a_xy, b_xy=b_xy, shape=(n0, n1))
    origin, e1, e2, nrm = _plane(points)
    rel = points - origin
    xy = np.stack([rel @ e1, rel @ e2], axis=-1)
    pz = rel @ nrm
    if np.abs(pz).max() > 1e-3 * C / carrier_frequency:
        raise ValueError(
            f"ffbp needs the points on a plane: they leave their best plane by up to "
            f"{np.abs(pz).max():.3g} m (more than a thousandth of a wavelength)"
        )
    return _ImagePlane(origin, e1, e2, nrm, _boundary(xy, grid_shape), xy=xy, pz=pz)


def _lattice_points(plane: _ImagePlane) -> tuple[np.ndarray, np.ndarray]:
    """Plane coordinates and (zero) heights of every point of the plane's regular lattice."""
    assert plane.xy0 is not None and plane.a_xy is not None and plane.b_xy is not None and plane.shape is not None
    n0, n1 = plane.shape
    ii, jj = np.arange(n0)[:, None], np.arange(n1)[None, :]
    xy = (plane.xy0 + ii[..., None] * plane.a_xy + jj[..., None] * plane.b_xy).reshape(-1, 2)
    return xy, np.zeros(len(xy))


def _subaperture_spans(n_az: int, factor: int, first_factor: int | None) -> list[np.ndarray]:
    """The tree's levels as subaperture edges: level 0 the pulses, level 1 groups of first_factor consecutive
    pulses, then groups of factor."""
    spans = [np.arange(n_az + 1)]
    while len(spans[-1]) > 2:
        edges = spans[-1][:: factor if len(spans) > 1 else int(first_factor or factor)]
        spans.append(edges if edges[-1] == n_az else np.append(edges, n_az))
    return spans


def _polar_grids(
    spans: list[np.ndarray], ant: np.ndarray, plane: _ImagePlane, dr: float, f_max: float, oversample: float
) -> _Tree:
    """Each subaperture's polar grid about its centre (antenna positions ``ant`` relative to the plane's origin):
    range spacing dr, angle spacing from its length, centred on the direction of the image's centre; extents
    left to :func:`_fit_extents`."""
    centre_xy = plane.boundary.mean(axis=0)  # inside the image (a mean over all points costs ~0.2 s at 4096^2)
    e1, e2, nrm = plane.e1, plane.e2, plane.nrm
    csum = np.concatenate([np.zeros((1, 3)), np.cumsum(ant, axis=0)])
    geos, ints_ = [], []
    for lev in range(1, len(spans)):
        e = spans[lev]
        centre = (csum[e[1:]] - csum[e[:-1]]) / np.diff(e)[:, None]
        half = np.array([np.linalg.norm(ant[a:b] - c, axis=1).max() for a, b, c in zip(e[:-1], e[1:], centre)])
        g = np.zeros((len(centre), 12))
        g[:, 0], g[:, 1], g[:, 2] = centre @ e1, centre @ e2, centre @ nrm
        g[:, 4] = dr
        g[:, 5] = np.arctan2(centre_xy[1] - g[:, 1], centre_xy[0] - g[:, 0])
        g[:, 7] = C / (f_max * 4.0 * np.maximum(half, 1e-9) * oversample)
        g[:, 8], g[:, 9] = np.cos(g[:, 5]), np.sin(g[:, 5])
        g[:, 10], g[:, 11] = 1.0 / dr, 1.0 / g[:, 7]
        geos.append(g)
        ints_.append(np.zeros((len(centre), 3), np.int64))
    return _Tree(spans, geos, ints_)


def _fit_extents(tree: _Tree, boundary: np.ndarray, dr: float, margin: int) -> None:
    """Set each polar grid's first range and angle, sample counts and offset in its level's buffer, top-down:
    the top grid covers the image, each child the sector its parent's grid spans; ``margin`` samples beyond
    for the reads."""
    n_levels = tree.n_levels
    for lev in range(n_levels, 0, -1):
        g, it = tree.geos[lev - 1], tree.ints[lev - 1]
        if lev == n_levels:
            bnd = np.broadcast_to(boundary, (len(g),) + boundary.shape)
        else:
            parent_of = np.searchsorted(tree.spans[lev + 1], tree.spans[lev][:-1], side="right") - 1
            bnd = _sector_boundary(tree.geos[lev], tree.ints[lev])[parent_of]
        r_lo, r_hi, t_lo, t_hi = _extents(g[:, :2], g[:, 2], bnd, g[:, 5])
        g[:, 3] = r_lo - margin * dr
        it[:, 1] = np.ceil((r_hi - r_lo) / dr).astype(np.int64) + 2 * margin + 1
        g[:, 6] = t_lo - margin * g[:, 7]
        it[:, 0] = np.ceil((t_hi - t_lo) / g[:, 7]).astype(np.int64) + 2 * margin + 1
        it[:, 2] = np.concatenate([[0], np.cumsum(it[:, 0] * it[:, 1])[:-1]])


def _pulse_image(
    rc: np.ndarray,
    range_time: np.ndarray,
    gate: np.ndarray,
    upsample: int,
    interpolation: str,
    ant_xy: np.ndarray,
    ant_h: np.ndarray,
) -> _Image:
    """The upsampled pulses as level 0's images: one angle each, range from the antenna."""
    from sarproc.focus.backprojection import read_emphasis, upsample_into, upsampled_length

    n_az, n_rg = rc.shape
    dt = (range_time[-1] - range_time[0]) / (n_rg - 1) if n_rg > 1 else 1.0
    n_up = upsampled_length(n_rg, upsample)
    fs_up = n_up / (n_rg * dt)
    buf = np.empty((n_az, n_up), np.complex64)
    cbuf = upsample_into(np.asarray(rc, np.complex64), buf, emphasis=read_emphasis(n_rg, n_up, interpolation)).ravel()
    cgeo = np.zeros((n_az, 12))
    cgeo[:, 0], cgeo[:, 1], cgeo[:, 2] = ant_xy[:, 0], ant_xy[:, 1], ant_h
    cgeo[:, 3] = C * (range_time[0] + gate) / 2.0
    cgeo[:, 4] = C / (2.0 * fs_up)
    cgeo[:, 7] = 1.0
    cgeo[:, 10], cgeo[:, 11] = 1.0 / cgeo[:, 4], 1.0
    cints = np.stack([np.ones(n_az, np.int64), np.full(n_az, n_up), np.arange(n_az) * n_up], axis=1)
    return _Image(cbuf, cgeo, cints, read_table(interpolation, 1.0))


def _merge(
    child: _Image, tree: _Tree, lev: int, kc2: float, tab_t: np.ndarray, tab_r: np.ndarray, linear: bool
) -> _Image:
    """Level lev's polar images, each the sum of its children's (level lev - 1) read on its grid."""
    from sarproc.focus import ffbp_kernel as fk

    g, it = tree.geos[lev - 1], tree.ints[lev - 1]
    pbuf = np.empty(int((it[:, 0] * it[:, 1]).sum()), np.complex64)
    row_parent = np.repeat(np.arange(len(g)), it[:, 0])
    row_angle = np.arange(len(row_parent)) - np.repeat(np.cumsum(it[:, 0]) - it[:, 0], it[:, 0])
    first_child = np.searchsorted(tree.spans[lev - 1], tree.spans[lev], side="left")
    fk.merge_level(
        child.buf,
        child.geo,
        child.ints,
        first_child,
        g,
        it,
        pbuf,
        row_parent,
        row_angle,
        kc2,
        child.table,
        tab_t,
        int(child.ints[:, 1].max()),
        linear,
    )
    return _Image(pbuf, g, it, tab_r)


def _read_points(
    top: _Image, xy: np.ndarray, pz: np.ndarray, kc2: float, tab_t: np.ndarray, n_az: int, out: np.ndarray
) -> None:
    """Read the top image at every output point (plane coordinates xy, heights pz), carrier restored, into out."""
    from sarproc.focus import ffbp_kernel as fk

    fk.final_points(
        top.buf,
        top.buf.view(np.float32),
        top.geo,
        top.ints,
        np.ascontiguousarray(xy[:, 0]),
        np.ascontiguousarray(xy[:, 1]),
        np.ascontiguousarray(pz),
        kc2,
        top.table,
        tab_t,
        out,
        True,
    )
    out /= n_az


def _read_coarse(top: _Image, coarse: _CoarseGrid, kc2: float, tab_t: np.ndarray) -> np.ndarray:
    """The top image (baseband) read on the coarse grid from :func:`_cartesian_grid`: complex64 of its shape."""
    from sarproc.focus import ffbp_kernel as fk

    ia, ib = np.meshgrid(np.arange(coarse.shape[0]), np.arange(coarse.shape[1]), indexing="ij")
    cx = coarse.origin[0] + ia * coarse.step_a[0] + ib * coarse.step_b[0]
    cy = coarse.origin[1] + ia * coarse.step_a[1] + ib * coarse.step_b[1]
    low = np.empty(cx.size, np.complex128)
    fk.final_points(
        top.buf,
        top.buf.view(np.float32),
        top.geo,
        top.ints,
        cx.ravel(),
        cy.ravel(),
        np.zeros(cx.size),
        kc2,
        top.table,
        tab_t,
        low,
        False,
    )
    return low.astype(np.complex64).reshape(coarse.shape)


def _upsample_to_lattice(
    low_c: np.ndarray,
    coarse: _CoarseGrid,
    plane: _ImagePlane,
    top_geo: np.ndarray,
    kc2: float,
    n_az: int,
    out: np.ndarray,
) -> None:
    """Upsample the coarse grid separably (Knab, CARTESIAN_TAPS) to the output lattice and restore the carrier
    pixel by pixel (the range from the top image's centre ``top_geo``), into out."""
    from sarproc.focus import ffbp_kernel as fk

    assert plane.xy0 is not None and plane.a_xy is not None and plane.b_xy is not None
    ia, wa = _upsampling_weights(coarse.pos_a, coarse.shape[0])
    ib, wb = _upsampling_weights(coarse.pos_b, coarse.shape[1])
    fk.upsample_restore(
        low_c,
        ia,
        wa,
        ib,
        wb,
        plane.xy0[0],
        plane.xy0[1],
        plane.a_xy[0],
        plane.a_xy[1],
        plane.b_xy[0],
        plane.b_xy[1],
        top_geo[0],
        top_geo[1],
        top_geo[2],
        kc2,
        1.0 / n_az,
        out,
    )


@dataclasses.dataclass(frozen=True)
class _PolarReads:
    """How the polar images are sampled and read: range spacing ``dr`` (m), the range and angle weight tables,
    and the samples beyond a sector that its reads reach."""

    dr: float
    tab_r: np.ndarray
    tab_t: np.ndarray
    margin: int


def _polar_reads(
    ffbp_interpolation: str, taps: int, bandwidth: float, oversample: float, range_oversample: float | None
) -> _PolarReads:
    q_r = range_oversample or oversample
    return _PolarReads(
        dr=C / (2.0 * bandwidth * q_r),
        tab_r=read_table(ffbp_interpolation, q_r, taps),
        tab_t=read_table(ffbp_interpolation, oversample, taps),
        margin=taps // 2 + 1,  # +1: the fractions' rounding
    )


def _level_info(tree: _Tree) -> dict:
    """The tree's levels and polar grid sizes, for ``info``."""
    return dict(
        levels=tree.n_levels,
        samples=[int((it[:, 0] * it[:, 1]).sum()) for it in tree.ints],
        angles_top=int(tree.ints[-1][0, 0]),
        ranges_top=int(tree.ints[-1][0, 1]),
    )


def _read_output(
    top: _Image,
    plane: _ImagePlane,
    n_points: int,
    kc2: float,
    tab_t: np.ndarray,
    oversample: float,
    range_oversample: float,
    n_az: int,
    info: dict | None,
    seconds: list[float],
) -> np.ndarray:
    """The top image at every output point, carrier restored, divided by n_az: a regular lattice finer than the
    image's bandwidth is read on a coarse grid at that bandwidth and upsampled; other points are read one by
    one."""
    out = np.empty(n_points, np.complex128)
    coarse = None
    if plane.shape is not None:
        assert plane.xy0 is not None and plane.a_xy is not None and plane.b_xy is not None
        coarse = _cartesian_grid(
            plane.xy0, plane.a_xy, plane.b_xy, plane.shape, top.geo[0], oversample, range_oversample, plane.boundary
        )
        if coarse is None:  # the lattice's points, for the reads at every point
            plane.xy, plane.pz = _lattice_points(plane)
    if coarse is None:
        assert plane.xy is not None and plane.pz is not None
        _read_points(top, plane.xy, plane.pz, kc2, tab_t, n_az, out)
        return out
    if info is not None:
        info["cartesian"] = coarse.shape
    low_c = _read_coarse(top, coarse, kc2, tab_t)
    seconds.append(time.perf_counter())
    _upsample_to_lattice(low_c, coarse, plane, top.geo[0], kc2, n_az, out)
    return out


def ffbp_points(
    rc: np.ndarray,
    range_time: np.ndarray,
    pos: np.ndarray,
    points: np.ndarray,
    carrier_frequency: float,
    bandwidth: float,
    *,
    upsample: int = 8,
    interpolation: str = "linear",
    gate_offset: np.ndarray | None = None,
    factor: int = 4,
    first_factor: int | None = None,
    oversample: float = 2.0,
    ffbp_interpolation: str = "knab",
    ffbp_taps: int = DEFAULT_TAPS,
    grid_shape: tuple[int, int] | None = None,
    workers: int | None = None,
    info: dict | None = None,
    range_oversample: float | None = None,
) -> np.ndarray:
    """Backproject range-compressed pulses (monostatic, antenna at ``pos`` (n_az, 3)) onto points on a plane by
    fast factorised backprojection; same result as backproject_points(..., engine='compiled') within
    :func:`predicted_error`. rc, range_time, gate_offset, upsample and interpolation ('linear' / 'cubic' on the
    upsampled pulse) as there; factor: subapertures merged per level; oversample: polar grid sampling over Nyquist;
    ffbp_interpolation: 'cubic' or 'linear' reads of the polar images; grid_shape: (n_az, n_rg) if the points are a
    grid in that order (its edges bound it; a regular lattice gives the plane coordinates without a pass over the
    points and, when finer than the image's bandwidth, is read on a coarse grid and upsampled). ``info`` (a dict)
    receives the levels and grid sizes.
    Returns (n_points,) complex128: the sum over pulses divided by n_az."""
    from sarproc.focus.backprojection import numba_threads

    taps = _checked_taps(interpolation, ffbp_interpolation, ffbp_taps, factor, first_factor, oversample)
    rc = np.asarray(rc)
    n_az = rc.shape[0]
    points = np.asarray(points, float).reshape(-1, 3)
    pos = np.asarray(pos, float)
    if n_az == 0:
        raise ValueError("ffbp_points: no pulses (rc has 0 rows)")
    if len(points) == 0:
        return np.zeros(0, np.complex128)
    gate = np.zeros(n_az) if gate_offset is None else np.asarray(gate_offset, float)
    plane = _image_plane(points, grid_shape, carrier_frequency)
    ant = pos - plane.origin
    kc2 = 2.0 * carrier_frequency / C
    reads = _polar_reads(ffbp_interpolation, taps, bandwidth, oversample, range_oversample)
    spans = _subaperture_spans(n_az, factor, first_factor)
    tree = _polar_grids(spans, ant, plane, reads.dr, carrier_frequency + 0.5 * bandwidth, oversample)
    _fit_extents(tree, plane.boundary, reads.dr, reads.margin)
    if info is not None and tree.n_levels:
        info.update(_level_info(tree))

    ant_xy = np.stack([ant @ plane.e1, ant @ plane.e2], axis=-1)
    seconds = [time.perf_counter()]
    with numba_threads(workers):
        image = _pulse_image(rc, range_time, gate, upsample, interpolation, ant_xy, ant @ plane.nrm)
        seconds.append(time.perf_counter())
        for lev in range(1, tree.n_levels + 1):
            linear = lev == 1 and interpolation == "linear"
            image = _merge(image, tree, lev, kc2, reads.tab_t, reads.tab_r, linear)
            seconds.append(time.perf_counter())
        q_r = range_oversample or oversample
        out = _read_output(image, plane, len(points), kc2, reads.tab_t, oversample, q_r, n_az, info, seconds)
        seconds.append(time.perf_counter())
    if info is not None:  # the pulses' upsampling, each level's merge, the output's read
        info["seconds"] = list(np.diff(seconds))
    return out
