"""Linear-array down-looking 3D SAR by elevation-angle compression (Du, Wang, Hong, Wu 2010).

Geometry (paper 004, Fig. 1-2): the platform flies along +x at height H; one transmitter at the
array centre, receivers across track at offsets v_n (y). A point P is described by the
cylindrical coordinates of eq. (3): azimuth x, slant range r from the track (x, 0, H) and
elevation angle theta from nadir, P = (x, r sin(theta), H - r cos(theta)). The processor
(Fig. 3) works on range-compressed channel data s(t, u_m, v_n):

1. range compression, eq. (9) (matched filter of the centred chirp; peak at the true delay);
2. azimuth RCMC in the range-Doppler domain, eq. (14), by kernel interpolation along range
   (the shift depends on azimuth frequency and on the range bin's r);
3. azimuth compression, eq. (17), per range bin (``azimuth_model: fresnel``; ``hyperbolic``
   uses the exact range-Doppler phase 4 pi r / lambda (D - 1), D = sqrt(1 - (lambda f_u / 2)^2));
   the result per channel is the 2D image of Fig. 5;
4. cross-track RCMC by the range-frequency factors of eq. (20) (the v_n^2 / (2 r0) term, at one
   reference range) and eq. (21) (the v_n sin(theta0) term). Eq. (21) needs theta0, the
   unknown target elevation: ``per_bin`` (default) applies it with each output elevation
   bin's own theta, which makes it exact for every elevation; ``reference`` applies it once
   with a fixed theta (the paper's Fig. 6 discussion), ``off`` skips it;
5. deramp over channels, eq. (23), with K_e = 1 / (lambda r) of each range bin;
6. transform over channels into the w = sin(theta) domain, eqs. (24)-(26): the channel DFT
   sum_n s_n exp(-j 2 pi v_n w / lambda), evaluated on an output grid uniform in theta. This is
   exactly the paper's zero-padded FFT followed by band-limited resampling from sin(theta) to
   theta (the sum is a trigonometric polynomial in w), done as one matrix product so that the
   elevation axis is uniformly spaced in radians; ``elevation_zero_padding`` sets the grid
   step lambda / (pad N d) as the FFT length pad N would.

Steps 4-6 with ``per_bin`` are one matrix product per range frequency f with kernel
exp(-j 2 pi (f_c + f) v_n sin(theta_k) / c): eq. (21) at theta_k and the DFT together.

Readings of the paper that are ours: the deramp is applied before the cross-track range shift
(the deramp phase varies by < 1e-3 rad over the shift); eq. (4)'s approximation is only used
by the processor, the data may be exact.
"""

from __future__ import annotations

import dataclasses
import math
from typing import TYPE_CHECKING

import numpy as np

from sarproc.dsp.interp import KERNELS, resample
from sarproc.dsp.phasor import multiply_separable_phase
from sarproc.dsp.rangecomp import chirp_replica, replica_fft_size, replica_spectrum
from sarproc.focus.array_response import chirp_attrs, period_attrs, range_response_attrs
from sarproc.product import fft as sfft
from sarproc.product.config import param
from sarproc.product.errors import IMAGE_DEFECT, InputError, ProcessingError
from sarproc.product.metadata import SINC_IRW_FACTOR, C, RadarMetadata
from sarproc.product.sorted_values import median
from sarproc.product.steps import steps, wrapped
from sarproc.product.theory import array_elevation_theory, fill_target_theory, window_theory

if TYPE_CHECKING:
    from collections.abc import Sequence

    import numpy.typing as npt

    from sarproc.product.model import Product
    from sarproc.product.steps import ProgressFactory


