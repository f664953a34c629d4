"""Moving-target detection and separation for ``reconstruct`` (paper 003 cites its ref. [11]; this is ours).

Movers separate where they are focused, not per range cell: two vehicles on one road share range
cells but appear at different azimuths. After the squint deramp (which is also the linear range-walk
correction) every target sits in a few range cells and its azimuth signal is a chirp of the static
FM rate

    K_a(f_r) = 2 v^2 cos^2(theta) (f_c + f_r) / (c R)                                          (7)

centred on its apparent time t_app (its static-equivalent position; a mover's Doppler offset f_v
shifts it by f_v / K_a). The detection image is the reconstructed signal (conventional filter bank;
with ``clutter_suppression`` the clutter-null residual through the same bank) compressed in azimuth
by exp(-j pi f_a^2 / K_a(f_r)) in (f_a, f_r): one peak per target at (walk-corrected range cell, t_app).

CFAR: the background is the median power of tiles of ``TILE`` (azimuth x range) samples, divided by
ln 2 (the mean of an exponential, i.e. complex-Gaussian, background from its median: a few bright
cells do not raise it); a peak is a detection when it exceeds that mean by ``cfar_db`` and the
strongest peak by ``level_db``. After the clutter null that background is far from exponential (clutter
residue: on xu_traffic 1 % of the cells stand 16 dB over it, 0.1 % 23 dB), so a fixed ``cfar_db`` sets no
false-alarm rate. :func:`peak_cfar` measures it: the normalised powers of the image's local maxima (one per
resolution cell) are fitted above their 99th percentile by a generalised Pareto tail (:func:`fit_tail`, the
peaks-over-threshold model of extreme values; exponential when xi = 0), and the threshold is where that tail
falls to the stated false-alarm rate per peak. ``reconstruct`` applies it to the image with the examined
responses taken out (reconstruct._second_pass). Side lobes: a candidate on the range or azimuth cut of a stronger
detection is kept only if it rises 6 dB over that detection's sinc envelope 1 / (pi x)^2
(x: distance in the detection's own measured -3 dB widths; a defocused mover's width is larger). With the clutter
null, a residual candidate under that envelope of a conventional-image peak that is mirrored about it, or deep under
it where the null passes the peak's spectral tails, is that static peak's side lobe (:func:`static_side_lobe`).

Separation (``extract``): the channels of one detection, in the range cells of its window, are
dechirped about t_app with (7); the detection becomes a tone at 0 Hz (modulo the channel PRF) whose
width is 1 / T plus its FM mismatch (along-track velocity) and the f_r spread of (7), while a target
at apparent time t' sits at K_a (t' - t_app). A raised-cosine mask of half width ``half_width`` Hz
keeps the detection, the chirp is restored: the channel data of that detection alone, except for
targets within half_width / K_a of t_app (or of t_app + k PRF / K_a, the channel ambiguities the
filter bank resolves) in the same range cells. Everything is linear, so the reconstruct stage can
replace the detection's conventional reconstruction by its modified one and leave the rest of the
scene (static targets, other movers) as it was.
"""

from __future__ import annotations

import dataclasses
import math
from typing import TYPE_CHECKING, Literal

import numpy as np
import numpy.typing as npt

from sarproc.dsp.numpy_phasor import unit_phasor
from sarproc.focus.multichannel import channels
from sarproc.product import fft as sfft
from sarproc.product.metadata import C
from sarproc.product.sorted_values import median

if TYPE_CHECKING:
    from collections.abc import Sequence

