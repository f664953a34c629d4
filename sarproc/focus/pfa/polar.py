"""Polar format: line-of-sight polar interpolation (LOSPI) and its inverse (Nie 2016, eqs. 4-6, 10).

Planar-wavefront model of eq. (5): for a ground point p (offset x = p - O from the reference O),

    r_0(t) - r_p(t) ~= u(t) . x,   u(t) = (P(t) - O) / |P(t) - O|,

so the compensated signal S(t, f_r) of eq. (4) is exp{j (k_a a + k_r r)} with a, r the
coordinates of x along the image axes e_a, e_r and

    k_a = K u(t) . e_a,   k_r = K u(t) . e_r,   K = 4 pi (f_c + f_r) / c      (eq. 5 with eq. 6).

Any per-pulse antenna positions work (non-straight tracks): only u(t) enters. The polar samples
are put on a rectangular (k_a, k_r) grid in two 1-D passes: along each pulse's line of sight
(range: f_r -> uniform k_r), then along constant k_r (azimuth: pulses -> uniform k_a, the pulse
position of k_a / k_r = u_a / u_r found on the monotonic ratio). The image is

    I(a, r) = sum_k S(k) exp{-j (k_a a + k_r r)},

evaluated on any uniform grid by FFTs with the grid's start folded into phase ramps
(:func:`grid_dft`), so a target at x peaks at x with phase 0 (the "band-pass" image: its carrier
is the rectangle's centre). The rectangle is either inscribed in the polar support (separable
sinc response, the output of plain PFA) or circumscribed (zeros outside the support; lossless,
used by the first step of the two-step PFA so that the inverse recovers every polar sample).
"""

from __future__ import annotations

import dataclasses
import math
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from sarproc.dsp.interp import resample_rows
from sarproc.dsp.phasor import unit_phasor
from sarproc.product import fft as sfft
from sarproc.product.errors import InputError
from sarproc.product.metadata import SINC_IRW_FACTOR, C
from sarproc.product.sorted_values import median

if TYPE_CHECKING:
    from sarproc.focus.pfa.phase_history import PhaseHistory
    from sarproc.product.theory import ResponseTheory

SUPPORTS = ("inscribed", "circumscribed")


@dataclasses.dataclass(frozen=True)
class KGrid:
    """Uniform (k_a, k_r) grid, rad/m: k_a = ka0 + m dka (m < n_ka), k_r = kr0 + j dkr (j < n_kr)."""

    ka0: float
    dka: float
    n_ka: int
    kr0: float
    dkr: float
    n_kr: int

    @property
    def ka(self) -> np.ndarray:
        return self.ka0 + self.dka * np.arange(self.n_ka)

    @property
    def kr(self) -> np.ndarray:
        return self.kr0 + self.dkr * np.arange(self.n_kr)

    @property
    def spans(self) -> tuple[float, float]:
        """Processed support (k_a, k_r) widths, rad/m: sample count times spacing."""
        return self.n_ka * self.dka, self.n_kr * self.dkr

    def irw(self, factor: float = SINC_IRW_FACTOR) -> tuple[float, float]:
        """Theoretical -3 dB widths (azimuth, range), m, of the uniform rectangle."""
        sa, sr = self.spans
        return factor * 2 * math.pi / sa, factor * 2 * math.pi / sr


@dataclasses.dataclass(frozen=True)
class Rect:
    """Bounds of a rectangle in (k_a, k_r), rad/m."""

    ka_lo: float
    ka_hi: float
    kr_lo: float
    kr_hi: float

    def intersect(self, other: Rect) -> Rect:
        return Rect(
            max(self.ka_lo, other.ka_lo),
            min(self.ka_hi, other.ka_hi),
            max(self.kr_lo, other.kr_lo),
            min(self.kr_hi, other.kr_hi),
        )

    @property
    def valid(self) -> bool:
        return self.ka_hi > self.ka_lo and self.kr_hi > self.kr_lo