@dataclasses.dataclass(frozen=True)
class Array3DParams:
    """Parameters of ``sarproc array3d`` (section ``array3d:``)."""

    range_filter: str = param(
        default="matched",
        choices=("matched", "flat"),
        doc=(
            "range compression: matched = eq. (9) (conjugate chirp spectrum); flat = divide by the chirp "
            "spectrum inside |f| <= B/2 (an exact rect spectrum, as sarproc.dsp.rangecomp's default)"
        ),
    )
    rcmc_kernel: str = param(
        default="sinc",
        choices=KERNELS + ("none",),
        doc=("azimuth RCMC interpolation kernel, eq. (14) (paper: sinc); none skips azimuth RCMC"),
    )
    rcmc_kernel_length: int = param(
        default=16, ge=2, le=64, doc=("taps of the sinc/lanczos kernels (cubic uses 4, linear 2, nearest 1)")
    )
    azimuth_model: str = param(
        default="fresnel",
        choices=("fresnel", "hyperbolic"),
        doc=("azimuth RCM and matched filter: fresnel = eqs. (14), (17); hyperbolic = exact range-Doppler form"),
    )
    cross_track_rcmc_range: str = param(
        default="off",
        choices=("off", "reference"),
        doc=("eq. (20), the v_n^2/(2 r0) range shift; paper: negligible for H >> L, so off"),
    )
    cross_track_rcmc_elevation: str = param(
        default="per_bin",
        choices=("per_bin", "reference", "off"),
        doc=(
            "eq. (21), the v_n sin(theta0) range shift; per_bin: with each elevation bin's theta (exact); "
            "reference: once with reference_elevation; off: skipped"
        ),
    )
    reference_range: float | None = param(
        "length", default=None, gt=0, doc=("r0 of eq. (20); default: the middle of the output range axis")
    )
    reference_elevation: float = param(
        "angle",
        default=0.0,
        gt=-math.pi / 2,
        lt=math.pi / 2,
        doc=("theta0 of eq. (21) for cross_track_rcmc_elevation: reference"),
    )
    elevation_zero_padding: float = param(
        default=4.0,
        ge=1.0,
        le=64.0,
        doc=("elevation grid step lambda / (pad N d), as a zero-padded FFT of length pad N (eq. 26)"),
    )
    elevation_span: float | None = param(
        "angle",
        default=None,
        gt=0,
        lt=math.pi / 2,
        doc=("half-width of the output elevation sector; default: the unambiguous sector asin(lambda / 2d)"),
    )
    deramp: bool = param(default=True, doc="apply the deramp of eq. (23)")
    crop_range: bool = param(
        default=True, doc=("keep only range samples where a whole pulse fits in the receive window")
    )
    precision: str = param(
        default="float32",
        choices=("float32", "float64"),
        doc=("intermediate precision of the signal arrays (phases and geometry are always float64)"),
    )
    block_elements: int = param(
        default=8_000_000, ge=10_000, doc=("complex elements per block of the elevation transform (bounds peak memory)")
    )


@dataclasses.dataclass
class ArrayGeometry:
    """Receiver offsets across track, m (relative to the transmitter), and derived sampling."""

    offsets: np.ndarray  # (n_ch,) v_n, m
    spacing: float  # d, m (median spacing of the sorted offsets)
    uniform: bool


@dataclasses.dataclass
class Array3DResult:
    """Output of :func:`focus_array3d` (all coordinates SI)."""

    cube: np.ndarray  # (n_el, n_az, n_rg) complex64
    elevation: np.ndarray  # (n_el,) rad, uniform
    azimuth: np.ndarray  # (n_az,) m (platform x of each pulse)
    range: np.ndarray  # (n_rg,) m, slant range r = c tau / 2
    theoretical_irw: list  # [elevation rad, azimuth m, range m] at nadir
    channel_images: np.ndarray | None  # (n_ch, n_az, n_rg) complex64 before elevation compression
    channel_irw: list  # [azimuth m, range m]
    info: dict  # numbers worth recording in the history


# ----------------------------------------------------------------------------------------------
# Geometry checks and theory


def array_geometry(tx_offset: np.ndarray, rx_offset: np.ndarray) -> ArrayGeometry:
    """Cross-track receiver offsets v_n relative to the transmitter; refuse other layouts."""
    tx = np.asarray(tx_offset, float).reshape(3)
    rx = np.asarray(rx_offset, float).reshape(-1, 3)
    if np.any(np.abs(tx) > 1e-9):
        raise InputError(
            f"aux rx/tx offsets: array3d needs the transmitter on the platform track "
            f"(tx_offset = 0), got {tx.tolist()} m"
        )
    if np.any(np.abs(rx[:, [0, 2]]) > 1e-9):
        raise InputError("aux rx_offset: array3d needs a cross-track (y) array; some receivers have x or z offsets")
    v = rx[:, 1].copy()
    if len(v) < 2:
        raise InputError(
            f"array3d needs at least 2 receivers for elevation compression, got {len(v)} "
            "(with one receiver there is no elevation resolution: use sarproc backproject "
            "or array3d --channel-image on a 2-receiver product)"
        )
    s = np.diff(np.sort(v))
    if np.any(s <= 0):
        raise InputError("aux rx_offset: two receivers share a cross-track position")
    d = median(s)
    return ArrayGeometry(offsets=v, spacing=d, uniform=bool(np.allclose(s, d, rtol=1e-6, atol=1e-12)))


def elevation_irw(offsets: np.ndarray, wavelength: float) -> float:
    """-3 dB width in w = sin(theta) of |sum_n exp(j 2 pi v_n w / lambda)| at w = 0 (eq. 26).

    0.886 lambda / (N d) for many uniform receivers; computed numerically so 2 receivers and
    non-uniform arrays get their true width.
    """
    v = np.asarray(offsets, float) - np.mean(offsets)
    span = float(np.ptp(v)) + median(np.diff(np.sort(v)))
    first_null = wavelength / span
    w = np.linspace(0.0, 1.5 * first_null, 6001)
    af = np.abs(np.exp(2j * np.pi * np.outer(w, v) / wavelength).sum(axis=1)) / len(v)
    below = np.nonzero(af**2 <= 0.5)[0]
    if len(below) == 0:
        raise ProcessingError("elevation response does not drop by 3 dB; array too short")
    i = below[0]
    w3 = w[i - 1] + (w[i] - w[i - 1]) * (af[i - 1] ** 2 - 0.5) / (af[i - 1] ** 2 - af[i] ** 2)
    return 2.0 * float(w3)


