"""Fine focusing of coarse-focused squint spotlight data (An et al. 2012, secs. 4-5, fig. 7).

Chain (all per-row / per-column operations vectorised, blocks bound the memory):

1. 2D spectrum of the coarse product (azimuth: centred DFT of the t' grid; range: DFT referred to
   absolute fast time). For the baseline corrections (linear / none) the missing part of eq. (7)
   is applied after the coarse step through the exact identity
   (s e^{j2 pi beta t}) * h (t') = e^{j2 pi beta t'} e^{-j pi beta^2/k} (s * h)(t' - beta/k); it is exact
   when the deramped data did not fold, so whatever breaks in those images comes from folding.
2. Range matched filter (``flat``: divide by the chirp spectrum inside |f_r| <= B/2, the ideal
   sinc; ``phase``: exp(j pi f_r^2 / K_r) of eq. 14), a bulk reference-function multiply at r_ref,
   the modified Stolt mapping (eq. 15, :mod:`sarproc.focus.squint_deramp.stolt`) with the chosen kernel, and a range
   IFFT to the range-Doppler domain of eq. (16).
3. Azimuth compression: eq. (12)'s reference spectrum exp(-j pi f_a^2 / k) is removed and
   - flow 1: exp(+j r G_c(f_a)) at every range bin r (direct compression, valid inside the depth
     of focus of eq. 17), or
   - flow 2: data are zero-padded in the compact coarse domain so that the full aperture fits in
     the time window, then eq. (22) (higher-order compensation), eq. (24) (quartic filter),
     eq. (27) (nonlinear chirp scaling, coefficients :mod:`sarproc.focus.squint_deramp.nlcs`),
     eq. (33) (azimuth filter).
4. Geometric correction: azimuth axis x_n = 2 alpha v t (flow 2) or v t (flow 1); range: every
   azimuth line is shifted by -x_n sin(theta) (the range phase factor of sec. 4.2), giving the
   squint frame (x_n, r_0). With ``output_frame: lrwc`` the range shift is skipped and the image is
   in the ``squint_lrwc`` frame (x_n, r_0 + x_n sin(theta)), where the point response is separable.

Theoretical IRW (attrs ``theoretical_irw``, [azimuth, range], metres): azimuth 0.886 v / B_d with
B_d = |K(r_c)| T the processed Doppler bandwidth of a target (T = n_pulses / PRF, K the FM rate at
the scene centre range), range 0.886 c / (2 B). Each target's own (targets table, sarproc.product.theory)
takes K at its own closest-approach range.
"""

from __future__ import annotations

import dataclasses
import logging
import math
from collections.abc import Callable, Iterable, Sequence

import numpy as np

from sarproc.dsp.interp import KERNELS, resample_rows
from sarproc.dsp.phasor import multiply_separable_phase, unit_phasor
from sarproc.dsp.rangecomp import chirp_replica, replica_spectrum
from sarproc.focus.backprojection import SUPPORT_WRAP_MARGIN, upsample_range
from sarproc.focus.squint_deramp import compiled
from sarproc.focus.squint_deramp.compiled import (
    copy_rows,
    crop_columns,
    gather_columns,
    pad_rows,
    pad_spectrum,
    scale_rows,
)
from sarproc.focus.squint_deramp.nlcs import (
    VARIANTS,
    compression_phase,
    group_delay_span,
    nlcs_coefficients,
    position_terms,
)
from sarproc.focus.squint_deramp.preprocess import PRECISIONS, complex_dtype, correction_frequency
from sarproc.focus.squint_deramp.stolt import MODELS, SpectrumModel, stolt_resample
from sarproc.product import fft as sfft
from sarproc.product.config import as_dict, param
from sarproc.product.errors import IMAGE_DEFECT, InputError, ProcessingError
from sarproc.product.frames import SquintFrame, SquintLrwcFrame, targets_in_frame
from sarproc.product.metadata import SINC_IRW_FACTOR, C, RadarMetadata
from sarproc.product.model import Product
from sarproc.product.theory import fill_target_theory, record_ridge_angles, window_theory

log = logging.getLogger(__name__)

Progress = Callable[[Iterable[int]], Iterable[int]]  # wraps a block range in a progress bar


@dataclasses.dataclass(frozen=True)
class FineFocusParams:
    """``fine_focus:`` section."""

    flow: int | None = param(
        default=None,
        choices=(1, 2),
        doc="1 = direct azimuth compression, 2 = modified NLCS; null = automatic from eq. (17)",
    )
    nlcs_variant: str = param(
        default="modified",
        choices=VARIANTS,
        doc="modified (paper), separated (two-dimension-separated), classic (NLCS)",
    )
    alpha: float = param(
        default=0.4,
        gt=0,
        lt=10,
        doc="NLCS output scaling: targets land at t_n / (2 alpha); "
        "below 1/2 the scaled spectrum (2 alpha B_d + |2 alpha - 1| x scene spread) needs no extra room",
    )
    stolt_model: str = param(
        default="exact", choices=MODELS, doc="exact 2D spectrum, or paper = eqs. (14)-(15) (odd terms >= 5 dropped)"
    )
    stolt_kernel: str = param(default="knab", choices=KERNELS, doc="Stolt interpolation kernel")
    stolt_length: int = param(default=8, ge=1, le=64, doc="taps of the sinc/knab Stolt kernel")
    stolt_oversampling: float | None = param(
        default=None, gt=1, doc="Knab design oversampling; default: range window / scene depth, clipped to [1.2, 4]"
    )
    range_filter: str = param(default="flat", choices=("flat", "phase"), doc="range matched filter")
    reference_range: float | None = param(
        "length",
        default=None,
        gt=0,
        doc="range of the bulk compression and centre of the output range "
        "window; default: the middle of the coarse step's scene box",
    )
    flow1_geometry: str = param(
        default="resample",
        choices=("resample", "none"),
        doc="flow 1: resample azimuth to undo the x_n^2 sin(theta)/r shift of edge targets",
    )
    output_frame: str = param(default="squint", choices=("squint", "lrwc"), doc="image frame (see module doc)")
    crop_margin: float = param("length", default=150.0, ge=0, doc="image kept around the coarse step's scene box")
    window_margin: float = param(default=1.15, ge=1.0, doc="flow 2: time/frequency window over the needed span")
    precision: str = param(
        default="float32",
        choices=PRECISIONS,
        doc="intermediate complex precision of data and FFTs (phases are float64, reduced to "
        "cycles and turned into complex64 phasors, < 1e-6 rad)",
    )
    block_rows: int = param(default=128, ge=1, doc="azimuth-frequency rows per Stolt block")
    block_range: int = param(default=256, ge=1, doc="range bins per azimuth block")
    max_samples: int = param(default=600_000_000, ge=1, doc="refuse working arrays larger than this")