TILE = (256, 32)  # CFAR background tiles: azimuth samples x range cells
SIDELOBE_MARGIN = 4.0  # 6 dB over a stronger detection's sinc envelope
# A static response's side lobes that the clutter null passes (find_detections' ``static`` test, StaticSources).
# Mirror test: the energy over +-MIRROR_HALF samples at a candidate against the most over the same span near its
# mirror about the static peak (within MIRROR_STRETCH of the offset: one side's tails sit up to 1.7 % further out
# than the other's); a side lobe stands less than MIRROR_MARGIN over it (one bright point's pairs, measured: -1.5 to
# +3.3 dB apart). The envelope (below) keeps xu_traffic's V9: a fixed 50 dB under the peak instead dropped it and
# 17 other residual peaks, which stood 10.4-23.6 dB over that envelope.
MIRROR_HALF = 12
MIRROR_STRETCH = 0.02
MIRROR_MARGIN = 2.5
# Beyond where the null passes a point's side lobes, one DEEP under its envelope needs no mirror (the side lobes of
# several points add there; measured 17.6-18.9 dB under it, unpaired, on three points).
DEEP = 0.1


@dataclasses.dataclass(frozen=True)
class Detection:
    cell: int  # walk-corrected range cell (index in the zero-padded range axis)
    index: int  # azimuth sample of the peak in the detection image (output grid)
    time: float  # apparent time t_app, s
    power: float  # peak power in the detection image
    background: float  # mean background power there (CFAR)
    width: float  # -3 dB azimuth width of the peak, samples

    @property
    def snr_db(self) -> float:
        return 10 * math.log10(self.power / self.background) if self.background > 0 else float("inf")


def sinc_sidelobes(offset: float) -> float:
    """Power of an unweighted sinc response's side-lobe envelope ``offset`` resolution widths from its peak, relative
    to the peak: 1 / (pi x)^2 (the envelope the detections' side-lobe tests are set against)."""
    return 1.0 / (math.pi * offset) ** 2


def maximum_filter(x: np.ndarray, size: tuple[int, ...], mode: Literal["edge", "wrap"]) -> np.ndarray:
    """Maximum over a centred box of odd ``size`` around every sample; outside the array ``mode`` as in
    numpy.pad ("edge": the nearest sample, "wrap": periodic). scipy.ndimage.maximum_filter's values
    (modes "nearest" and "wrap"; a maximum is exact, so equal bit for bit) without importing scipy.ndimage
    (~0.1 s of the command's start)."""
    out = np.asarray(x)
    for axis, n in enumerate(size):
        if n % 2 != 1:
            raise ValueError(f"maximum_filter: size {size} must be odd")
        h = n // 2
        if h == 0:
            continue
        pad = [(0, 0)] * out.ndim
        pad[axis] = (h, h)
        padded = np.pad(out, pad, mode=mode)
        length = out.shape[axis]
        acc = np.take(padded, np.arange(0, length), axis=axis)
        for k in range(1, n):
            acc = np.maximum(acc, np.take(padded, np.arange(k, k + length), axis=axis))
        out = acc
    return out


def fm_rate(
    velocity: float, squint: float, slant_range: float, carrier_frequency: float, f_r: npt.ArrayLike
) -> np.ndarray:
    """Eq. (7): static azimuth FM rate K_a(f_r), Hz/s (positive; the deramped phase is -pi K_a t^2)."""
    return 2 * (velocity * math.cos(squint)) ** 2 * (carrier_frequency + np.asarray(f_r, float)) / (C * slant_range)


def compressed(y_fa: np.ndarray, out_f: np.ndarray, ka: np.ndarray) -> np.ndarray:
    """(N n_az, n_fft) reconstructed spectrum in (f_a, f_r) -> complex detection image (t', range cell)."""
    return sfft.ifft2(y_fa * compression(out_f, ka), workers=-1)


def compression(out_f: np.ndarray, ka: np.ndarray) -> np.ndarray:
    """The azimuth compression exp(-j pi f_a^2 / K_a(f_r)) of :func:`compressed`, (n f_a, n f_r)."""
    return unit_phasor(np.mod(-0.5 * out_f[:, None] ** 2 / np.asarray(ka, float).reshape(1, -1), 1.0))