def target_theory_3d(
    offsets: np.ndarray, wavelength: float, elevations: np.ndarray, channel_irw: Sequence[float]
) -> list:
    """Each target's own theory (sarproc.product.theory.ResponseTheory per axis: elevation rad, azimuth m,
    range m): the receivers' array factor seen from its elevation theta (spatial frequencies v_n cos(theta) /
    lambda per radian, each receiver a cell of the median spacing wide), and the flat azimuth and range
    supports of ``channel_irw`` (their unweighted IRWs)."""
    flat = window_theory("none")
    others = [flat.scaled(w / SINC_IRW_FACTOR) for w in channel_irw]
    return [
        [array_elevation_theory(offsets, wavelength, float(theta))] + others for theta in np.asarray(elevations, float)
    ]


def azimuth_bandwidth(radar: RadarMetadata, du: float) -> float:
    """Processed azimuth (spatial) bandwidth, cycles/m: the beam's 4 sin(beta/2) / lambda, or PRF/v."""
    full = 1.0 / du
    if radar.azimuth_beamwidth > 0:
        return min(4.0 * math.sin(radar.azimuth_beamwidth / 2) / radar.wavelength, full)
    return full


def elevation_grid(geom: ArrayGeometry, wavelength: float, params: Array3DParams) -> np.ndarray:
    """Output elevation angles, rad: uniform, symmetric about nadir, step asin(lambda/(pad N d))."""
    n = len(geom.offsets)
    step = math.asin(min(1.0, wavelength / (params.elevation_zero_padding * n * geom.spacing)))
    if params.elevation_span is not None:
        span = params.elevation_span
    else:
        span = math.asin(min(1.0, wavelength / (2 * geom.spacing)))
    k = int(math.floor(span / step + 1e-9))
    if k < 1:
        raise InputError("array3d.elevation_span: narrower than one elevation bin")
    theta = np.arange(-k, k + 1) * step
    return theta[np.abs(np.sin(theta)) < 1.0]


# ----------------------------------------------------------------------------------------------
# Processing steps


def range_compress(
    signal: np.ndarray, radar: RadarMetadata, ctype: npt.DTypeLike, workers: int = -1, kind: str = "matched"
) -> np.ndarray:
    """Range compression of the centred chirp along the last axis, eq. (9); a unit echo peaks at ~1.

    ``matched``: conj(H(f)), the paper's matched filter; ``flat``: rect(f/B) / H(f). Works in
    ``ctype`` precision (the shared :func:`sarproc.dsp.rangecomp.range_compress` always returns complex64).
    """
    n_rg = signal.shape[-1]
    h, _ = chirp_replica(radar)
    n_fft = replica_fft_size(radar, n_rg)
    spec_h = replica_spectrum(radar, n_fft)
    if kind == "matched":
        filt = (np.conj(spec_h) / np.count_nonzero(h)).astype(ctype)
    else:
        band = np.abs(sfft.fftfreq(n_fft, 1.0 / radar.range_sampling_rate)) <= radar.bandwidth / 2
        filt = (np.where(band, 1.0 / np.where(band, spec_h, 1.0), 0.0) * (np.count_nonzero(band) / n_fft)).astype(ctype)
    # Channel by channel into one output: the zero-padded spectra of all channels at once were twice the input.
    flat = signal.reshape(-1, signal.shape[-2], n_rg)
    out = np.empty(flat.shape, dtype=ctype)
    for c in range(len(flat)):
        spec = sfft.fft(flat[c].astype(ctype, copy=False), n=n_fft, axis=-1, workers=workers)
        spec *= filt
        out[c] = sfft.ifft(spec, axis=-1, workers=workers, overwrite_x=True)[:, :n_rg]
    return out.reshape(signal.shape[:-1] + (n_rg,))