def los_components(
    positions: np.ndarray, reference: npt.ArrayLike, e_azimuth: np.ndarray, e_range: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """u(t) . e_a and u(t) . e_r (n_pulses,) for the unit vectors from ``reference`` to the antenna."""
    d = np.asarray(positions, float) - np.asarray(reference, float).reshape(1, 3)
    u = d / np.linalg.norm(d, axis=1, keepdims=True)
    return u @ np.asarray(e_azimuth, float), u @ np.asarray(e_range, float)


def rotate_axes(e_azimuth: np.ndarray, e_range: np.ndarray, angle: float) -> tuple[np.ndarray, np.ndarray]:
    """(e_a', e_r'): e_a, e_r turned by ``angle`` from e_r towards e_a (a line of sight at that angle: u . e_a' = 0)."""
    c, s = math.cos(angle), math.sin(angle)
    e_a, e_r = np.asarray(e_azimuth, float), np.asarray(e_range, float)
    return c * e_a - s * e_r, s * e_a + c * e_r


def wavenumbers(carrier_frequency: float, freqs: npt.ArrayLike) -> np.ndarray:
    """K = 4 pi (f_c + f_r) / c, rad/m."""
    return 4 * math.pi * (carrier_frequency + np.asarray(freqs, float)) / C


def polar_support(
    ua: np.ndarray, ur: np.ndarray, carrier_frequency: float, freqs: np.ndarray, kind: str = "inscribed"
) -> Rect:
    """Rectangle inscribed in (or circumscribing) the polar support of the pulses."""
    if kind not in SUPPORTS:
        raise InputError(f"support {kind!r} is not one of {list(SUPPORTS)}")
    k = wavenumbers(carrier_frequency, [freqs[0], freqs[-1]])
    kr_pulse = np.stack([k[0] * ur, k[1] * ur])  # (2, n_pulses)
    lo, hi = kr_pulse.min(axis=0), kr_pulse.max(axis=0)
    if kind == "circumscribed":
        ka = np.outer(k, ua)
        return Rect(float(ka.min()), float(ka.max()), float(lo.min()), float(hi.max()))
    kr_lo, kr_hi = float(lo.max()), float(hi.min())
    ratio = ua / ur
    rmin, rmax = float(ratio.min()), float(ratio.max())
    ends = [np.array([kr * rmin, kr * rmax]) for kr in (kr_lo, kr_hi)]
    ka_lo = max(float(e.min()) for e in ends)
    ka_hi = min(float(e.max()) for e in ends)
    return Rect(ka_lo, ka_hi, kr_lo, kr_hi)


def rectangle_range_theory(
    kg: KGrid,
    ua: np.ndarray,
    ur: np.ndarray,
    carrier_frequency: float,
    bandwidth: float,
    window: str,
) -> ResponseTheory:
    """The range theory of a polar-format image whose pulses carry a ``window`` taper over their chirp band
    (range compression) and whose support is the rectangle ``kg`` inscribed in their polar support: each point
    (k_a, k_r) of the rectangle is the pulse whose line of sight has u_a / u_r = k_a / k_r, at the wavenumber
    k_r / u_r, so its weight is the taper at that frequency, and the range response is the transform of the
    weights averaged over k_a. The rectangle keeps only the middle of each pulse's band (the edge pulses' bands
    shift by 1 - cos of their angle, and into the ground plane by the depression): a Hamming taper is cut off
    above its pedestal, so its side lobes rise over the window's own (L-band, 10.7 % fractional bandwidth, 3 s
    aperture at 3 km: the rectangle holds 97.6 % of the band, PSLR -40.5 dB instead of -42.7)."""
    from sarproc.product.theory import response_theory, window_taper

    order = np.argsort(ua / ur)
    ratio, u_r = (ua / ur)[order], np.abs(ur[order])
    ka, kr = kg.ka, kg.kr
    pulse_ur = np.interp(ka[:, None] / kr[None, :], ratio, u_r)  # (n_ka, n_kr) the pulse through each point
    freq = (np.abs(kr)[None, :] / pulse_ur) * C / (4 * math.pi) - carrier_frequency
    x = freq / bandwidth
    taper = np.where(np.abs(x) <= 0.5, window_taper(window, np.clip(x, -0.5, 0.5)), 0.0)
    weights = taper.mean(axis=0)
    k = kr / (2 * math.pi)  # cycles per metre
    half = 0.5 * kg.dkr / (2 * math.pi)
    return response_theory(k, weights, band=(float(k.min()) - half, float(k.max()) + half))


def inscribed_support(ua: np.ndarray, ur: np.ndarray, carrier_frequency: float, freqs: np.ndarray) -> Rect:
    """:func:`polar_support`'s inscribed rectangle; raises InputError saying why where there is none."""
    rect = polar_support(ua, ur, carrier_frequency, freqs, "inscribed")
    if not rect.valid:
        raise InputError(no_common_support_reason(ur, carrier_frequency, freqs))
    return rect


def no_common_support_reason(ur: np.ndarray, carrier_frequency: float, freqs: npt.ArrayLike) -> str:
    """Why the pulses' polar supports share no rectangle, in a user's terms: each pulse's band lands on the image's
    range axis scaled by its line of sight's component u . e_r; where that component varies over the aperture by
    more than the fractional bandwidth (a squinted aperture whose depression angle changes along it, imaged in a
    ground-plane frame), the first and last pulses' bands do not overlap."""
    k = wavenumbers(carrier_frequency, [np.min(freqs), np.max(freqs)])
    band = float(k[1] / k[0] - 1.0)
    mag = np.abs(np.asarray(ur, float))
    spread = float(mag.max() / mag.min() - 1.0) if mag.size and mag.min() > 0 else math.inf
    if spread > band:
        why = (
            f"the pulses' lines of sight project onto the image's range axis with u.e_r from {mag.min():.4g} to "
            f"{mag.max():.4g} over the aperture, a {100 * spread:.3g} % spread, wider than the {100 * band:.3g} % "
            "fractional bandwidth, so the first and last pulses' range bands do not overlap (a squinted aperture "
            "whose depression angle changes along it, imaged in the ground plane)"
        )
    else:
        why = "the pulses' azimuth extents do not overlap"
    return (
        f"polar format: the pulses' polar supports share no rectangle: {why}; a wider radar.bandwidth, a shorter "
        "acquisition.aperture_time or less geometry.squint makes one, or sarproc backproject focuses the scene"
    )


def _fft_length(spacing_guess: float, pixel: float, n_pixels: int) -> tuple[int, float]:
    """FFT length M >= n_pixels with M dk pixel = 2 pi, and the resulting dk <= spacing_guess.

    A ratio 2 pi / (spacing_guess pixel) that is a whole number up to rounding (the sub-images ask for
    os x n pixels exactly) is taken as that number: ceil of 405.00000000001 would make M jump from 405 to
    next_fast_len(406) = 420 on a 1e-10 m change of the antenna positions (the ECF round trip of a CPHD
    file), a different k grid and a -70 dB different two-step image (tests/formats/test_cphd_import.py).
    """
    ratio = 2 * math.pi / (spacing_guess * pixel)
    whole = round(ratio)
    need = int(whole) if abs(ratio - whole) <= 1e-9 * ratio else int(math.ceil(ratio))
    m = sfft.next_fast_len(max(int(n_pixels), need))
    return m, 2 * math.pi / (m * pixel)


def make_kgrid(
    rect: Rect, dka_max: float, dkr_max: float, da: float, dr: float, n_a: int, n_r: int
) -> tuple[KGrid, tuple[int, int]]:
    """The (k_a, k_r) grid over ``rect`` whose FFT lands exactly on pixels (da, dr); plus the FFT lengths."""
    if not rect.valid:
        raise InputError("polar format: the pulses' polar supports do not overlap (no common rectangle)")
    m_a, dka = _fft_length(dka_max, da, n_a)
    m_r, dkr = _fft_length(dkr_max, dr, n_r)
    n_ka = int(math.floor((rect.ka_hi - rect.ka_lo) / dka)) + 1
    n_kr = int(math.floor((rect.kr_hi - rect.kr_lo) / dkr)) + 1
    if n_ka > m_a or n_kr > m_r:
        raise InputError(
            f"polar format: pixel spacing ({da:.4g} m, {dr:.4g} m) is coarser than the support "
            f"allows ({2 * math.pi / (rect.ka_hi - rect.ka_lo):.4g} m, "
            f"{2 * math.pi / (rect.kr_hi - rect.kr_lo):.4g} m)"
        )
    ka0 = (rect.ka_lo + rect.ka_hi) / 2 - (n_ka - 1) / 2 * dka
    kr0 = (rect.kr_lo + rect.kr_hi) / 2 - (n_kr - 1) / 2 * dkr
    return KGrid(ka0, dka, n_ka, kr0, dkr, n_kr), (m_a, m_r)


def grid_dft(
    x: np.ndarray, u0: float, du: float, v0: float, dv: float, n_out: int, sign: int, workers: int = -1
) -> np.ndarray:
    """y_m = sum_p x_p exp(sign j (u0 + p du)(v0 + m dv)), m < n_out, along the last axis, by FFT.

    (u: the input's coordinate, v: the output's; one is a wavenumber, the other a position.)
    Needs 2 pi / (du dv) = M, an integer >= the input and output lengths. float64 phases;
    returns complex64 for complex64 input.
    """
    if x.ndim == 2 and x.shape[0] * int(round(2 * math.pi / (du * dv))) > (1 << 24):
        # bound the FFT's working set: ~16 M samples per block of rows
        rows = max(1, (1 << 24) // int(round(2 * math.pi / (du * dv))))
        out = np.empty((x.shape[0], n_out), np.complex64 if x.dtype == np.complex64 else np.complex128)
        for s in range(0, x.shape[0], rows):
            out[s : s + rows] = grid_dft(x[s : s + rows], u0, du, v0, dv, n_out, sign, workers)
        return out
    n_in = x.shape[-1]
    m = int(round(2 * math.pi / (du * dv)))
    if abs(m * du * dv - 2 * math.pi) > 1e-6 or m < max(n_in, n_out):
        raise ValueError(
            f"grid_dft: 2 pi / (du dv) = {2 * math.pi / (du * dv):.6g} must be an integer >= {max(n_in, n_out)}"
        )
    dtype = np.complex64 if x.dtype == np.complex64 else np.complex128
    pre = np.exp(sign * 1j * ((du * v0 * np.arange(n_in)) % (2 * math.pi))).astype(dtype)
    z = x * pre
    if sign < 0:
        y = sfft.fft(z, n=m, axis=-1, workers=workers)[..., :n_out]
    else:
        y = sfft.ifft(z, n=m, axis=-1, workers=workers)[..., :n_out]
        y *= m
    post = np.exp(sign * 1j * ((u0 * (v0 + dv * np.arange(n_out))) % (2 * math.pi))).astype(dtype)
    y *= post
    return y.astype(dtype, copy=False)


def _pulse_positions(ratio: np.ndarray, wanted: np.ndarray) -> np.ndarray:
    """Fractional pulse index where u_a / u_r equals ``wanted`` (NaN outside the aperture)."""
    idx = np.arange(len(ratio), dtype=float)
    step = np.diff(ratio)
    if np.all(step > 0):
        return np.interp(wanted, ratio, idx, left=np.nan, right=np.nan)
    if np.all(step < 0):
        return np.interp(wanted, ratio[::-1], idx[::-1], left=np.nan, right=np.nan)
    raise InputError(
        "polar format: the line-of-sight angle is not monotonic over the pulses "
        "(the track turns back); split the aperture"
    )


@dataclasses.dataclass(frozen=True)
class Interpolation:
    """Kernels of the two polar passes (sarproc.dsp.interp names) and the signals' oversampling."""

    range_kernel: str = "knab"
    range_length: int | None = 8
    azimuth_kernel: str = "knab"
    azimuth_length: int | None = 8
    azimuth_oversampling: float = 1.25


def data_sampling(ua: np.ndarray, ur: np.ndarray, k_max: float, freq_step: float) -> tuple[float, float]:
    """Largest k spacings that keep the data's own sampling density (rad/m)."""
    dkr = 4 * math.pi * freq_step / C * float(np.min(np.abs(ur)))
    ratio = ua / ur
    dka = k_max * float(np.max(np.abs(ur))) * median(np.abs(np.diff(ratio))) if len(ratio) > 1 else dkr
    return dka, dkr


def polar_to_rect(
    ph: PhaseHistory, ua: np.ndarray, ur: np.ndarray, kg: KGrid, interp: Interpolation, block: int = 256
) -> np.ndarray:
    """LOSPI: resample S(t, f_r) onto the (k_r, k_a) grid; returns (n_kr, n_ka) complex64."""
    n_az = ph.data.shape[0]
    fc, f0, dfr = ph.carrier_frequency, float(ph.freqs[0]), ph.freq_step
    kr = kg.kr
    rng_t = np.empty((kg.n_kr, n_az), np.complex64)  # range pass written transposed: one copy less
    for s in range(0, n_az, block):
        e = min(s + block, n_az)
        tc = ph.delay_center[s:e, None]
        centred = not np.any(tc)  # the two-step's sub-images: support already at zero delay, no phasors
        over = max(1.05, float(np.min(1.0 / (dfr * ph.delay_span[s:e]))))
        # centre the time support before interpolating the spectrum, restore it afterwards
        rows = ph.data[s:e] if centred else ph.data[s:e] * _phasor(ph.freqs[None, :] * tc)
        f_new = kr[None, :] * (C / (4 * math.pi)) / ur[s:e, None] - fc  # range pass along the LOS
        out = resample_rows(rows, (f_new - f0) / dfr, interp.range_kernel, interp.range_length, oversampling=over)
        if not centred:
            out *= _phasor(-f_new * tc)
        rng_t[:, s:e] = out.T
    out = np.empty((kg.n_kr, kg.n_ka), np.complex64)
    rows = max(1, (1 << 22) // max(kg.n_ka, 1))  # ~4 M outputs per block
    ratio = ua / ur
    for s in range(0, kg.n_kr, rows):
        e = min(s + rows, kg.n_kr)
        pos = _pulse_positions(ratio, kg.ka[None, :] / kr[s:e, None])  # azimuth pass at constant k_r
        out[s:e] = resample_rows(
            rng_t[s:e], pos, interp.azimuth_kernel, interp.azimuth_length, oversampling=interp.azimuth_oversampling
        )
    return out


def rect_to_polar(
    spec: np.ndarray,
    kg: KGrid,
    ua: np.ndarray,
    ur: np.ndarray,
    carrier_frequency: float,
    freqs: np.ndarray,
    interp: Interpolation,
    oversampling: float = 1.25,
) -> np.ndarray:
    """Inverse LOSPI: values of a (n_kr, n_ka) rectangle at the polar samples (n_pulses, n_freq).

    Polar samples outside the rectangle are zero.
    """
    kr = kg.kr
    pos = ((kr[:, None] * (ua / ur)[None, :]) - kg.ka0) / kg.dka  # (n_kr, n_pulses)
    az = resample_rows(spec, pos, interp.azimuth_kernel, interp.azimuth_length, oversampling=oversampling)
    k = wavenumbers(carrier_frequency, freqs)
    pos_r = (k[None, :] * ur[:, None] - kg.kr0) / kg.dkr  # (n_pulses, n_freq)
    return resample_rows(
        np.ascontiguousarray(az.T), pos_r, interp.range_kernel, interp.range_length, oversampling=oversampling
    )


def _phasor(cycles: np.ndarray) -> np.ndarray:
    """exp(j 2 pi cycles) complex64: reduced in float64, then float32 cos/sin (numpy's complex128 exp was
    a seventh of a sub-image's time)."""
    c = np.asarray(cycles, float)
    return unit_phasor(c - np.floor(c))


@dataclasses.dataclass(frozen=True)
class Grid:
    """Uniform image grid relative to a reference point along (e_a, e_r): a = a0 + i da, r = r0 + j dr."""

    a0: float
    da: float
    n_a: int
    r0: float
    dr: float
    n_r: int

    @property
    def a(self) -> np.ndarray:
        return self.a0 + self.da * np.arange(self.n_a)

    @property
    def r(self) -> np.ndarray:
        return self.r0 + self.dr * np.arange(self.n_r)

    def sub(self, rows: slice, cols: slice) -> Grid:
        """The grid of pixels [rows, cols] (slices with explicit start and stop)."""
        return Grid(
            self.a0 + rows.start * self.da,
            self.da,
            rows.stop - rows.start,
            self.r0 + cols.start * self.dr,
            self.dr,
            cols.stop - cols.start,
        )


def rect_to_image(spec: np.ndarray, kg: KGrid, grid: Grid, workers: int = -1) -> np.ndarray:
    """I(a, r) = sum_k spec(k) exp{-j (k_a a + k_r r)} / n_k on ``grid``: (n_a, n_r) complex64."""
    y = grid_dft(np.ascontiguousarray(spec.T), kg.kr0, kg.dkr, grid.r0, grid.dr, grid.n_r, -1, workers)
    img = grid_dft(np.ascontiguousarray(y.T), kg.ka0, kg.dka, grid.a0, grid.da, grid.n_a, -1, workers)
    img /= np.float32(kg.n_ka * kg.n_kr)
    return np.ascontiguousarray(img.T)


def image_to_rect(img: np.ndarray, grid: Grid, kg: KGrid, forward: KGrid, workers: int = -1) -> np.ndarray:
    """Spectrum (n_kr, n_ka) complex64 on ``kg`` of an image made by :func:`rect_to_image` on ``forward``.

    S(k) = n_k (dka da / 2 pi)(dkr dr / 2 pi) sum_x I(x) exp{+j k . x} with the forward grid's
    n_k and spacings: exact for every k of the forward grid when the image holds all the energy.
    """
    y = grid_dft(np.ascontiguousarray(img.T), grid.a0, grid.da, kg.ka0, kg.dka, kg.n_ka, +1, workers)
    spec = grid_dft(np.ascontiguousarray(y.T), grid.r0, grid.dr, kg.kr0, kg.dkr, kg.n_kr, +1, workers)
    spec = np.ascontiguousarray(spec.T)
    spec *= np.float32(forward.n_ka * forward.n_kr * forward.dka * grid.da * forward.dkr * grid.dr / (4 * math.pi**2))
    return spec


def pfa(
    ph: PhaseHistory,
    e_azimuth: np.ndarray,
    e_range: np.ndarray,
    grid: Grid,
    *,
    support: str = "inscribed",
    rect: Rect | None = None,
    kgrid: KGrid | None = None,
    interp: Interpolation = Interpolation(),
    workers: int = -1,
) -> tuple[np.ndarray, KGrid]:
    """Polar format image of ``ph`` on ``grid`` (offsets from ``ph.reference`` along e_a, e_r).

    Returns (image (n_a, n_r) complex64, KGrid). ``rect`` overrides the support rectangle and
    ``kgrid`` the whole k grid (the two-step PFA gives every sub-image the same one, so that
    responses match across seams).
    """
    ua, ur = los_components(ph.positions, ph.reference, e_azimuth, e_range)
    if kgrid is None:
        if rect is None:
            rect = polar_support(ua, ur, ph.carrier_frequency, ph.freqs, support)
        k_max = float(wavenumbers(ph.carrier_frequency, ph.freqs[-1]))
        dka_max, dkr_max = data_sampling(ua, ur, k_max, ph.freq_step)
        kgrid, _ = make_kgrid(rect, dka_max, dkr_max, grid.da, grid.dr, grid.n_a, grid.n_r)
    spec = polar_to_rect(ph, ua, ur, kgrid, interp)
    return rect_to_image(spec, kgrid, grid, workers), kgrid