def cycles(phase: np.ndarray) -> np.ndarray:
    """Phase (rad, float64) reduced to cycles in [0, 1) for :func:`sarproc.dsp.phasor.unit_phasor`."""
    c = np.multiply(phase, 1.0 / (2 * np.pi))
    c -= np.floor(c)
    return c


def phasor(phase: np.ndarray) -> np.ndarray:
    """exp(j phase) as complex64 from a float64 phase (float32 cos/sin of the reduced phase, < 1e-6 rad)."""
    return unit_phasor(cycles(phase))


def _alternate(x: np.ndarray, axis: int, start: int) -> None:
    """x[..., start::2, ...] *= -1 along ``axis``, in place (2D: rows in parallel)."""
    if x.ndim == 2:
        compiled.negate_alternate_2d(x, axis, start)
        return
    idx = [slice(None)] * x.ndim
    idx[axis] = slice(start, None, 2)
    x[tuple(idx)] *= -1


def _centred(transform: Callable[..., np.ndarray], x: np.ndarray, axis: int, overwrite: bool) -> np.ndarray:
    n = x.shape[axis]
    if n % 2:
        return sfft.fftshift(transform(sfft.ifftshift(x, axes=axis), axis=axis, workers=-1), axes=axis)
    # even n: the two shifts are the modulations (-1)^n before and (-1)^(k - n/2) after the transform, done
    # in place (no rolled copies of the array)
    y = x if overwrite else x.copy()
    _alternate(y, axis, 1)
    y = transform(y, axis=axis, workers=-1, overwrite_x=True)
    _alternate(y, axis, (n // 2 + 1) % 2)
    return y


def cfft(x: np.ndarray, axis: int = 0, overwrite: bool = False) -> np.ndarray:
    """Centred DFT: time index centred on N//2 -> frequency index centred on N//2."""
    return _centred(sfft.fft, x, axis, overwrite)


def cifft(x: np.ndarray, axis: int = 0, overwrite: bool = False) -> np.ndarray:
    return _centred(sfft.ifft, x, axis, overwrite)


def centred(n: int, step: float) -> np.ndarray:
    return (np.arange(n) - n // 2) * step


def depth_of_focus_half_width(radar: RadarMetadata, resolution: float) -> float:
    """|x_n| limit of eq. (17): 2 rho_a^2 cos^2(theta) / (lambda |sin(theta)|), m (inf at zero squint)."""
    s = abs(math.sin(radar.squint))
    if s < 1e-12:
        return math.inf
    return 2 * resolution**2 * math.cos(radar.squint) ** 2 / (radar.wavelength * s)


def scene_and_focus_depth(radar: RadarMetadata, box: Sequence[float], n_pulses: int) -> tuple[float, float]:
    """(depth-of-focus half width, scene half width) of eq. (17), m, for the coarse product's scene box
    and aperture; flow 1 when the scene fits (also the plan's flow, sarproc.cli.stage)."""
    r_c = 0.5 * (box[2] + box[3])
    K_c = -2 * radar.velocity**2 * math.cos(radar.squint) ** 2 / (radar.wavelength * r_c)
    rho_a = radar.velocity / (abs(K_c) * (n_pulses / radar.prf))
    return depth_of_focus_half_width(radar, rho_a), max(abs(box[0]), abs(box[1]))


def _range_filter(radar: RadarMetadata, f_r: np.ndarray, kind: str) -> np.ndarray:
    band = np.abs(f_r) <= radar.bandwidth / 2
    if kind == "phase":
        return np.where(band, np.exp(1j * np.pi * f_r**2 / radar.chirp_rate), 0)
    h, _ = chirp_replica(radar)
    n = len(f_r)
    if len(h) > n:
        raise InputError(f"fine-focus: the chirp ({len(h)} samples) is longer than the range FFT ({n})")
    H = sfft.fftshift(replica_spectrum(radar, n))  # on the centred f_r grid
    return np.where(band, 1.0 / np.where(band, H, 1), 0) * np.count_nonzero(h)


def _residual_doppler(
    S: np.ndarray, t_c: np.ndarray, f_r: np.ndarray, k: float, beta: np.ndarray, prf: float
) -> np.ndarray:
    """Apply the missing part of eq. (7) after the coarse step (exact when nothing folded).

    (s e^{j2 pi beta t}) * h (t') = e^{j2 pi beta t'} e^{-j pi beta^2/k} (s * h)(t' - beta/k). The pulses only
    know beta modulo the PRF, so beta is wrapped to [-PRF/2, PRF/2); the modulation is applied first
    (it centres the spectrum on the F_a'' grid), then the circular shift by beta/k (FFT phase ramp).
    S: (n_t', n_fr) in the (t', f_r) domain, modified in place and returned.
    """
    M = S.shape[0]
    beta = np.mod(beta + prf / 2, prf) - prf / 2
    f_a = centred(M, 1.0 / (M * (t_c[1] - t_c[0])))
    S *= np.exp(2j * np.pi * np.mod(t_c[:, None] * beta[None, :], 1.0))
    X = cfft(S, 0, overwrite=True)
    X *= np.exp(-2j * np.pi * np.mod(f_a[:, None] * beta[None, :] / k, 1.0))
    S = cifft(X, 0, overwrite=True)
    S *= np.exp(1j * np.pi * np.mod(beta**2 / k, 2.0))[None, :]
    return S


@dataclasses.dataclass(frozen=True)
class CoarseGrid:
    """What fine focusing reads off a coarse product: its grids, deramp rate, scene box and aperture."""

    deramp_rate: float  # k, Hz/s (eq. 12's reference)
    doppler_correction: str  # preprocess method: nonlinear, linear or none
    azimuth_time: np.ndarray  # t', s, centred on 0
    range_time: np.ndarray  # tau, s
    scene_box: tuple[float, float, float, float]  # (x_min, x_max, r_min, r_max), m
    aperture: tuple[float, float]  # first and last pulse time, s
    n_pulses: int
    total_doppler_bandwidth: float  # Hz, of the scene (flow 1's resampling kernel design); default F_a'' / 1.2

    @property
    def scene_centre_range(self) -> float:
        return 0.5 * (self.scene_box[2] + self.scene_box[3])


@dataclasses.dataclass(frozen=True)
class FlowChoice:
    """Eq. (17): flow 1 when the scene fits the depth of focus, else flow 2 (or as configured)."""

    flow: int
    depth_of_focus_half_width: float  # m
    scene_half_width: float  # m
    doppler_rate: float  # K at the scene centre range, Hz/s


@dataclasses.dataclass
class RangeDoppler:
    """The range-Doppler data of eq. (16) after Stolt: envelope at r_LRWC, azimuth phase -r_0 G_c(f_a)."""

    data: np.ndarray  # (n_azimuth_frequencies, N) complex, (f_a, r)
    azimuth_frequency: np.ndarray  # f_a, Hz, centred
    range_frequency: np.ndarray  # f_r, Hz, centred
    slant_range: np.ndarray  # r, m, centred on r_ref
    stolt_oversampling: float
    stolt_masked_fraction: float


@dataclasses.dataclass
class AzimuthFocused:
    """The image after azimuth compression, before the range geometry: rows at azimuth ``x``."""

    data: np.ndarray  # (n_x, N) complex
    x: np.ndarray  # azimuth, m
    alpha: float | None  # NLCS scaling (flow 2), None for flow 1
    info: dict  # flow 2's recorded NLCS figures (history), empty for flow 1


def coarse_grid(coarse: Product) -> CoarseGrid:
    """The coarse product's grids and attributes fine focusing needs; a product not made by coarse-focus is
    refused."""
    if coarse.kind != "coarse":
        raise InputError(f"fine-focus needs a 'coarse' product, got {coarse.kind!r}")
    at = coarse.attrs
    for key in ("deramp_rate", "azimuth_sampling_rate", "aperture_start", "aperture_end", "n_pulses", "scene_box"):
        if key not in at:
            raise InputError(f"fine-focus: coarse product lacks attribute {key!r} (not made by coarse-focus?)")
    t_c = np.asarray(coarse.coords["azimuth_time"], float)
    dtc = t_c[1] - t_c[0]
    if abs(t_c[len(t_c) // 2]) > 1e-9 * max(1.0, abs(dtc)) * 1e6:
        raise InputError("fine-focus: the coarse azimuth grid is not centred on t' = 0")
    box = [float(b) for b in at["scene_box"]]
    return CoarseGrid(
        deramp_rate=float(at["deramp_rate"]),
        doppler_correction=at.get("doppler_correction", "none"),
        azimuth_time=t_c,
        range_time=np.asarray(coarse.coords["range_time"], float),
        scene_box=(box[0], box[1], box[2], box[3]),
        aperture=(float(at["aperture_start"]), float(at["aperture_end"])),
        n_pulses=int(at["n_pulses"]),
        total_doppler_bandwidth=float(at.get("total_doppler_bandwidth", (1.0 / dtc) / 1.2)),
    )


def choose_flow(radar: RadarMetadata, grid: CoarseGrid, params: FineFocusParams) -> FlowChoice:
    """Eq. (17)'s choice of flow for this scene box and aperture (``params.flow`` overrides it)."""
    v, c_th = radar.velocity, math.cos(radar.squint)
    K_c = -2 * v**2 * c_th**2 / (radar.wavelength * grid.scene_centre_range)
    half_adof, scene_half = scene_and_focus_depth(radar, grid.scene_box, grid.n_pulses)
    return FlowChoice(params.flow or (1 if scene_half <= half_adof else 2), half_adof, scene_half, K_c)


def range_padded_length(radar: RadarMetadata, n_range: int) -> int:
    """Range FFT length: the samples plus a chirp, against circular wrap of the chirp."""
    n_chirp = int(math.ceil(radar.pulse_duration * radar.range_sampling_rate))
    return sfft.next_fast_len(n_range + n_chirp)


def two_dimensional_spectrum(
    data: np.ndarray, grid: CoarseGrid, radar: RadarMetadata, N: int, cdt: type[np.complexfloating]
) -> np.ndarray:
    """Step 1: range FFT (zero padded to ``N``), eq. (7)'s missing part for the baseline corrections, then
    the centred azimuth DFT: the (f_a, f_r) spectrum, both axes centred."""
    M = len(grid.azimuth_time)
    f_r = centred(N, radar.range_sampling_rate / N)
    S = np.empty((M, N), cdt)  # zero padded in one parallel copy, transformed in place
    if N % 2 == 0:
        pad_rows(data, S, 1)  # fftshift of the spectrum as (-1)^n in time
        S = sfft.fft(S, axis=1, workers=-1, overwrite_x=True)
    else:
        pad_rows(data, S, -1)
        S = sfft.fftshift(sfft.fft(S, axis=1, workers=-1, overwrite_x=True), axes=1)
    method = grid.doppler_correction
    if method != "nonlinear":
        beta = correction_frequency(radar, f_r, "nonlinear") - correction_frequency(radar, f_r, method)
        S = _residual_doppler(S, grid.azimuth_time, f_r, grid.deramp_rate, beta, radar.prf)
    return cfft(S, 0, overwrite=True)


def _check_range_window(box: tuple[float, float, float, float], s_th: float, r_ref: float, half_window: float) -> None:
    """The scene's slant ranges (squint-shifted over its azimuth extent) must fit the range window."""
    if (
        max(
            abs(box[2] + min(0, box[0] * s_th, box[1] * s_th) - r_ref),
            abs(box[3] + max(0, box[0] * s_th, box[1] * s_th) - r_ref),
        )
        > half_window
    ):
        raise InputError(
            f"fine-focus: the scene (r_0 in [{box[2]:.0f}, {box[3]:.0f}] m) does not fit the "
            f"{2 * half_window:.0f} m range window centred on r_ref = {r_ref:.0f} m"
        )


def stolt_to_range_doppler(
    S: np.ndarray,
    grid: CoarseGrid,
    radar: RadarMetadata,
    model: SpectrumModel,
    r_ref: float,
    params: FineFocusParams,
    cdt: type[np.complexfloating],
    progress: Progress | None,
) -> RangeDoppler:
    """Step 2, in place on ``S`` (f_a, f_r): range compression, bulk reference-function multiply at
    ``r_ref``, the modified Stolt mapping (eq. 15) and the range IFFT, block by block of azimuth rows."""
    M, N = S.shape
    fs = radar.range_sampling_rate
    f_r = centred(N, fs / N)
    f_a = centred(M, (1.0 / (grid.azimuth_time[1] - grid.azimuth_time[0])) / M)
    box = grid.scene_box
    r = r_ref + centred(N, C / (2 * fs))
    depth = max(box[3] - box[2], 1.0) + abs(math.sin(radar.squint)) * (box[1] - box[0])
    over = params.stolt_oversampling or float(
        np.clip((N / fs) / (2 * (depth + 4 * C / (2 * radar.bandwidth)) / C), 1.2, 4.0)
    )
    _check_range_window(box, math.sin(radar.squint), r_ref, (N / 2) * C / (2 * fs))
    hr = _range_filter(radar, f_r, params.range_filter) * np.exp(-2j * np.pi * f_r * grid.range_time[0])
    hr = hr.astype(cdt)
    f_abs = radar.carrier_frequency + f_r
    masked = 0
    stolt_buf = np.empty((min(params.block_rows, M), N), cdt)  # the resampled block, reused
    blocks = range(0, M, params.block_rows)
    for s in progress(blocks) if progress is not None else blocks:
        e = min(s + params.block_rows, M)
        blk = S[s:e]  # in place: rewritten below
        model.rotate(blk, f_abs, f_a[s:e], r_ref, pre=hr)  # fused: hr exp(j r_ref G), no field stored
        blk, m_ = stolt_resample(
            blk,
            f_r,
            f_a[s:e],
            model,
            params.stolt_kernel,
            params.stolt_length,
            oversampling=over,
            band=radar.bandwidth,
            out=stolt_buf[: e - s],
        )
        masked += m_
        gc, okc = model.Gc(f_a[s:e])
        fac = np.where(okc, np.exp(-1j * np.mod(r_ref * gc, 2 * np.pi)), 0).astype(cdt)
        if N % 2 == 0:  # the centred range IFFT with its (-1)^n modulations fused
            scale_rows(blk, fac, 1)  # into the row factor and the write-back
            blk = sfft.ifft(blk, axis=1, workers=-1, overwrite_x=True)
            copy_rows(blk, S[s:e], (N // 2 + 1) % 2)
        else:
            blk *= fac[:, None]
            S[s:e] = cifft(blk, 1, overwrite=True)
    return RangeDoppler(S, f_a, f_r, r, over, masked / float(M * N))


def flow1_compress(
    rd: RangeDoppler,
    grid: CoarseGrid,
    radar: RadarMetadata,
    model: SpectrumModel,
    params: FineFocusParams,
    cdt: type[np.complexfloating],
    blocks: Iterable[int],
    progress: Progress | None,
) -> AzimuthFocused:
    """Step 3, flow 1, in place on ``rd.data``: eq. (12)'s reference removed and exp(+j r G_c(f_a)) at every
    range bin (direct compression, inside the depth of focus of eq. 17), then the optional azimuth
    resampling that undoes the x_n^2 sin(theta) / r shift of edge targets; rows cropped to the scene box."""
    RD, f_a, r = rd.data, rd.azimuth_frequency, rd.slant_range
    N = RD.shape[1]
    t_c = grid.azimuth_time
    gc, okc = model.Gc(f_a)
    ref = np.exp(1j * np.pi * f_a**2 / grid.deramp_rate)  # removes eq. (12)'s reference
    for s in blocks:
        e = min(s + params.block_range, N)
        blk = RD[:, s:e] * np.where(okc, ref, 0)[:, None].astype(cdt)
        multiply_separable_phase(blk, np.where(okc, gc, 0)[None, :], r[None, s:e])
        RD[:, s:e] = cifft(blk, 0, overwrite=True)
    x = radar.velocity * t_c
    keep = (x >= grid.scene_box[0] - params.crop_margin) & (x <= grid.scene_box[1] + params.crop_margin)
    if params.flow1_geometry == "resample":
        _flow1_resample(RD, x, keep, r, radar, grid, params, progress)
    return AzimuthFocused(RD[keep], x[keep], None, {})


def _flow1_resample(
    RD: np.ndarray,
    x: np.ndarray,
    keep: np.ndarray,
    r: np.ndarray,
    radar: RadarMetadata,
    grid: CoarseGrid,
    params: FineFocusParams,
    progress: Progress | None,
) -> None:
    """Flow 1 puts a target at x_n + x_n^2 sin(theta) / r: the residual quadratic phase x_n sin(theta) g2 f_a^2
    is linear around the target's Doppler centre -K t_n (spotlight); resample the kept rows back, in place."""
    s_th = math.sin(radar.squint)
    Fa = 1.0 / (grid.azimuth_time[1] - grid.azimuth_time[0])
    N = RD.shape[1]
    idx = np.flatnonzero(keep)
    xs = x[idx]
    resample_blocks = range(0, N, params.block_range)  # a third bar: the geometric resampling
    for s in progress(resample_blocks) if progress is not None else resample_blocks:
        e = min(s + params.block_range, N)
        src = xs[:, None] + xs[:, None] ** 2 * s_th / r[None, s:e]
        pos = (src - x[0]) / (x[1] - x[0])
        RD[idx, s:e] = resample_rows(
            RD[:, s:e].T,
            pos.T,
            "knab",
            16,
            oversampling=max(1.1, Fa / max(grid.total_doppler_bandwidth, 1.0)),
        ).T


def squint_frame_support_extent(radar: RadarMetadata, grid: CoarseGrid, doppler_rate: float) -> float:
    """Azimuth extent (cycles/m) of a target's support in the squint frame: its Doppler band |K(r)| T / v (widest
    at the scene box's near range, K ~ 1/r) plus the shear of the range shift by -x_n sin(theta), which moves
    each range frequency f_r of the band B by 2 f_r sin(theta) / c along azimuth: + 2 B |sin(theta)| / c."""
    T_ap = grid.n_pulses / radar.prf
    r_near = max(grid.scene_box[2], 1e-9)
    doppler = abs(doppler_rate) * grid.scene_centre_range / r_near * T_ap / radar.velocity
    return doppler + 2 * radar.bandwidth * abs(math.sin(radar.squint)) / C


def to_output_frame(
    focused: AzimuthFocused,
    range_frequency: np.ndarray,
    slant_range: np.ndarray,
    grid: CoarseGrid,
    radar: RadarMetadata,
    params: FineFocusParams,
    doppler_rate: float,
) -> tuple[np.ndarray, SquintFrame | SquintLrwcFrame, np.ndarray, np.ndarray]:
    """Step 4: the range geometry (squint frame: every azimuth line shifted by -x_n sin(theta), the range phase
    factor of sec. 4.2; lrwc: left as is) and the crop to the scene box. Returns (image, frame, azimuths, ranges).

    The shift shears each target's support along azimuth (:func:`squint_frame_support_extent`); where the
    focused azimuth spacing would not sample it SUPPORT_WRAP_MARGIN x over (as backproject's default grid), the
    lrwc image, whose own band fits, is first upsampled in azimuth by FFT zero-padding (Session 42 new-user
    trial, row 1: at 55 deg the 9.47 m spacing sampled 0.106 cycles/m of a 0.160 cycles/m support, and
    evaluate read the wrapped responses at IRW/theory 0.29-0.32, PSLR -0.6..-3.7 dB)."""
    img, x, f_r, r = focused.data, focused.x, range_frequency, slant_range
    th, box = radar.squint, grid.scene_box
    s_th = math.sin(th)
    if params.output_frame == "squint":
        img, x = _sample_sheared_support(
            img, x, SUPPORT_WRAP_MARGIN * squint_frame_support_extent(radar, grid, doppler_rate)
        )
        spec = cfft(img, 1, overwrite=True)
        multiply_separable_phase(
            spec,
            [2 * x * s_th / C, np.mod(4 * np.pi * radar.carrier_frequency * x * s_th / C, 2 * np.pi)],
            [2 * np.pi * f_r, np.ones_like(f_r)],
        )
        img = cifft(spec, 1, overwrite=True)
        frame: SquintFrame | SquintLrwcFrame = SquintFrame(th, radar.altitude)
        rlo, rhi = box[2] - params.crop_margin, box[3] + params.crop_margin
    else:
        frame = _lrwc_frame(th, radar.altitude)
        rlo = box[2] + min(box[0] * s_th, box[1] * s_th) - params.crop_margin
        rhi = box[3] + max(box[0] * s_th, box[1] * s_th) + params.crop_margin
    keep_r = (r >= rlo) & (r <= rhi)
    cols = np.flatnonzero(keep_r)  # r ascending: one run of columns
    img, finite = crop_columns(img, int(cols[0]) if cols.size else 0, int(cols[-1]) + 1 if cols.size else 0)
    # checked on what is handed out (squint frame: the range FFTs above carry any NaN into every row kept)
    if not finite:
        raise ProcessingError("fine-focus: the image has NaN/Inf values (numerical breakdown)")
    return img, frame, x, r[keep_r]


def _sample_sheared_support(img: np.ndarray, x: np.ndarray, rate: float) -> tuple[np.ndarray, np.ndarray]:
    """(image, azimuths) with at least ``rate`` samples per metre in azimuth: the rows FFT-upsampled (band-limited,
    baseband) to the fewest rows that reach it, or as given where the spacing already does."""
    n = img.shape[0]
    if n < 2 or rate <= 0:
        return img, x
    dx = float(x[1] - x[0])
    if rate * abs(dx) <= 1.0:
        return img, x
    m = math.ceil(n * rate * abs(dx))
    log.info(
        "fine-focus: squint frame: azimuth spacing %.3f m samples %.4f cycles/m of a %.4f cycles/m sheared support "
        "(x%.1f margin); upsampled to %.3f m (%d -> %d rows)",
        abs(dx),
        1 / abs(dx),
        rate / SUPPORT_WRAP_MARGIN,
        SUPPORT_WRAP_MARGIN,
        abs(dx) * n / m,
        n,
        m,
    )
    up = upsample_range(np.ascontiguousarray(img.T), 1, length=m).T
    return np.ascontiguousarray(up.astype(img.dtype, copy=False)), x[0] + np.arange(m) * (dx * n / m)


def target_theory(
    coarse: Product, frame: SquintFrame | SquintLrwcFrame, choice: FlowChoice, grid: CoarseGrid
) -> np.ndarray:
    """The targets table in the image frame with each target's own theory: its Doppler bandwidth |K(r_0)| T at
    its own closest-approach range (K ~ 1/r_0) over a flat aperture, and the flat range band."""
    radar = coarse.radar
    v, T_ap = radar.velocity, grid.n_pulses / radar.prf
    K_c, r_c = choice.doppler_rate, grid.scene_centre_range
    targets = targets_in_frame(coarse.targets, frame)
    r0 = targets_in_frame(coarse.targets, SquintFrame(radar.squint, radar.altitude))["range"]
    flat = window_theory("none")
    fill_target_theory(
        targets,
        ("azimuth", "range"),
        [
            [flat.scaled(v / (abs(K_c) * r_c / max(float(r_t), 1e-9) * T_ap)), flat.scaled(C / (2 * radar.bandwidth))]
            for r_t in r0
        ],
    )
    return targets


def fine_focus(
    coarse: Product, params: FineFocusParams = FineFocusParams(), progress: Progress | None = None
) -> Product:
    """``coarse`` product -> focused ``image`` product in the squint frame (see module doc)."""
    from sarproc.product.io import history_entry

    grid = coarse_grid(coarse)
    radar = coarse.radar
    cdt = complex_dtype(params.precision)
    r_ref = params.reference_range or grid.scene_centre_range
    model = SpectrumModel(radar.carrier_frequency, radar.velocity, radar.squint, params.stolt_model)
    choice = choose_flow(radar, grid, params)

    M, N = len(grid.azimuth_time), range_padded_length(radar, len(grid.range_time))
    if params.max_samples < M * N:
        raise InputError(f"fine-focus: working array {M} x {N} exceeds fine_focus.max_samples {params.max_samples}")
    S = two_dimensional_spectrum(coarse.data, grid, radar, N, cdt)
    rd = stolt_to_range_doppler(S, grid, radar, model, r_ref, params, cdt, progress)
    del S

    azimuth_blocks: Iterable[int] = range(0, N, params.block_range)  # a second progress bar: azimuth compression
    if progress is not None:
        azimuth_blocks = progress(azimuth_blocks)
    if choice.flow == 1:
        focused = flow1_compress(rd, grid, radar, model, params, cdt, azimuth_blocks, progress)
    else:
        focused = flow2_compress(rd, grid, radar, model, params, cdt, azimuth_blocks)
    f_r, r, over, masked = rd.range_frequency, rd.slant_range, rd.stolt_oversampling, rd.stolt_masked_fraction
    del rd  # the range-Doppler array is no longer needed (flow 1's image is a copy of its rows)
    img, frame, azimuths, ranges = to_output_frame(focused, f_r, r, grid, radar, params, choice.doppler_rate)

    attrs = {
        "frame": frame.spec,
        "theoretical_irw": [
            SINC_IRW_FACTOR * radar.velocity / (abs(choice.doppler_rate) * (grid.n_pulses / radar.prf)),
            SINC_IRW_FACTOR * C / (2 * radar.bandwidth),
        ],
        "flow": int(choice.flow),
        "doppler_correction": grid.doppler_correction,
        "alpha": focused.alpha if focused.alpha is not None else 0.0,
        "stolt_masked_fraction": masked,
        "depth_of_focus_half_width": choice.depth_of_focus_half_width,
    }
    targets = target_theory(coarse, frame, choice, grid)
    out = coarse.derive(
        "image", img, ("azimuth", "range"), {"azimuth": azimuths, "range": ranges}, attrs=attrs, targets=targets
    )
    record_ridge_angles(out)  # evaluate reads them rather than sighting the pulses again
    info = {
        "flow": choice.flow,
        "depth_of_focus_half_width": choice.depth_of_focus_half_width,
        "scene_half_width": choice.scene_half_width,
        "stolt_oversampling": over,
        "stolt_masked_fraction": masked,
        **focused.info,
    }
    entry = as_dict(params)
    entry.update({k_: (float(v_) if isinstance(v_, (float, np.floating)) else v_) for k_, v_ in info.items()})
    entry["resolved_flow"] = int(choice.flow)
    entry["resolved_reference_range"] = r_ref
    entry["azimuth_edge_aliases"] = _warn_edge_aliases(out)
    out.history.append(history_entry("fine_focus", entry))
    return out


def _warn_edge_aliases(image: Product) -> list[dict]:
    """Warn of every target alias whose azimuth side lobes enter the image from beyond its azimuth edge
    (:func:`sarproc.focus.backprojection_alias.image_edge_aliases`): the image spans the PRF's unambiguous extent,
    so a target near one edge has an alias just beyond the other, its side lobes in the data as in any image of
    them (the exact backprojection's too), at -31 dB on configs/an2012_exp1_small.yaml. Returns them for the
    history."""
    from sarproc.focus.backprojection_alias import edge_alias_warning

    message, records = edge_alias_warning(image)
    if message:
        log.warning("fine-focus: %s", message, extra=IMAGE_DEFECT)
    return records


def _lrwc_frame(squint: float, altitude: float) -> SquintLrwcFrame:
    return SquintLrwcFrame(squint, altitude)


@dataclasses.dataclass(frozen=True)
class NlcsDesign:
    """Flow 2's coefficients per range bin (:mod:`sarproc.focus.squint_deramp.nlcs`) and the scene's target times."""

    coefficients: dict  # nlcs_coefficients: alpha, q2, q3, q4 (eq. 27), Y3, Y4 (eq. 24), per range bin
    positions: dict  # position_terms: a1, c2, c3 (image time of a target at t_n), per range bin
    doppler_rate: np.ndarray  # K(r), Hz/s
    range_walk: np.ndarray  # eps(r) = v sin(theta) / r, 1/s
    target_times: np.ndarray  # t_n = x / v at 33 points across the scene box, s

    @property
    def alpha(self) -> float:
        return float(self.coefficients["alpha"])


@dataclasses.dataclass(frozen=True)
class NlcsWindow:
    """Flow 2's azimuth grids (FFT order: index 0 = zero time / frequency): the compact t' spectrum zero-padded
    to ``n_padded`` samples, then ``n_scaled`` samples at ``sampling_rate`` after the chirp scaling."""

    n_padded: int  # L1: the aperture, the targets' image times and the filter's dispersion fit
    n_scaled: int  # N2: the scaled frequency span fits
    sampling_rate: float  # F2, Hz
    dispersion: float  # group-delay span of the eq. (33) filter over the band, s
    f1: np.ndarray  # (L1,) padded spectrum's frequencies, Hz
    f2: np.ndarray  # (N2,) scaled spectrum's frequencies, Hz
    t2: np.ndarray  # (N2,) image times, s
    keep: np.ndarray  # rows of the (N2,) image inside the cropped scene box, by ascending x
    x: np.ndarray  # (len(keep),) their azimuth 2 alpha v t2, m


def nlcs_design(
    slant_range: np.ndarray, radar: RadarMetadata, model: SpectrumModel, params: FineFocusParams, box: Sequence[float]
) -> NlcsDesign:
    """Flow 2's NLCS coefficients (eq. 31, ``params.nlcs_variant``) and position terms at every range bin."""
    v, th = radar.velocity, radar.squint
    s_th, c_th = math.sin(th), math.cos(th)
    r = slant_range
    _, g3 = model.taylor()
    K = -2 * v**2 * c_th**2 / (radar.wavelength * r)
    eps = v * s_th / r
    p = v * s_th * g3 / np.pi
    variant = params.nlcs_variant
    try:
        co = nlcs_coefficients(K, eps, 0.0 if variant != "modified" else p, params.alpha, variant)
    except ValueError as exc:
        raise InputError(f"fine_focus.alpha: {exc}") from None
    return NlcsDesign(co, position_terms(K, eps, p, co), K, eps, np.linspace(box[0], box[1], 33) / v)


def nlcs_window(
    design: NlcsDesign, grid: CoarseGrid, radar: RadarMetadata, params: FineFocusParams, shape: tuple[int, int]
) -> NlcsWindow:
    """Flow 2's zero padding and grids. The time window holds the aperture, the targets' image times and the
    eq. (33) filter's dispersion; the scaled band holds the frequency span over aperture times, scene positions
    and range bins (first, middle, last of the range-Doppler array's ``shape`` (M, N)); refused when the scaled
    length is too large."""
    v, co, pos, tn = radar.velocity, design.coefficients, design.positions, design.target_times
    t_c = grid.azimuth_time
    M, N = shape
    dtc = t_c[1] - t_c[0]
    Fa = 1.0 / dtc
    t_first, t_last = grid.aperture
    t = np.linspace(t_first, t_last, 65)
    spans = []
    disp = 0.0
    for j in (0, N // 2, N - 1):
        Kj = design.doppler_rate[j]
        Ka = Kj / (1 - design.range_walk[j] * tn[None, :])
        fr = Ka * (t[:, None] - tn[None, :])
        Fv = fr + co["q2"][j] * t[:, None] + 1.5 * co["q3"][j] * t[:, None] ** 2 + 2 * co["q4"][j] * t[:, None] ** 3
        spans.append(np.abs(Fv).max())
        spans.append(np.abs(fr).max())
        cj = {kk: (vv[j] if np.ndim(vv) else vv) for kk, vv in co.items() if kk != "alpha"}
        disp = max(disp, group_delay_span(-Fa / 2, Fa / 2, cj))
    F_need = 2 * max(spans) * params.window_margin
    t_img = (
        pos["a1"].max() * np.abs(tn).max()
        + np.abs(pos["c2"]).max() * tn.max() ** 2
        + np.abs(pos["c3"]).max() * np.abs(tn).max() ** 3
    )
    T_need = 2 * max(abs(t_first), abs(t_last), t_img) + 2 * disp
    T_need = max(T_need * params.window_margin, M * dtc)
    L1 = sfft.next_fast_len(int(math.ceil(T_need / dtc)))
    N2 = sfft.next_fast_len(max(L1, int(math.ceil(L1 * F_need / Fa))))
    if N2 * min(N, params.block_range) > params.max_samples or N2 > 4_000_000:
        raise InputError(
            f"fine-focus: flow 2 needs {N2} azimuth samples (alpha = {co['alpha']}, dispersion {disp:.3g} s); "
            "alpha too close to 1/2 or the scene too wide; change fine_focus.alpha or max_samples"
        )
    df = Fa / L1
    F2 = N2 * df
    t2 = sfft.fftfreq(N2, df)
    x_img = 2 * co["alpha"] * v * t2
    box = grid.scene_box
    xlim = (box[0] - params.crop_margin, box[1] + params.crop_margin)
    keep = np.flatnonzero((x_img >= xlim[0]) & (x_img <= xlim[1]))
    keep = keep[np.argsort(x_img[keep])]
    return NlcsWindow(
        L1, N2, F2, disp, sfft.fftfreq(L1, 1.0 / (L1 * df)), sfft.fftfreq(N2, 1.0 / F2), t2, keep, x_img[keep]
    )


def nlcs_compress(
    rd: RangeDoppler,
    design: NlcsDesign,
    window: NlcsWindow,
    deramp_rate: float,
    model: SpectrumModel,
    params: FineFocusParams,
    cdt: type[np.complexfloating],
    blocks: Iterable[int],
) -> np.ndarray:
    """Flow 2's block loop over range bins: eq. (12)'s reference removed in the zero-padded spectrum, eq. (24)
    (plus eq. 22 for the modified variant), eq. (27) (the chirp scaling), eq. (33) (azimuth filter); returns the
    kept image rows, (len(window.keep), N) complex64."""
    RD, r = rd.data, rd.slant_range
    M, N = RD.shape
    co, f1, f2, t2, keep = design.coefficients, window.f1, window.f2, window.t2, window.keep
    L1, N2 = window.n_padded, window.n_scaled
    g2, _ = model.taylor()
    out = np.empty((len(keep), N), np.complex64)
    pdt = np.complex64
    ref = np.exp(1j * np.mod(np.pi * f1**2 / deramp_rate, 2 * np.pi)).astype(pdt)
    gc_full, okc = model.Gc(f2)
    hopc = np.where(okc, gc_full - g2 * f2**2, 0.0)
    rows24 = [np.pi * f2**3, np.pi * f2**4] + ([hopc] if params.nlcs_variant == "modified" else [])
    rows27 = [np.pi * t2**2, np.pi * t2**3, np.pi * t2**4]
    no_factor = np.ones(0, pdt)

    nb_max = min(params.block_range, N)
    pad_buf = np.empty((nb_max, L1), cdt)
    x_buf = np.empty((nb_max, N2), cdt)
    for s in blocks:
        e = min(s + params.block_range, N)
        nb = e - s
        # the block is processed transposed, (range bins, azimuth): every FFT runs along contiguous memory
        blk = RD[:, s:e].T
        if M % 2 == 0:  # compact t' (reference in)
            comp = sfft.ifft(blk, axis=1, workers=-1)
            alt = 1  # the ifftshift, as (-1)^n after
        else:
            comp = sfft.ifft(sfft.ifftshift(blk, axes=1), axis=1, workers=-1)
            alt = -1
        # zero-padded buffers reused from block to block (the transforms below may overwrite them), each
        # filled in one parallel pass: the modulation, the zero padding and the reference multiply fused
        pad = pad_buf[:nb]
        pad_spectrum(comp, pad, no_factor, alt)
        X1 = sfft.fft(pad, axis=1, workers=-1, overwrite_x=True)
        X = x_buf[:nb]
        pad_spectrum(X1, X, ref, -1)
        # eq. (24) pi (Y3 f^3 + Y4 f^4), plus eq. (22) r hopc(f) (exact) for the modified variant
        multiply_separable_phase(X, [co["Y3"][s:e], co["Y4"][s:e], r[s:e]][: len(rows24)], rows24)
        xt = sfft.ifft(X, axis=1, workers=-1, overwrite_x=True)
        multiply_separable_phase(xt, [co["q2"][s:e], co["q3"][s:e], co["q4"][s:e]], rows27)  # eq. (27)
        X = sfft.fft(xt, axis=1, workers=-1, overwrite_x=True)
        vals, weights = _theta0_terms(f2, design.doppler_rate, co, s, e)  # eq. (33), exact
        multiply_separable_phase(X, weights, -vals)
        img = sfft.ifft(X, axis=1, workers=-1, overwrite_x=True)
        gather_columns(img, keep, out, s)  # out[:, s:e] = img[:, keep].T
    return out


def nlcs_info(design: NlcsDesign, window: NlcsWindow, velocity: float) -> dict:
    """Flow 2's figures recorded in the history: alpha, the window, the predicted residual position error."""
    pos, tn, alpha = design.positions, design.target_times, design.coefficients["alpha"]
    return {
        "alpha": float(alpha),
        "nlcs_azimuth_samples": int(window.n_scaled),
        "nlcs_time_window": float(window.n_scaled / window.sampling_rate),
        "nlcs_sampling_rate": float(window.sampling_rate),
        "nlcs_dispersion": float(window.dispersion),
        "nlcs_c3_max": float(np.abs(pos["c3"]).max()),
        "nlcs_c2_max": float(np.abs(pos["c2"]).max()),
        "nlcs_position_error_max_m": float(
            2
            * alpha
            * velocity
            * (np.abs(pos["c2"]).max() * tn.max() ** 2 + np.abs(pos["c3"]).max() * np.abs(tn).max() ** 3)
        ),
    }


def flow2_compress(
    rd: RangeDoppler,
    grid: CoarseGrid,
    radar: RadarMetadata,
    model: SpectrumModel,
    params: FineFocusParams,
    cdt: type[np.complexfloating],
    blocks: Iterable[int],
) -> AzimuthFocused:
    """Step 3, flow 2: modified NLCS azimuth compression (eqs. 22-33) in four steps: the coefficients
    (:func:`nlcs_design`), the window and grids (:func:`nlcs_window`), the block loop (:func:`nlcs_compress`)
    and the recorded figures (:func:`nlcs_info`); rows cropped to the scene box."""
    design = nlcs_design(rd.slant_range, radar, model, params, grid.scene_box)
    window = nlcs_window(design, grid, radar, params, rd.data.shape)
    img = nlcs_compress(rd, design, window, grid.deramp_rate, model, params, cdt, blocks)
    info = nlcs_info(design, window, radar.velocity)
    return AzimuthFocused(img, window.x, info["alpha"], info)


def _theta0_terms(f: np.ndarray, K: np.ndarray, co: dict, s: int, e: int) -> tuple[np.ndarray, np.ndarray]:
    """Exact eq. (33) phase for range bins s..e-1: evaluated at three nodes, quadratic in the bin index.

    Returns (vals (n_nodes, len(f)), weights (n_nodes, e - s)): theta0[i, j] = sum_a vals[a, i] weights[a, j]
    (Lagrange weights), so the field need never be stored. The coefficients vary like 1/r, so over a block
    (a few km at hundreds of km) the cubic term of the interpolation is below 1e-3 rad; the nodes themselves
    are exact (Newton, :func:`compression_phase`).
    """
    nodes = sorted({s, (s + e - 1) // 2, e - 1})
    vals = []
    for j in nodes:
        cj = {kk: float(vv[j]) for kk, vv in co.items() if kk != "alpha"}
        vals.append(compression_phase(f, float(K[j]), cj))
    idx = np.arange(s, e, dtype=float)
    weights = np.ones((len(nodes), e - s))
    for a, ja in enumerate(nodes):
        for jb in nodes:
            if jb != ja:
                weights[a] *= (idx - jb) / (ja - jb)
    return np.array(vals), weights