def azimuth_focus(
    rc: np.ndarray,
    du: float,
    ranges: np.ndarray,
    radar: RadarMetadata,
    params: Array3DParams,
    ctype: npt.DTypeLike,
    workers: int = -1,
    overwrite: bool = False,
) -> np.ndarray:
    """Azimuth RCMC (eq. 14) and compression (eq. 17) of (n_ch, n_az, n_rg) range-compressed data.

    ``du`` is the along-track pulse spacing (m), ``ranges`` the slant range r = c tau / 2 of each
    range sample. Returns the per-channel 2D images, same shape, azimuth sample m focused at
    x = u_m (written into ``rc`` itself when ``overwrite``).
    """
    n_ch, n_az, n_rg = rc.shape
    lam = radar.wavelength
    fs = radar.range_sampling_rate
    # Pad by one beam footprint so the circular azimuth convolution does not wrap.
    if radar.azimuth_beamwidth > 0:
        pad = int(math.ceil(2 * float(ranges.max()) * math.tan(radar.azimuth_beamwidth / 2) / du)) + 2
    else:
        pad = n_az
    n_fft = sfft.next_fast_len(n_az + min(pad, n_az))
    fu = sfft.fftfreq(n_fft, du)[:, None]  # spatial frequency, cycles/m
    r = ranges[None, :]
    if params.azimuth_model == "fresnel":
        d_r = lam**2 * r * fu**2 / 4.0  # eq. (14), two-way path excess, m
        phase = -np.pi * fu**2 * lam * r / 2.0  # eq. (17): -pi f_u^2 / K_a, K_a = 2/(lambda r)
    else:
        arg = 1.0 - (lam * fu / 2.0) ** 2
        if np.any(arg <= 0):
            raise ProcessingError(
                "azimuth frequencies beyond 2/lambda: the PRF/velocity sampling is too fine for the hyperbolic model"
            )
        dfac = np.sqrt(arg)
        d_r = 2.0 * r * (1.0 / dfac - 1.0)
        phase = 4.0 * np.pi * r / lam * (dfac - 1.0)
    filt = np.exp(1j * phase).astype(ctype)  # (n_fft, n_rg)
    pos = np.arange(n_rg)[None, :] + d_r * fs / C  # read the sample at tau + dR / c
    # Channel by channel, each focused image written over its range-compressed input when ``overwrite``
    # (the padded spectra, their resampled copy and the output of all channels at once were 4x the data).
    out = rc if overwrite else np.empty_like(rc)
    for c in range(n_ch):
        spec = sfft.fft(rc[c], n=n_fft, axis=0, workers=workers)
        if params.rcmc_kernel != "none":
            # Kaiser beta = taps / 4 for the sinc kernel (16 taps: < 1.3 % error up to 0.42 cycles/sample).
            spec = resample(
                spec, pos, params.rcmc_kernel, params.rcmc_kernel_length, beta=params.rcmc_kernel_length / 4.0
            )
        spec *= filt
        out[c] = sfft.ifft(spec, axis=0, workers=workers, overwrite_x=True)[:n_az, :]
    return out