def decompressed(image: np.ndarray, out_f: np.ndarray, ka: np.ndarray) -> np.ndarray:
    """Inverse of :func:`compressed`: complex detection image (t', range cell) -> spectrum (f_a, f_r)."""
    return sfft.fft2(image, workers=-1) * decompression(out_f, ka)


def decompression(out_f: np.ndarray, ka: np.ndarray) -> np.ndarray:
    """The phasor exp(+j pi f_a^2 / K_a(f_r)) of :func:`decompressed`, (n f_a, n f_r)."""
    return unit_phasor(np.mod(0.5 * out_f[:, None] ** 2 / ka[None, :], 1.0))


def detection_image(y_fa: np.ndarray, out_f: np.ndarray, ka: np.ndarray) -> np.ndarray:
    """Power of :func:`compressed`, float32."""
    return intensity(compressed(y_fa, out_f, ka))


def intensity(img: np.ndarray) -> np.ndarray:
    """|img|^2 as float32 (a detection image's power)."""
    return (img.real**2 + img.imag**2).astype(np.float32)


def background(power: np.ndarray, tile: tuple[int, int] = TILE) -> np.ndarray:
    """Mean background per tile from its median (median / ln 2, exponential statistics), same shape as power."""
    n_t, n_r = power.shape
    ta, tr = min(tile[0], n_t), min(tile[1], n_r)
    ia = np.minimum(np.arange(n_t) // ta, max(n_t // ta - 1, 0))
    ir = np.minimum(np.arange(n_r) // tr, max(n_r // tr - 1, 0))
    na, nr = ia[-1] + 1, ir[-1] + 1
    med = np.empty((na, nr))
    for a in range(na):
        rows = power[ia == a]
        for r in range(nr):
            med[a, r] = median(rows[:, ir == r])
    # Neighbouring tiles' median too (a 3 x 3 max), so a tile edge inside clutter is not a false alarm.
    med = maximum_filter(med, (3, 3), "edge")
    return (med[ia][:, ir] / math.log(2)).astype(np.float32)


TAIL_FRACTION = 1e-2  # the measured background's top fraction whose exceedances the tail model is fitted to


@dataclasses.dataclass(frozen=True)
class TailFit:
    """The measured background's tail: normalised power z = power / background (its local mean from tile medians)
    over ``u``, exceeded by a fraction ``p_u`` of the cells, as a generalised Pareto distribution
    P(z > t) = p_u (1 + xi (t - u) / sigma)^(-1 / xi) (``xi`` 0: exponential; a complex-Gaussian background has
    xi = 0, sigma = 1; clutter residue, a few bright cells in each tile, xi > 0: a heavier tail)."""

    u: float
    p_u: float
    xi: float
    sigma: float
    n: int  # cells measured

    def threshold(self, pfa: float) -> float:
        """z exceeded by a fraction ``pfa`` of the background cells (pfa <= p_u)."""
        r = self.p_u / pfa
        if abs(self.xi) < 1e-6:
            return self.u + self.sigma * math.log(r)
        return self.u + self.sigma / self.xi * (r**self.xi - 1)


def fit_tail(z: np.ndarray, tail_fraction: float = TAIL_FRACTION) -> TailFit:
    """:class:`TailFit` of the normalised powers ``z`` (any shape): peaks over the (1 - tail_fraction) quantile,
    generalised Pareto by probability-weighted moments (Hosking and Wallis 1987: unbiased for xi < 1, no
    iteration). A few targets among millions of cells barely move it: the fit is a property of the background."""
    flat = np.asarray(z, np.float64).ravel()
    flat = flat[np.isfinite(flat)]
    n = flat.size
    k = max(int(round(tail_fraction * n)), 10)
    if n < 2 * k:
        raise ValueError(f"fit_tail: {n} cells are too few for a tail of {k}")
    part = np.partition(flat, n - k - 1)
    u = float(part[n - k - 1])
    y = np.sort(part[n - k :]) - u  # the k exceedances, ascending
    a0 = float(np.mean(y))
    a1 = float(np.mean(y * (k - 1 - np.arange(k)) / (k - 1)))  # sum (k - i) / (k - 1) y_(i) / k, i = 1 ... k
    if a0 <= 0 or a0 - 2 * a1 <= 0:
        return TailFit(u, k / n, 0.0, max(a0, 1e-30), n)
    xi = -(a0 / (a0 - 2 * a1) - 2)
    sigma = 2 * a0 * a1 / (a0 - 2 * a1)
    return TailFit(u, k / n, float(xi), float(sigma), n)


@dataclasses.dataclass(frozen=True)
class StaticSources:
    """The conventional image's bright responses whose side lobes the clutter null passes (:func:`static_side_lobe`).

    The null cancels a static point's Doppler band (times clutter_band) but not its spectrum beyond it: the
    illumination a rect beam cuts sharply spreads the point's chirp past the band edge by Delta f with an amplitude
    ~ 1 / Delta f, and compression puts that tail Delta f / K_a from the point. So from ``far`` = (clutter_band - 1)
    half_band / K_a on (paper 003's radar: 75 ms) the residual holds the point's side lobes almost whole (-1 to -2.5
    dB under the conventional image's), nearer ones cancelled by 13-40 dB (docs/multichannel.md section 8).
    """

    peaks: Sequence[Detection]  # strongest first, in the residual image's scale
    cells: int  # range cells a peak's response reaches either side (side lobes, the chirp's aliased tails)
    far: float  # azimuth samples from a peak beyond which the null passes its side lobes


def static_side_lobe(power: np.ndarray, index: int, cell: int, p: float, static: StaticSources) -> bool:
    """Whether the clutter-null residual's candidate at (``index``, ``cell``) of power ``p`` is a side lobe of one of
    the ``static`` sources that the null did not cancel.

    For a source beyond the candidate's own span in azimuth and within ``static.cells`` in range, under its azimuth
    side-lobe envelope (find_detections' 1 / (pi x)^2 with SIDELOBE_MARGIN): when it is also DEEP under that
    envelope beyond ``static.far``, or else it stands less than MIRROR_MARGIN over its mirror about the source
    (energies over +-MIRROR_HALF samples in its range cell). A point's response comes in pairs mirrored about it; a
    mover's does not.
    """
    n = power.shape[0]
    span = 2 * MIRROR_HALF + 1
    here = None
    for s in static.peaks:
        dt = (index - s.index + n // 2) % n - n // 2
        if abs(dt) < 2 * s.width + span or abs(cell - s.cell) > static.cells:
            continue
        envelope = s.power * SIDELOBE_MARGIN * sinc_sidelobes(dt / s.width)
        if p > envelope:
            continue
        if abs(dt) >= static.far and p <= DEEP * envelope:
            return True
        if here is None:
            here = float(np.sum(power[(index + np.arange(-MIRROR_HALF, MIRROR_HALF + 1)) % n, cell]))
        reach = MIRROR_HALF + int(MIRROR_STRETCH * abs(dt))
        near = power[(s.index - dt + np.arange(-reach, reach + 1)) % n, cell].astype(np.float64)
        if here < MIRROR_MARGIN * float(np.max(np.convolve(near, np.ones(span), "valid"))):
            return True
    return False


def local_peaks(power: np.ndarray) -> np.ndarray:
    """Mask of the local maxima of a (t', range) power image over a 5 x 3 box (find_detections' candidates)."""
    return (maximum_filter(power, (5, 3), "wrap") == power) & (power > 0)


def peak_cfar(
    power: np.ndarray, bg: np.ndarray, pfa: float, floor_db: float, exclude: np.ndarray | None = None
) -> tuple[float, TailFit | None, np.ndarray]:
    """CFAR threshold (dB over the local background ``bg``) that the measured background's peaks exceed with
    probability ``pfa``, and at least ``floor_db``.

    The events are the local maxima of ``power`` (one per resolution cell: a threshold crossing is a peak); their
    normalised powers z = power / bg are fitted by :func:`fit_tail`. ``exclude``: cells (True) whose peaks are no
    part of the background (the known responses' own structure). Returns the threshold, the fit (None: too few
    peaks, the floor alone) and the sorted z of the peaks (to say how many of them exceed a given level).
    """
    peaks = local_peaks(power) & (bg > 0)
    if exclude is not None:
        peaks &= ~exclude
    z = np.sort((power[peaks] / bg[peaks]).astype(np.float64))
    try:
        fit = fit_tail(z)
    except ValueError:
        return floor_db, None, z
    t = fit.threshold(min(pfa, fit.p_u))
    return max(floor_db, 10 * math.log10(t) if t > 0 else -math.inf), fit, z


def _width(profile: np.ndarray, k: int) -> float:
    """-3 dB width (samples) of the peak at k of a power profile (circular)."""
    half = profile[k] / 2
    n = len(profile)
    lo = hi = 0
    while lo < n // 2 and profile[(k - lo - 1) % n] > half:
        lo += 1
    while hi < n // 2 and profile[(k + hi + 1) % n] > half:
        hi += 1
    return float(max(1, lo + hi + 1))


def side_lobe_of(d: Detection, p: float, index: int, cell: int, n_az: int, range_width: float) -> bool:
    """Whether power ``p`` at (``index``, ``cell``) of the detection image lies on ``d``'s azimuth cut (its range cells)
    or range cut (its azimuth samples) under its sinc envelope 1 / (pi x)^2 with SIDELOBE_MARGIN (x: the distance in
    ``d``'s measured -3 dB widths, or in range resolutions ``range_width``): find_detections' side-lobe test."""
    dt = abs(index - d.index)
    dt = min(dt, n_az - dt)
    dr = abs(cell - d.cell)
    return (
        dr <= 2
        and p < d.power * SIDELOBE_MARGIN * sinc_sidelobes(max(dt / d.width, 0.5))
        or dt <= max(2, d.width)
        and p < d.power * SIDELOBE_MARGIN * sinc_sidelobes(max(dr / range_width, 0.5))
    )


def find_detections(
    power: np.ndarray,
    bg: np.ndarray,
    times: np.ndarray,
    cfar_db: float,
    level_db: float,
    range_width: float,
    max_detections: int,
    known: Sequence[Detection] = (),
    static: StaticSources | None = None,
) -> tuple[list[Detection], int, int]:
    """CFAR peaks of a (t', range) power image, side lobes of stronger peaks removed (module docstring).

    ``known``: detections made before (whose responses the image may no longer hold): a candidate on their side-lobe
    envelope is dropped as well. ``static``: with a clutter-null residual image, the conventional image's bright
    responses: a candidate that is one of their side lobes the null passed (:func:`static_side_lobe`) is dropped and
    counted.
    Returns the new detections, strongest first, the number of candidates beyond ``max_detections`` and the number
    of static side lobes dropped.
    """
    peak = float(power.max()) if power.size else 0.0
    if peak <= 0:
        return [], 0, 0
    above = (power > bg * 10 ** (cfar_db / 10)) & (power > peak * 10 ** (level_db / 10))
    local = maximum_filter(power, (5, 3), "wrap") == power
    idx = np.argwhere(above & local)
    order = np.argsort(-power[idx[:, 0], idx[:, 1]])
    found: list[Detection] = []
    dropped = side_lobes = 0
    for t_i, r_i in idx[order]:
        p = float(power[t_i, r_i])
        if any(side_lobe_of(d, p, int(t_i), int(r_i), power.shape[0], range_width) for d in (*known, *found)):
            continue
        if static is not None and static_side_lobe(power, int(t_i), int(r_i), p, static):
            side_lobes += 1
            continue
        if len(found) >= max_detections:
            dropped += 1
            continue
        found.append(
            Detection(
                cell=int(r_i),
                index=int(t_i),
                time=float(times[t_i]),
                power=p,
                background=float(bg[t_i, r_i]),
                width=_width(power[:, r_i], int(t_i)),
            )
        )
    return found, dropped, side_lobes


def extraction_mask(frequencies: np.ndarray, prf: float, half_width: float) -> np.ndarray:
    """Raised-cosine pass band |f mod PRF| <= half_width, tapering to 0 at 1.5 half_width (channel spectrum bins)."""
    f = np.abs((frequencies + prf / 2) % prf - prf / 2)
    m = np.ones_like(f)
    edge = (f > half_width) & (f < 1.5 * half_width)
    m[edge] = 0.5 * (1 + np.cos(np.pi * (f[edge] - half_width) / (0.5 * half_width)))
    m[f >= 1.5 * half_width] = 0.0
    return m


def extract(
    x_tf: np.ndarray,
    times: np.ndarray,
    prf: float,
    t_app: float,
    ka: np.ndarray,
    half_width: float,
    notches: Sequence[float] | None = None,
) -> np.ndarray:
    """Channels (N, n_az, L) in (t, f_r) of one window -> the part focused within half_width / K_a of t_app.

    With ``notches`` (dechirped frequencies K_a (t_j - t_app) of the other targets in the window, Hz) the
    complement is kept instead: everything but those targets. A sharp-edged illumination (rect beam) leaves
    about 2 / (pi^2 half_width T) of a target's energy outside its pass band; what a target leaves
    outside keeps the conventional reconstruction and its ghosts, so the reconstruction uses the
    complement (nothing lost where no other target is) and the velocity search the pass band (least clutter).
    """
    chirp = unit_phasor(np.mod(0.5 * (times - t_app)[:, None] ** 2 * ka[None, :], 1.0))
    f = sfft.fftfreq(len(times), 1.0 / prf)
    if notches is None:
        mask = extraction_mask(f, prf, half_width)
    else:
        mask = np.ones_like(f)
        for c in notches:
            mask *= 1.0 - extraction_mask(f - c, prf, half_width)
        if np.all(mask == 1.0):
            return x_tf.copy()
    z = sfft.fft(x_tf * chirp[None], axis=1, workers=-1)
    z *= mask.astype(np.float32)[None, :, None]
    return sfft.ifft(z, axis=1, workers=-1) * np.conj(chirp)[None]


def clutter_null_peak_gains(
    tau: np.ndarray,
    prf: float,
    half_band: float,
    band_factor: float,
    wavelength: float,
    v_los: float,
    n_az: int = 512,
) -> np.ndarray:
    """Peak power a mover keeps through the clutter null at each of its responses k PRF / K_a apart.

    Returns (2 N - 1,) fractions of its conventional peak for k = -(N - 1) ... N - 1 (index k + N - 1).
    Channel n of a mover is the static channel model (channels.py eq. 3, delays ``tau``) with its band
    shifted by its Doppler offset f_v = -2 v_los / lambda: at alias frequency f its channel vector is
    exp(j 2 pi (f - f_v) tau_n), filled where |f - f_v| <= half_band. The null (reconstruct.clutter_null)
    projects each base bin onto the complement of the static steering vectors of the aliases inside
    ``band_factor`` x half_band; the static filter bank P = H^-1 then spreads what is left over the
    output bands. As in eq. (6) (channels.ghost_level_db), the part moved by k bands forms a response
    k PRF / K_a away whose peak is |sum_a sum_j E[a, j + k, j] o_aj| / sum o_aj with E = P (I - proj) M,
    over the conventional peak (E = P M, k = 0). A slow mover's residual is the channel phase
    2 pi f_v tau_n by which it differs from the clutter, so it falls as v_los^2.
    """
    tau = np.asarray(tau, float)
    n = len(tau)
    fo = channels.band_frequencies(n_az, prf, n)  # (n_az, N)
    h = np.exp(2j * np.pi * tau[None, :, None] * fo[:, None, :])
    a = h * (np.abs(fo) <= half_band * band_factor)[:, None, :]
    proj = np.eye(n)[None] - a @ np.linalg.pinv(a, rcond=1e-10)
    f_v = -2.0 * v_los / wavelength
    m = np.exp(2j * np.pi * tau[None, :, None] * (fo - f_v)[:, None, :])
    occ = (np.abs(fo - f_v) <= half_band).astype(float)
    p = np.linalg.inv(h)

    def peak(e: np.ndarray, k: int) -> float:
        return abs(sum(np.sum(e[:, j + k, j] * occ[:, j]) for j in range(n) if 0 <= j + k < n))

    ref = peak(p @ m, 0)
    e = p @ (proj @ m)
    gains = np.array([peak(e, k) ** 2 for k in range(-n + 1, n)])
    return gains / ref**2 if ref > 0 else np.zeros_like(gains)


def clutter_null_peak_gain(
    tau: np.ndarray,
    prf: float,
    half_band: float,
    band_factor: float,
    wavelength: float,
    v_los: float,
    n_az: int = 512,
) -> float:
    """The strongest of :func:`clutter_null_peak_gains`: what the null keeps of a mover's peak (fraction)."""
    return float(np.max(clutter_null_peak_gains(tau, prf, half_band, band_factor, wavelength, v_los, n_az)))


def minimum_detectable_velocity(
    tau: np.ndarray,
    prf: float,
    half_band: float,
    band_factor: float,
    wavelength: float,
    required_gain_db: float | np.ndarray,
    v_max: float | None = None,
) -> float:
    """Smallest |v_los| (m/s) at which one of a mover's responses through the clutter null passes the CFAR.

    A mover with conventional detection SNR snr_db (peak over the local background) passes the CFAR
    threshold cfar_db after the null at its response k when snr_db + gain_k - depth_k >= cfar_db, depth_k
    (dB, negative) being how much lower the background is there after the null than where the mover
    appears before it: ``required_gain_db`` = cfar_db - snr_db + depth_k, one value for all k or one per k
    (2 N - 1 values, k = -(N - 1) ... N - 1, as :func:`clutter_null_peak_gains`). The gains rise as
    v_los^2 from 0 at v_los = 0: the first crossing is bracketed on a 0.05 m/s grid and bisected to
    1 mm/s. inf if it is never reached below ``v_max``.

    ``v_max`` (default) is the speed lambda N PRF / 4 whose Doppler offset 2 v_los / lambda reaches the edge of the
    processed band N PRF: beyond it a mover's spectrum wraps round that band (its gains repeat with period
    lambda N PRF / 2), so inf means no speed at all. A fixed 50 m/s missed the band edge of campaign scene 026's
    radar (78.1 m/s), where the null, farthest from the clutter, lifts its M3 and M6 over the CFAR threshold by 3.1
    and 0.6 dB: they were said "undetectable at any speed" (docs/multichannel.md section 17). The model keeps only
    the part of a band-edge mover's spectrum inside the band (it does not wrap it), so it understates the gain there.
    """
    need = 10 ** (np.asarray(required_gain_db, float) / 10)
    if v_max is None:
        v_max = wavelength * len(tau) * prf / 4

    def passes(v: float) -> bool:
        return bool(np.any(clutter_null_peak_gains(tau, prf, half_band, band_factor, wavelength, v, 256) >= need))

    lo = 0.0
    for hi in np.arange(0.05, v_max + 1e-9, 0.05):
        if passes(float(hi)):
            break
        lo = float(hi)
    else:
        return math.inf
    hi = float(hi)
    while hi - lo > 1e-3:
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if passes(mid) else (mid, hi)
    return hi


PEAK_UPSAMPLE = 16  # fine-grid points per sample in band_limited_peak


def band_limited_peak(spec: np.ndarray, index: int, cell: int, upsample: int = PEAK_UPSAMPLE) -> tuple[float, float]:
    """Sub-sample (azimuth index, range cell) of the peak of ifft2(``spec``) nearest the sample (index, cell).

    The image is band-limited, so its values between samples are its spectrum's Fourier sum there
    (azimuth frequencies taken about the spectrum's energy centroid, so a band across +-N PRF / 2 is not
    split): evaluated on a grid of 1 / ``upsample`` sample over +-1 sample, its maximum refined by a
    parabola. A parabola through the samples themselves is biased towards the nearest sample: up to
    0.21 range cells (0.9 m) where the range profile is sampled at only 1.2 x its bandwidth (xu_scene).
    """
    n_a, n_r = spec.shape
    k_a = np.fft.fftfreq(n_a) * n_a
    k_r = np.fft.fftfreq(n_r) * n_r
    energy = np.sum(np.abs(spec) ** 2, axis=1)
    centre = float(np.angle(np.sum(energy * np.exp(2j * np.pi * k_a / n_a)))) / (2 * np.pi) * n_a
    k_a = np.mod(k_a - centre + n_a / 2, n_a) - n_a / 2 + centre
    d = np.arange(-upsample, upsample + 1) / upsample
    e_a = np.exp(2j * np.pi * np.outer(index + d, k_a) / n_a)
    e_r = np.exp(2j * np.pi * np.outer(k_r, cell + d) / n_r) if n_r > 1 else np.ones((1, 1))
    fine = np.abs(e_a @ spec @ e_r) ** 2
    i, c = np.unravel_index(int(np.argmax(fine)), fine.shape)

    def vertex(v: np.ndarray, j: int | np.integer) -> float:
        if 0 < j < len(v) - 1:
            den = v[j - 1] - 2 * v[j] + v[j + 1]
            if den < 0:
                return j + 0.5 * (v[j - 1] - v[j + 1]) / den
        return float(j)

    return index + d[0] + vertex(fine[:, c], i) / upsample, cell + (
        d[0] + vertex(fine[i], c) / upsample if n_r > 1 else 0.0
    )


def compressed_peak_offset(
    out_times: np.ndarray,
    positions: np.ndarray,
    xyz: np.ndarray,
    interval: tuple[float, float],
    beam_centre_time: float,
    squint: float,
    velocity: float,
    wavelength: float,
    ka: float,
) -> float:
    """Time (s) from a static point's beam-centre time to its peak in the detection image (:func:`compressed`).

    The compression is quadratic (K_a, eq. 7); the squinted range history R(t) = |xyz - P(t)| also has a cubic
    term (R''' = -3 R' R'' / R), whose group delay over an illumination not centred on the beam-centre time moves
    the peak: -0.18 ms (1.2 m in azimuth) for a static point of xu_scene, -0.13 to -0.17 ms for its movers, whose
    echoes (the static equivalent's chirp over the mover's own ``interval``, s) lie 110-150 ms after it. K_a
    taken at another range than the point's adds (offset of the band centre) x (1 / K_a - 1 / K_a(R)). Modelled
    exactly: that chirp (walk-corrected as the data: R + v sin(theta) t, at the phase centres ``positions`` at
    ``out_times``), compressed by ``ka``, its peak found by :func:`band_limited_peak`.
    """
    t = np.asarray(out_times, float)
    lit = (t >= interval[0]) & (t <= interval[1])
    r = np.linalg.norm(np.asarray(xyz, float)[None, :] - positions, axis=1)
    path = r + velocity * math.sin(squint) * t
    sig = np.where(lit, unit_phasor(np.mod(-2 * path / wavelength, 1.0)), 0)
    f = np.fft.fftfreq(len(t), t[1] - t[0])
    spec = sfft.fft(sig)[:, None] * compression(f, np.array([ka]))
    index = int(np.argmax(np.abs(sfft.ifft(spec[:, 0]))))
    peak, _ = band_limited_peak(spec, index, 0)
    return float(t[0] + peak * (t[1] - t[0]) - beam_centre_time)