def elevation_compress(
    images: np.ndarray,
    ranges: np.ndarray,
    geom: ArrayGeometry,
    theta: np.ndarray,
    radar: RadarMetadata,
    params: Array3DParams,
    ctype: npt.DTypeLike,
    workers: int = -1,
    progress: ProgressFactory | None = None,
) -> np.ndarray:
    """Cross-track RCMC (eqs. 20, 21), deramp (eq. 23) and transform over channels (eqs. 24-26).

    images: (n_ch, n_az, n_rg) per-channel 2D images; ranges: (n_rg,) m; theta: output
    elevations, rad. Returns (n_el, n_az, n_rg), normalised by the number of channels.
    """
    n_ch, n_az, n_rg = images.shape
    lam, fs, fc = radar.wavelength, radar.range_sampling_rate, radar.carrier_frequency
    v = geom.offsets
    w = np.sin(theta)
    x = images
    if params.deramp:  # eq. (23): exp(j pi K_e v_n^2), K_e = 1/(lambda r)
        x = x * np.exp(1j * np.pi * v[:, None, None] ** 2 / (lam * ranges[None, None, :])).astype(ctype)
    r_ref = params.reference_range or float(ranges[len(ranges) // 2])
    n_fft, blocks, step = _elevation_blocks(images.shape, ranges, geom, theta, radar, params)
    f = sfft.fftfreq(n_fft, 1.0 / fs)  # baseband range frequency, Hz
    # Range-frequency factors per channel, fac = outer(fac_per_hz, f) (n_ch, n_f): eq. (20) and eq. (21) at a
    # reference theta, both linear in f.
    fac_per_hz = np.zeros(n_ch)
    if params.cross_track_rcmc_range == "reference":
        fac_per_hz += np.pi * v**2 / (C * r_ref)  # eq. (20)
    if params.cross_track_rcmc_elevation == "reference":
        fac_per_hz += -2 * np.pi * v * math.sin(params.reference_elevation) / C  # eq. (21)
    fac = np.outer(fac_per_hz, f)
    spec = sfft.fft(x, n=n_fft, axis=-1, workers=workers)  # (n_ch, n_az, n_f)
    scale = 1.0 / n_ch
    out = np.empty((len(theta), n_az, n_rg), dtype=ctype)
    if params.cross_track_rcmc_elevation == "per_bin":
        # One product per range frequency: eq. (21) at theta_k and the DFT of eq. (26) together.
        spec = np.ascontiguousarray(spec.transpose(2, 0, 1))  # (n_f, n_ch, n_az)
        y = np.empty((n_fft, len(theta), n_az), dtype=ctype)
        for s in progress(blocks) if progress is not None else blocks:
            e = min(s + step, n_fft)
            # phase -2 pi (f_c + f) w_k v_n / c + f fac_per_hz[n], generated straight into the kernel (fused)
            kern = np.full((e - s, len(theta) * n_ch), scale, dtype=ctype)
            multiply_separable_phase(
                kern,
                [fc + f[s:e], f[s:e]],
                [(-2 * np.pi / C) * np.outer(w, v).ravel(), np.tile(fac_per_hz, len(theta))],
            )
            np.matmul(kern.reshape(e - s, len(theta), n_ch), spec[s:e], out=y[s:e])
        del spec
        y = sfft.ifft(y, axis=0, workers=workers, overwrite_x=True)[:n_rg]  # (n_rg, n_el, n_az)
        out[...] = y.transpose(1, 2, 0)
        return out
    if np.any(fac != 0):
        spec *= np.exp(1j * fac)[:, None, :].astype(ctype)
    x = sfft.ifft(spec, axis=-1, workers=workers, overwrite_x=True)[..., :n_rg]
    kern = (np.exp(-2j * np.pi * np.outer(w, v) / lam) * scale).astype(ctype)  # eq. (26) DFT, (n_el, n_ch)
    flat = x.reshape(n_ch, -1)
    out2 = out.reshape(len(theta), -1)
    for s in progress(blocks) if progress is not None else blocks:
        out2[:, s : s + step] = kern @ flat[:, s : s + step]
    return out


def _elevation_blocks(
    shape: tuple[int, ...],
    ranges: np.ndarray,
    geom: ArrayGeometry,
    theta: np.ndarray,
    radar: RadarMetadata,
    params: Array3DParams,
) -> tuple[int, range, int]:
    """(n_fft, block starts, block length) of :func:`elevation_compress` on (n_ch, n_az, n_rg) images.

    The range FFT is padded by the largest cross-track range shift (eqs. 20, 21); the blocks run
    over range frequencies (per-bin RCMC) or over (azimuth, range) pixels, params.block_elements each.
    """
    n_ch, n_az, n_rg = shape
    v, w = geom.offsets, np.sin(theta)
    r_ref = params.reference_range or float(ranges[len(ranges) // 2])
    shift_max = float(np.max(np.abs(v)) * np.max(np.abs(w)) + np.max(v**2) / (2 * r_ref))
    pad = int(math.ceil(2 * shift_max / C * radar.range_sampling_rate)) + 4
    n_fft = sfft.next_fast_len(n_rg + pad)
    if params.cross_track_rcmc_elevation == "per_bin":
        per_f = 2 * len(theta) * n_ch + len(theta) * n_az + n_ch * n_az
        step = max(1, int(params.block_elements // max(per_f, 1)))
        return n_fft, range(0, n_fft, step), step
    step = max(1, int(params.block_elements // max(len(theta) + n_ch, 1)))
    return n_fft, range(0, n_az * n_rg, step), step


def _along_track(platform_position: np.ndarray, radar: RadarMetadata) -> tuple[np.ndarray, float]:
    pos = np.asarray(platform_position, float)
    if pos.ndim != 2 or pos.shape[1] != 3 or len(pos) < 2:
        raise InputError(f"aux platform_position: expected (n_az >= 2, 3), got {pos.shape}")
    if np.any(np.abs(pos[:, 1]) > 1e-6) or np.any(np.abs(pos[:, 2] - radar.altitude) > 1e-6):
        raise InputError(
            "aux platform_position: array3d needs a straight track along x at y = 0, z = altitude "
            "(motion errors are not modelled)"
        )
    u = pos[:, 0]
    du = (u[-1] - u[0]) / (len(u) - 1)
    if du <= 0 or np.max(np.abs(np.diff(u) - du)) > 1e-6 * abs(du):
        raise InputError("aux platform_position: pulses must be uniformly spaced along +x")
    return u, float(du)


def focus_array3d(
    signal: np.ndarray,
    range_time: np.ndarray,
    platform_position: np.ndarray,
    tx_offset: np.ndarray,
    rx_offset: np.ndarray,
    radar: RadarMetadata,
    params: Array3DParams = Array3DParams(),
    *,
    keep_channel_images: bool = False,
    progress: ProgressFactory | None = None,
    workers: int = -1,
) -> Array3DResult:
    """The whole chain of Fig. 3 on a (n_ch, n_az, n_rg) ``raw_array`` signal.

    range_time: (n_rg,) s since transmit, uniform at f_s; platform_position: (n_az, 3) m;
    tx_offset (3,), rx_offset (n_ch, 3) m relative to the platform. Inputs are not modified.
    """
    signal = np.asarray(signal)
    acq = _checked_acquisition(signal, range_time, platform_position, tx_offset, rx_offset, radar)
    geom, u, du, range_time = acq.geometry, acq.along_track, acq.along_track_spacing, acq.range_time
    n_ch, n_az, n_rg = signal.shape
    ctype = np.complex64 if params.precision == "float32" else np.complex128
    lam = radar.wavelength
    ranges = C * range_time / 2.0

    theta = elevation_grid(geom, lam, params)
    sl = _range_crop(range_time, radar, params)
    # One bar over the whole chain: range compression, azimuth focusing, then each elevation block.
    n_kept = len(range(n_rg)[sl])
    blocks = _elevation_blocks((n_ch, n_az, n_kept), ranges[sl], geom, theta, radar, params)[1]
    done = steps(progress, 2 + len(blocks))
    rc = range_compress(signal, radar, ctype, workers, params.range_filter)
    done()
    images = azimuth_focus(rc, du, ranges, radar, params, ctype, workers, overwrite=True)
    done()
    del rc
    # Elevation compression works on the cropped range span plus a guard for the range shifts.
    cube = elevation_compress(
        images[:, :, sl],
        ranges[sl],
        geom,
        theta,
        radar,
        params,
        ctype,
        workers,
        None if progress is None else (lambda it, total=None: wrapped(done, it)),
    )
    b_az = azimuth_bandwidth(radar, du)
    irw_az = SINC_IRW_FACTOR / b_az
    irw_rg = SINC_IRW_FACTOR * C / (2 * radar.bandwidth)
    irw_el = elevation_irw(geom.offsets, lam)
    info = _chain_info(geom, theta, lam, b_az, du, ranges, sl, n_rg)
    chans = images[:, :, sl].astype(np.complex64) if keep_channel_images else None
    return Array3DResult(
        cube=cube.astype(np.complex64, copy=False),
        elevation=theta,
        azimuth=u.copy(),
        range=ranges[sl].copy(),
        theoretical_irw=[irw_el, irw_az, irw_rg],
        channel_images=chans,
        channel_irw=[irw_az, irw_rg],
        info=info,
    )


@dataclasses.dataclass(frozen=True)
class _Acquisition:
    """What :func:`focus_array3d` needs of its inputs besides the signal, checked against its shape."""

    geometry: ArrayGeometry
    along_track: np.ndarray  # (n_az,) m, the pulses' platform x
    along_track_spacing: float  # m
    range_time: np.ndarray  # (n_rg,) s since transmit, float64


def _checked_acquisition(
    signal: np.ndarray,
    range_time: np.ndarray,
    platform_position: np.ndarray,
    tx_offset: np.ndarray,
    rx_offset: np.ndarray,
    radar: RadarMetadata,
) -> _Acquisition:
    """The array geometry, the along-track axis and the range times of a (n_ch, n_az, n_rg) signal; raises
    InputError where they do not match it (or the signal holds NaN or Inf)."""
    if signal.ndim != 3:
        raise InputError(f"signal: expected (channel, azimuth_time, range_time), got shape {signal.shape}")
    n_ch, n_az, n_rg = signal.shape
    geom = array_geometry(tx_offset, rx_offset)
    if len(geom.offsets) != n_ch:
        raise InputError(f"aux rx_offset has {len(geom.offsets)} receivers, the signal {n_ch} channels")
    if radar.altitude <= 0:
        raise InputError("radar.altitude: array3d is a down-looking processor and needs altitude > 0")
    u, du = _along_track(platform_position, radar)
    if len(u) != n_az:
        raise InputError(f"aux platform_position has {len(u)} pulses, the signal {n_az}")
    range_time = np.asarray(range_time, float)
    if len(range_time) != n_rg:
        raise InputError(f"range_time has {len(range_time)} samples, the signal {n_rg}")
    if not np.all(np.isfinite(signal)):
        raise InputError("signal contains NaN or Inf")
    return _Acquisition(geom, u, du, range_time)


def _range_crop(range_time: np.ndarray, radar: RadarMetadata, params: Array3DParams) -> slice:
    """The range samples kept: with ``crop_range`` those fully compressed (half a pulse from either end of the
    receive window), else all."""
    if not params.crop_range:
        return slice(None)
    keep = np.nonzero(
        (range_time >= range_time[0] + radar.pulse_duration / 2)
        & (range_time <= range_time[-1] - radar.pulse_duration / 2)
    )[0]
    if len(keep) < 2:
        raise ProcessingError(
            "the receive window is shorter than the pulse: no fully compressed range "
            "sample (set array3d.crop_range: false to keep partial ones)"
        )
    return slice(int(keep[0]), int(keep[-1]) + 1)


def _chain_info(
    geom: ArrayGeometry,
    theta: np.ndarray,
    lam: float,
    b_az: float,
    du: float,
    ranges: np.ndarray,
    sl: slice,
    n_rg: int,
) -> dict:
    """The numbers of a focus_array3d run worth recording in the history (Array3DResult.info)."""
    return {
        "n_channels": len(geom.offsets),
        "receiver_spacing_m": geom.spacing,
        "uniform_array": geom.uniform,
        "elevation_bins": int(len(theta)),
        "elevation_step_rad": float(theta[1] - theta[0]),
        "unambiguous_half_sector_rad": math.asin(min(1.0, lam / (2 * geom.spacing))),
        "azimuth_bandwidth_cycles_per_m": b_az,
        "along_track_spacing_m": du,
        "cross_track_rcm_max_m": float(
            np.max(np.abs(geom.offsets)) * np.max(np.abs(np.sin(theta)))
            + np.max(geom.offsets**2) / (2 * float(ranges[sl].mean()))
        ),
        "range_crop_samples": [int(sl.start or 0), int(sl.stop or n_rg)],
    }


# ----------------------------------------------------------------------------------------------
# Product level (in memory; the CLI only reads and writes)


def focus_raw_array(
    raw: Product,
    params: Array3DParams = Array3DParams(),
    *,
    keep_channel_images: bool = False,
    progress: ProgressFactory | None = None,
) -> Array3DResult:
    """:func:`focus_array3d` on a ``raw_array`` product's signal, range times, track and array offsets."""
    return focus_array3d(
        raw.data,
        raw.coords["range_time"],
        raw.aux["platform_position"],
        raw.aux["tx_offset"],
        raw.aux["rx_offset"],
        raw.radar,
        params,
        keep_channel_images=keep_channel_images,
        progress=progress,
    )


def array3d_product(
    raw: Product,
    params: Array3DParams = Array3DParams(),
    *,
    channel_image: int | None = None,
    channel_overlap: bool = False,
    progress: ProgressFactory | None = None,
    command: str = "array3d",
) -> tuple[Product, Product | None]:
    """Focus a ``raw_array`` :class:`~sarproc.product.model.Product` into an ``image3d`` product.

    ``channel_image`` (1-based receiver number, as the paper's "14th receiver") also returns the
    2D ``image`` of that channel before elevation compression (paper Fig. 5), else None.
    ``channel_overlap``: measure, over every receiver's 2D image, the overlap of targets sharing one
    (azimuth, range) cell (:func:`channel_overlap`), recorded as the cube's attribute ``channel_overlap``.
    Returns (cube product, channel product or None).

    Steps: :func:`_checked_raw`, :func:`focus_array3d`, :func:`_cube_product` (elevation ambiguities,
    history, each target's theory), :func:`_channel_product`.
    """
    _checked_raw(raw, channel_image)
    keep = channel_image is not None or channel_overlap
    res = focus_raw_array(raw, params, keep_channel_images=keep, progress=progress)
    cube = _cube_product(raw, res, params, command)
    if channel_overlap:
        cube.attrs["channel_overlap"] = channel_overlap_measure(raw, res)
    chan = None if channel_image is None else _channel_product(raw, res, params, channel_image, command)
    return cube, chan


def channel_overlap_measure(raw: Product, res: Array3DResult) -> dict:
    """Paper 004's Fig. 5 overlap over every receiver (:func:`sarproc.quality.overlap.image_overlap` on
    ``res.channel_images``): targets sharing one (azimuth, range) cell of the 2D images, each group's energy
    over the mean of the lone targets' per receiver, and the coherent sum its targets' two-way paths predict
    (at the pulse nearest each target's azimuth)."""
    from sarproc.product.frames import SquintFrame, targets_in_frame
    from sarproc.product.model import target_names
    from sarproc.quality.overlap import image_overlap

    if res.channel_images is None:
        raise ValueError("channel_overlap_measure: the result kept no channel images")
    t = targets_in_frame(raw.targets, SquintFrame(0.0, raw.radar.altitude))
    xyz = np.stack([t["x"], t["y"], t["z"]], axis=1)
    pos = np.asarray(raw.aux["platform_position"], float)
    pulse = np.argmin(np.abs(pos[:, 0][None, :] - xyz[:, 0][:, None]), axis=1)  # (k,) nearest pulse
    tx = pos[pulse] + np.asarray(raw.aux["tx_offset"], float).reshape(3)  # (k, 3)
    rx = pos[pulse][None, :, :] + np.asarray(raw.aux["rx_offset"], float)[:, None, :]  # (n, k, 3)
    paths = np.linalg.norm(xyz - tx, axis=-1)[None, :] + np.linalg.norm(xyz[None] - rx, axis=-1)
    names = target_names(t)
    groups, lone = image_overlap(
        res.channel_images,
        res.azimuth,
        res.range,
        names,
        np.stack([t["azimuth"], t["range"]], axis=1),
        res.channel_irw,
        paths,
        t["amplitude"],
        raw.radar.wavelength,
    )
    return {
        "groups": [g.to_dict() for g in groups],
        "reference_targets": lone,
        "note": (
            "per receiver (1..N), before elevation compression: the largest |pixel|^2 at a group's (azimuth, "
            "range) cell (nearest azimuth row, 3 nearest range samples) over its mean at the lone targets' cells; "
            "predicted: |sum_k a_k exp(-j 2 pi R_nk / lambda)|^2 / mean |a_lone|^2, R_nk the two-way paths"
        ),
    }


def _checked_raw(raw: Product, channel_image: int | None) -> None:
    """Refuse a product array3d cannot focus (InputError naming the key)."""
    if raw.kind != "raw_array":
        raise InputError(f"array3d needs a raw_array product, got {raw.kind!r}")
    if tuple(raw.dims) != ("channel", "azimuth_time", "range_time"):
        raise InputError(f"signal dims {raw.dims}: expected ('channel', 'azimuth_time', 'range_time')")
    for key in ("platform_position", "tx_offset", "rx_offset"):
        if key not in raw.aux:
            raise InputError(f"aux/{key}: missing (array3d needs the platform track and the array layout)")
    if "range_gate_offset" in raw.aux and np.any(raw.aux["range_gate_offset"] != 0):
        raise InputError("aux/range_gate_offset: a varying receive gate is not supported by array3d")
    n_ch = raw.data.shape[0]
    if channel_image is not None and not 1 <= channel_image <= n_ch:
        raise InputError(f"--channel-image {channel_image}: receivers are numbered 1..{n_ch}")


AZIMUTH_CHIRP_NOTE = (
    "the azimuth matched filter exp(-j pi f^2 / K_a) of eq. (17) spans the whole azimuth FFT band, so a target "
    "seen over a finite aperture (the beam's) focuses to its aperture's sinc times exp(j pi K_a (x - x0)^2) about "
    "its own peak, K_a = 2 / (lambda r): azimuth_chirp_times_range = 2 / lambda (1/m), K_a = value / r "
    "(the magnitude is the sinc's; the phase matters to a neighbour's side lobes)"
)


def _chirp_attrs(radar: RadarMetadata) -> dict:
    """The azimuth chirp every response carries (AZIMUTH_CHIRP_NOTE), for the cube and the channel images."""
    return chirp_attrs(radar, AZIMUTH_CHIRP_NOTE)


def _period_attrs(raw: Product) -> dict:
    """:func:`sarproc.focus.array_response.period_attrs` of the receivers."""
    return period_attrs(raw.radar, raw.aux["rx_offset"])


def _range_response_attrs(raw: Product, params: Array3DParams) -> dict:
    """The range response (:func:`sarproc.focus.array_response.range_response`), for evaluate's neighbour
    models."""
    return range_response_attrs(raw.radar, raw.data.shape[-1], params.range_filter)


def _cube_product(raw: Product, res: Array3DResult, params: Array3DParams, command: str) -> Product:
    """The ``image3d`` product of a focused cube: elevation ambiguities warned and recorded, each target's
    theory in its table, the azimuth chirp of its responses."""
    import logging

    from sarproc.focus.array3d.ambiguity import elevation_ambiguities
    from sarproc.product.config import as_dict
    from sarproc.product.frames import ElevationFrame, targets_in_frame
    from sarproc.product.io import history_entry

    frame = ElevationFrame(raw.radar.altitude)
    ambiguities = elevation_ambiguities(
        res.cube,
        res.elevation,
        res.azimuth,
        res.range,
        raw.radar.elevation_beamwidth,
        raw.radar.wavelength,
        np.asarray(raw.aux["rx_offset"])[:, 1],
        res.theoretical_irw[0],
    )
    for msg in ambiguities:
        logging.getLogger(__name__).warning("array3d: %s", msg, extra=IMAGE_DEFECT)
    entry = history_entry(command, {**as_dict(params), "derived": {**res.info, "elevation_ambiguities": ambiguities}})
    targets = targets_in_frame(raw.targets, frame)
    fill_target_theory(
        targets,
        ("elevation", "azimuth", "range"),
        target_theory_3d(
            array_geometry(raw.aux["tx_offset"], raw.aux["rx_offset"]).offsets,
            raw.radar.wavelength,
            targets["elevation"],
            res.channel_irw,
        ),
    )
    return raw.derive(
        "image3d",
        res.cube,
        ("elevation", "azimuth", "range"),
        {"elevation": res.elevation, "azimuth": res.azimuth, "range": res.range},
        targets=targets,
        attrs={
            "frame": frame.spec,
            "theoretical_irw": [float(x) for x in res.theoretical_irw],
            "axis_units": ["rad", "m", "m"],  # the values are complex amplitudes (units "1")
            "theoretical_irw_note": (
                "unweighted -3 dB widths at nadir: elevation = array-factor width of the receiver "
                "offsets (0.886 lambda / (N d) for many receivers), azimuth = 0.886 / (4 sin(beta_az/2) "
                "/ lambda) (rect beam; PRF/v without a beam), range = 0.886 c / (2 B)"
            ),
            **_chirp_attrs(raw.radar),
            **_period_attrs(raw),
            **_range_response_attrs(raw, params),
        },
        history=list(raw.history) + [entry],
    )


def _channel_product(
    raw: Product, res: Array3DResult, params: Array3DParams, channel_image: int, command: str
) -> Product:
    """The 2D ``image`` of receiver ``channel_image`` (1-based) before elevation compression (paper Fig. 5)."""
    from sarproc.product.config import as_dict
    from sarproc.product.frames import SquintFrame, targets_in_frame
    from sarproc.product.io import history_entry

    assert res.channel_images is not None  # kept because channel_image is set
    f2 = SquintFrame(0.0, raw.radar.altitude)  # zero-Doppler: (x, slant range from the track)
    return raw.derive(
        "image",
        res.channel_images[channel_image - 1],
        ("azimuth", "range"),
        {"azimuth": res.azimuth, "range": res.range},
        targets=targets_in_frame(raw.targets, f2),
        attrs={
            "frame": f2.spec,
            "theoretical_irw": [float(x) for x in res.channel_irw],
            "axis_units": ["m", "m"],
            "channel": int(channel_image),
            "rx_offset": [float(x) for x in np.asarray(raw.aux["rx_offset"])[channel_image - 1]],
            **_chirp_attrs(raw.radar),
        },
        history=list(raw.history)
        + [
            history_entry(
                command + f" --channel-image {channel_image}",
                {
                    **as_dict(params),
                    "channel_image": channel_image,
                    "stage": "range compression, azimuth RCMC and compression (before elevation compression)",
                },
            )
        ],
    )
