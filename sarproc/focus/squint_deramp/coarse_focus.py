"""Azimuth coarse focusing by deramping / SPECAN (An et al. 2012, sec. 3.2; Lanari et al. 2001).

After the Doppler-centroid correction a target at (x_n = v t_n, r_0) has the azimuth phase
pi f_dr (t - t_n)^2 + ..., f_dr = -2 v^2 cos^2(theta) / (lambda r_0) (eqs. 3, 9). The coarse step
is the azimuth convolution of eq. (11) with the reference chirp h(t) = exp(j pi k t^2),
k = -f_dr,ref = 2 v^2 cos^2(theta) / (lambda r_ref) (eq. 10 with this file's sign convention),
evaluated as reference multiply -> DFT -> residual phase:

    y(t'_m) = sum_n s(t_n) h(t'_m - t_n)
            = exp(j pi k t'_m^2) sum_n [s(t_n) exp(j pi k t_n^2)] exp(-j 2 pi k t'_m t_n)

on the output grid t'_m = (m - M/2) / F_a'', F_a'' = M k / PRF (the DFT of length M >= n_pulses
of the deramped pulses). Because the convolution is exact, the output spectrum is the
unfolded spectrum of the input times H(f) = FT{h} (eq. 12) as long as the *deramped* signal is
not aliased: its instantaneous frequencies (Doppler + k t) over the scene, the aperture and the
range band must span less than the PRF, and F_a'' must exceed the total Doppler bandwidth.
Both are checked here from the exact geometry; :func:`doppler_budget` returns the numbers.

Input (azimuth_time, range_time); output (azimuth_time, range_time) on the t' grid, complex64.
"""

from __future__ import annotations

import dataclasses
import logging
import math

import numpy as np

from sarproc.focus.squint_deramp.preprocess import METHODS, PRECISIONS, complex_dtype
from sarproc.product import fft as sfft
from sarproc.product.config import as_dict, param
from sarproc.product.errors import IMAGE_DEFECT, InputError
from sarproc.product.frames import SquintFrame
from sarproc.product.metadata import C, RadarMetadata
from sarproc.product.model import Product
from sarproc.product.steps import ProgressFactory

log = logging.getLogger(__name__)


@dataclasses.dataclass(frozen=True)
class CoarseFocusParams:
    """``coarse_focus:`` section."""

    reference_range: float | None = param(
        "length", default=None, gt=0, doc="r_ref of eq. (10); default: the radar reference range"
    )
    azimuth_samples: int | None = param(
        default=None,
        ge=2,
        doc="DFT length M (>= pulses); default: smallest fast length with F_a'' >= bandwidth_margin x total bandwidth",
    )
    bandwidth_margin: float = param(default=1.2, ge=1.0, doc="F_a'' / total Doppler bandwidth for the default M")
    scene_azimuth_extent: float | None = param(
        "length",
        default=None,
        gt=0,
        doc="scene width along x_n used by the alias checks; default: the targets' span plus 2 scene_margin",
    )
    scene_range_extent: float | None = param(
        "length", default=None, gt=0, doc="scene depth along r_0; default: targets' span plus 2 scene_margin"
    )
    scene_margin: float = param("length", default=100.0, ge=0, doc="margin around the targets for default extents")
    fold_check: bool = param(
        default=True,
        doc=("measure where the data's deramped energy lies and detect energy that folded (nonlinear correction only)"),
    )
    on_alias: str = param(
        default="error",
        choices=("error", "warn"),
        doc="deramped spectrum wider than the PRF: refuse (error) or go on and record it (warn)",
    )
    precision: str = param(default="float32", choices=PRECISIONS, doc="intermediate complex precision")
    block_range: int = param(default=1024, ge=1, doc="range samples per FFT block (memory bound)")


def deramp_rate(radar: RadarMetadata, reference_range: float) -> float:
    """k = -f_dr,ref > 0, Hz/s (eqs. 3, 10)."""
    return 2.0 * radar.velocity**2 * math.cos(radar.squint) ** 2 / (radar.wavelength * reference_range)


def scene_box(product: Product, params: CoarseFocusParams, reference_range: float) -> tuple[float, float, float, float]:
    """(x_n min, x_n max, r_0 min, r_0 max) of the scene in the squint frame, m."""
    frame = SquintFrame(product.radar.squint, product.radar.altitude)
    xc, rc = frame.from_xyz(np.asarray(product.radar.scene_center))
    t = product.targets
    if len(t):
        xn, r0 = frame.from_xyz(np.stack([t["x"], t["y"], t["z"]], axis=-1))
    else:
        xn, r0 = np.array([float(xc)]), np.array([float(rc)])
    m = params.scene_margin
    if params.scene_azimuth_extent is not None:
        xa, xb = float(xc) - params.scene_azimuth_extent / 2, float(xc) + params.scene_azimuth_extent / 2
    else:
        xa, xb = float(xn.min()) - m, float(xn.max()) + m
    if params.scene_range_extent is not None:
        ra, rb = float(rc) - params.scene_range_extent / 2, float(rc) + params.scene_range_extent / 2
    else:
        ra, rb = float(r0.min()) - m, float(r0.max()) + m
    return xa, xb, ra, rb


def doppler_budget(
    radar: RadarMetadata, t_first: float, t_last: float, box: tuple[float, float, float, float], k: float, method: str
) -> dict:
    """Exact-geometry Doppler numbers of a scene box over the aperture.

    Returns ``total_bandwidth`` (span of the Doppler frequencies after the nonlinear correction,
    what F_a'' must hold), ``deramp_spread`` (span of Doppler + k t after the given correction) and
    ``deramp_extent``: what the PRF must hold, the larger of that spread (no two parts of the scene may
    overlap in the circular DFT window) and twice the largest magnitude after the nonlinear correction
    (the focused scene must sit inside the window centred on zero), all Hz.
    """
    xa, xb, ra, rb = box
    s, c = math.sin(radar.squint), math.cos(radar.squint)
    v = radar.velocity
    xn, r0 = np.meshgrid(np.linspace(xa, xb, 9), np.linspace(ra, rb, 5), indexing="ij")
    X, Y = (xn + r0 * s).ravel(), (r0 * c).ravel()
    t = np.linspace(t_first, t_last, 129)
    f = radar.carrier_frequency + np.array([-0.5, 0.0, 0.5])[:, None, None] * radar.bandwidth
    u = v * t[None, :, None] - X[None, None, :]
    rdot = v * u / np.sqrt(u**2 + Y[None, None, :] ** 2)  # (1, n_t, n_pts)
    beta = {"nonlinear": -2 * f * v * s / C, "linear": -2 * radar.carrier_frequency * v * s / C + 0 * f, "none": 0 * f}
    if method not in beta:
        raise InputError(f"unknown Doppler correction {method!r}; known: {list(METHODS)}")
    f_nl = -2 * f * rdot / C + beta["nonlinear"]
    f_m = -2 * f * rdot / C + beta[method]
    der = f_m + k * t[None, :, None]
    der_nl = f_nl + k * t[None, :, None]
    if method == "none":
        # the squint centroid 2 v sin(theta) / lambda is known to the pulses only modulo the PRF
        c0 = 2 * radar.carrier_frequency * v * s / C
        prf = radar.prf
        der = der - (c0 - (np.mod(c0 + prf / 2, prf) - prf / 2))
    return {
        "total_bandwidth": float(f_nl.max() - f_nl.min()),
        "doppler_min": float(f_nl.min()),
        "doppler_max": float(f_nl.max()),
        "deramp_spread": float(der.max() - der.min()),
        "deramp_extent": float(max(2 * np.abs(der_nl).max(), der.max() - der.min())),
    }


def specan(
    signal: np.ndarray,
    azimuth_time: np.ndarray,
    prf: float,
    k: float,
    n_out: int,
    precision: str = "float64",
    block_range: int = 1024,
    progress: ProgressFactory | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Discrete eq. (11): returns (y (n_out, n_rg) complex64, t' (n_out,) s)."""
    n_az, n_rg = signal.shape
    if n_out < n_az:
        raise InputError(f"coarse_focus.azimuth_samples: {n_out} is below the {n_az} pulses")
    cdt = complex_dtype(precision)
    t = np.asarray(azimuth_time, float)
    t0 = t[0]
    m = np.arange(n_out)
    half = n_out // 2
    dt_out = prf / (n_out * k)
    t_out = (m - half) * dt_out
    n = np.arange(n_az)
    # reference multiply (eq. 10) with the DFT index shift folded in, float64 phases
    pre = np.exp(1j * (np.pi * k * t**2 + 2 * np.pi * half * n / n_out)).astype(cdt)
    post = np.exp(1j * (np.pi * k * t_out**2 - 2 * np.pi * (m - half) * prf * t0 / n_out)).astype(cdt)
    out = np.empty((n_out, n_rg), np.complex64)
    starts = range(0, n_rg, block_range)
    for s in progress(starts) if progress is not None else starts:
        e = min(s + block_range, n_rg)
        blk = signal[:, s:e].astype(cdt) * pre[:, None]
        spec = sfft.fft(blk, n=n_out, axis=0, workers=-1)
        out[:, s:e] = spec * post[:, None]
    return out, t_out


def deramp_interval(
    radar: RadarMetadata, t_first: float, t_last: float, box: tuple[float, float, float, float], k: float
) -> tuple[float, float]:
    """Deramped frequencies (Hz, after the nonlinear correction, aperture mean) spanned by a scene box:
    where its responses land on the coarse grid (t' = f / k)."""
    xa, xb, ra, rb = box
    s, c = math.sin(radar.squint), math.cos(radar.squint)
    xn, r0 = np.meshgrid(np.linspace(xa, xb, 9), np.linspace(ra, rb, 5), indexing="ij")
    X, Y = (xn + r0 * s).ravel(), (r0 * c).ravel()
    t = np.linspace(t_first, t_last, 129)[:, None]
    u = radar.velocity * t - X[None, :]
    rdot = radar.velocity * u / np.sqrt(u**2 + Y[None, :] ** 2)
    der = (-2 * radar.carrier_frequency * (rdot + radar.velocity * s) / C + k * t).mean(axis=0)
    return float(der.min()), float(der.max())


@dataclasses.dataclass(frozen=True)
class DerampedResponse:
    """One response peak of the deramped spectrum (fields in the order coarse-focus records them)."""

    f_app: float  # deramped frequency where it lands, Hz
    t_app: float  # coarse time where it lands, s (f_app / k)
    n: int | None  # folds (true = apparent + n PRF); None: not resolvable with this band and aperture
    f_true: float  # Hz
    t_true: float  # s
    level_db: float  # relative to the strongest response
    inside_box: bool  # f_app within the scene box's deramped interval (+-2 coarse cells)


@dataclasses.dataclass(frozen=True)
class SubbandSpectra:
    """Deramped azimuth power of the lower and upper thirds of the range band, per coarse bin."""

    lower: np.ndarray  # (n_out,) power, DFT bins centred on n_out // 2
    upper: np.ndarray  # (n_out,)
    centres: tuple[float, float]  # mean range frequency of each sub-band, Hz
    prf: float  # Hz
    carrier_frequency: float  # Hz
    n_pulses: int

    @property
    def n_out(self) -> int:
        return len(self.lower)

    @property
    def frequencies(self) -> np.ndarray:
        """Deramped frequency of each coarse bin, Hz."""
        return (np.arange(self.n_out) - self.n_out // 2) * self.prf / self.n_out

    @property
    def cell(self) -> float:
        """Bins per coarse resolution cell (1 / aperture time)."""
        return self.n_out / self.n_pulses

    @property
    def slope(self) -> float:
        """Shift of a response between the sub-bands per Hz of its true deramped frequency."""
        return (self.centres[1] - self.centres[0]) / self.carrier_frequency

    @property
    def resolvable(self) -> bool:
        """A PRF of frequency moves a peak by >= 4 coarse cells between the sub-bands: folds can be counted."""
        return (
            self.prf * (self.centres[1] - self.centres[0]) / self.carrier_frequency * (self.n_pulses / self.prf) >= 4.0
        )


def subband_spectra(
    signal: np.ndarray, azimuth_time: np.ndarray, radar: RadarMetadata, k: float, n_out: int, max_columns: int
) -> SubbandSpectra | None:
    """:func:`specan` power of two range sub-bands (-0.45..-0.15 and 0.15..0.45 of the band), each on up to
    ``max_columns`` range frequencies; None when the band has no column in a sub-band."""
    n_az, n_rg = signal.shape
    bw = radar.bandwidth
    fr = sfft.fftfreq(n_rg, 1.0 / radar.range_sampling_rate)
    spec = sfft.fft(np.asarray(signal), axis=1, workers=-1)
    power, centre = [], []
    for lo, hi in ((-0.45, -0.15), (0.15, 0.45)):
        cols = np.flatnonzero((fr > lo * bw) & (fr < hi * bw))
        if cols.size == 0:
            return None
        cols = cols[np.linspace(0, cols.size - 1, min(cols.size, max_columns)).round().astype(int)]
        y, _ = specan(spec[:, cols], azimuth_time, radar.prf, k, n_out, "float32")
        power.append((np.abs(y) ** 2).sum(axis=1))
        centre.append(float(fr[cols].mean()))
    return SubbandSpectra(power[0], power[1], (centre[0], centre[1]), radar.prf, radar.carrier_frequency, n_az)


def response_peaks(total: np.ndarray, cell: float, level_db: float) -> list[int]:
    """Local maxima of the power (over +-3 coarse cells, circular) above ``level_db`` of the strongest, strongest
    first, without the side lobes of a 10x stronger peak within 12 cells."""
    n_out, half = len(total), len(total) // 2
    w = max(1, int(round(3 * cell)))
    padded = np.concatenate([total[-w:], total, total[:w]])
    local_max = np.lib.stride_tricks.sliding_window_view(padded, 2 * w + 1).max(axis=1) == total
    peaks = np.flatnonzero(local_max & (total >= total.max() * 10 ** (level_db / 10)))
    accepted: list[int] = []
    for i in peaks[np.argsort(total[peaks])[::-1]]:  # side lobes of a much stronger nearby peak are not responses
        near = [j for j in accepted if abs((i - j + half) % n_out - half) < 12 * cell and total[j] > 10 * total[i]]
        if not near:
            accepted.append(int(i))
    return accepted


def centroid_frequency(sp: SubbandSpectra, i: int, r: int) -> float:
    """True deramped frequency of peak ``i`` (Hz) from the shift of the sub-bands' power centroids within +-r
    bins of it."""
    window = np.arange(-r, r + 1)
    idx = (i + window) % sp.n_out
    f_win = sp.frequencies[i] + window * sp.prf / sp.n_out
    c_lo, c_hi = (np.sum(p[idx] * f_win) / np.sum(p[idx]) for p in (sp.lower, sp.upper))
    return (c_hi - c_lo) / sp.slope


def subband_peak_frequency(sp: SubbandSpectra, i: int) -> float:
    """The same from the shift of the sub-bands' own peaks near peak ``i`` (parabolic refinement), Hz."""
    n_out, prf = sp.n_out, sp.prf
    r = int(math.ceil(4 * prf * abs(sp.slope) * n_out / prf + 3 * sp.cell))
    window = np.arange(-r, r + 1)
    pos = []
    for p in (sp.lower, sp.upper):
        v = p[(i + window) % n_out]
        j = int(np.argmax(v))
        frac = 0.0
        if 0 < j < len(v) - 1:
            d = v[j - 1] - 2 * v[j] + v[j + 1]
            frac = 0.5 * (v[j - 1] - v[j + 1]) / d if d < 0 else 0.0
        pos.append((window[j] + frac) * prf / n_out)
    return (pos[1] - pos[0]) / sp.slope


def fold_count(sp: SubbandSpectra, total: np.ndarray, i: int, accepted: list[int], reach: int) -> int:
    """Folds of peak ``i`` (0: none claimed). The centroid window is +-``reach`` bins, twice that for a smeared
    response (far outside the window its FM rate differs from the reference) unless another comparable
    response lies in the wider window (its energy would bias the centroids); a fold is claimed only when it is
    clean and the sub-bands' own peaks say the same (no false alarm from neighbours' smeared energy)."""
    n_out, half, prf = sp.n_out, sp.n_out // 2, sp.prf
    f_app = float(sp.frequencies[i])
    crowded = any(
        reach < abs((i - j + half) % n_out - half) <= 2 * reach and total[j] >= total[i] / 2 for j in accepted if j != i
    )
    n = 0
    for r in (reach,) if crowded else (reach, 2 * reach):
        f_est = centroid_frequency(sp, i, r)
        n = int(round((f_est - f_app) / prf))
        if n != 0 and abs(f_est - f_app - n * prf) > prf / 4:  # not a clean fold: no claim
            n = 0
        if n:
            break
    if n and int(round((subband_peak_frequency(sp, i) - f_app) / prf)) != n:
        n = 0
    return n


def deramped_folds(
    signal: np.ndarray,
    azimuth_time: np.ndarray,
    radar: RadarMetadata,
    k: float,
    n_out: int,
    box_interval: tuple[float, float],
    level_db: float = -30.0,
    max_columns: int = 96,
) -> list[DerampedResponse]:
    """Where the data's deramped energy lies, and which of it folded (data-driven, issue 9).

    The deramped azimuth spectrum of two range sub-bands (lower and upper third of the chirp band) is
    formed with :func:`specan` on up to ``max_columns`` range frequencies each (:func:`subband_spectra`).
    After the nonlinear correction a response's deramped frequency scales with the carrier plus range
    frequency, so a response whose true deramped frequency is f = f_app + n PRF (folded n times) moves by
    f x (band separation) / f_c between the two sub-bands: the shift of the sub-bands' power centroids
    within +-PRF/10 of a peak (+-PRF/5 for smeared responses with no comparable neighbour there) measures
    f, hence n, and a fold is claimed only when the shift of the sub-bands' own peaks gives the same n
    (:func:`fold_count`). That is decidable when a PRF of frequency moves a peak by at least 4 coarse
    resolution cells between the sub-bands (PRF x band separation / f_c x aperture time >= 4); otherwise
    only the energy outside the box is reported (``n`` None).

    Returns one :class:`DerampedResponse` per response peak above ``level_db`` (relative to the strongest),
    strongest first, at most 32.
    """
    sp = subband_spectra(signal, azimuth_time, radar, k, n_out, max_columns)
    if sp is None:
        return []
    total = sp.lower + sp.upper
    if not total.max() > 0:
        return []
    accepted = response_peaks(total, sp.cell, level_db)
    reach = max(int(round(20 * sp.cell)), int(round(0.1 * n_out)))  # +-PRF/10 around a peak, >= 20 cells
    aperture = sp.n_pulses / sp.prf
    freq = sp.frequencies
    out: list[DerampedResponse] = []
    for i in accepted[:32]:
        f_app = float(freq[i])
        n = fold_count(sp, total, i, accepted, reach) if sp.resolvable else None
        f_true = f_app + (n or 0) * sp.prf
        if any(o.n == n and abs(o.f_app - f_app) <= reach * sp.prf / n_out for o in out):
            continue  # another peak of the same (smeared) response
        out.append(
            DerampedResponse(
                f_app=f_app,
                t_app=f_app / k,
                n=n,
                f_true=f_true,
                t_true=f_true / k,
                level_db=float(10 * np.log10(total[i] / total.max())),
                inside_box=bool(box_interval[0] - 2 / aperture <= f_app <= box_interval[1] + 2 / aperture),
            )
        )
    return out


def _fold_messages(
    found: list[DerampedResponse], radar: RadarMetadata, k: float, box: tuple[float, float, float, float]
) -> tuple[list[str], list[str]]:
    """(problems, notes) worded from :func:`deramped_folds`; x_n is read as v t' (flow 1's axis)."""
    v, prf = radar.velocity, radar.prf
    where = f"the scene box x_n in [{box[0]:.0f}, {box[1]:.0f}] m"
    problems, notes = [], []
    for f in found:
        if f.n:
            problems.append(
                f"deramped energy at t' = {f.t_app:.4g} s ({f.level_db:.1f} dB below the strongest response) is "
                f"a fold: its range-band slope puts it {f.n:+d} PRF away at {f.f_true:.1f} Hz, outside the "
                f"deramped window +-{prf / 2:.1f} Hz; cause: a scatterer at x_n ~ {v * f.t_true:.0f} m, outside "
                f"{where}; fine focus would process it with a Doppler {f.n:+d} PRF off, so it is not imaged at "
                f"x_n ~ {v * f.t_true:.0f} m but lands near x_n ~ {v * f.t_app:.0f} m (a ghost) or smeared. "
                "Raise the PRF or remove the scatterer from the data "
                "(a larger box does not help: the window is the PRF)"
            )
        elif f.n is None and not f.inside_box and f.level_db >= -20.0:  # not a box-edge target's smear
            notes.append(
                f"deramped energy at t' = {f.t_app:.4g} s ({f.level_db:.1f} dB) lies outside {where}; the range "
                f"band is too narrow for this aperture to tell whether it folded: it is a scatterer at x_n ~ "
                f"{v * f.t_app:.0f} m or the fold of one at x_n ~ {v * (f.t_app + prf / k):.0f} m or "
                f"{v * (f.t_app - prf / k):.0f} m (a ghost); declare coarse_focus.scene_azimuth_extent to cover "
                "the scene so the alias check sees it"
            )
    return problems, notes


def _azimuth_time(pre: Product) -> np.ndarray:
    """The pulses' azimuth times (float64 s), checked: at least two, uniform at the PRF."""
    t = np.asarray(pre.coords["azimuth_time"], float)
    if len(t) < 2:
        raise InputError("coarse-focus: need at least two pulses")
    if not np.allclose(np.diff(t), 1.0 / pre.radar.prf, rtol=1e-6, atol=0):
        raise InputError("coarse-focus: azimuth_time is not uniformly sampled at the PRF")
    return t


def _output_samples(params: CoarseFocusParams, budget: dict, prf: float, k: float, n_pulses: int) -> int:
    """Samples of the deramped azimuth grid: ``azimuth_samples``, or the total Doppler bandwidth times the
    margin at the deramped rate (at least the pulses), rounded up to a fast FFT length."""
    if params.azimuth_samples is not None:
        return params.azimuth_samples
    need = params.bandwidth_margin * budget["total_bandwidth"] * prf / k
    return sfft.next_fast_len(max(n_pulses, int(math.ceil(need))))


def _alias_problems(
    budget: dict, f_out: float, prf: float, method: str, box: tuple[float, float, float, float]
) -> list[str]:
    """What folds after deramping (spread beyond the PRF) or is cut by the output rate F_a'', with the fix."""
    problems = []
    if budget["deramp_extent"] > prf:
        fix = "raise the PRF or shrink the scene" + (
            "" if method == "nonlinear" else " or use the nonlinear correction"
        )
        problems.append(
            f"the deramped Doppler spread {budget['deramp_spread']:.1f} Hz (extent about zero "
            f"{budget['deramp_extent']:.1f} Hz) exceeds the PRF {prf:.1f} Hz "
            f"(Doppler correction {method!r}, scene x_n in [{box[0]:.0f}, {box[1]:.0f}] m, "
            f"r_0 in [{box[2]:.0f}, {box[3]:.0f}] m): the scene folds after deramping; {fix}"
        )
    if budget["total_bandwidth"] > f_out:
        problems.append(
            f"F_a'' = {f_out:.1f} Hz is below the total Doppler bandwidth {budget['total_bandwidth']:.1f} "
            "Hz; raise coarse_focus.azimuth_samples"
        )
    return problems


def coarse_focus(
    pre: Product, params: CoarseFocusParams = CoarseFocusParams(), progress: ProgressFactory | None = None
) -> Product:
    """``preprocessed`` product -> ``coarse`` product on the deramped azimuth grid t'."""
    from sarproc.product.io import history_entry

    if pre.kind != "preprocessed":
        raise InputError(f"coarse-focus needs a 'preprocessed' product, got {pre.kind!r}")
    radar = pre.radar
    t = _azimuth_time(pre)
    prf = radar.prf
    r_ref = params.reference_range or radar.reference_range
    k = deramp_rate(radar, r_ref)
    method = pre.attrs.get("doppler_correction", "none")
    box = scene_box(pre, params, r_ref)
    budget = doppler_budget(radar, t[0], t[-1], box, k, method)
    n_out = _output_samples(params, budget, prf, k, len(t))
    f_out = n_out * k / prf
    problems = _alias_problems(budget, f_out, prf, method, box)
    folds = []
    if params.fold_check and method == "nonlinear":
        folds = deramped_folds(pre.data, t, radar, k, n_out, deramp_interval(radar, t[0], t[-1], box, k))
        fold_problems, notes = _fold_messages(folds, radar, k, box)
        problems += fold_problems
        for note in notes:
            log.warning("coarse-focus: %s", note, extra=IMAGE_DEFECT)
    if problems:
        msg = "coarse-focus: " + "; ".join(problems)
        if params.on_alias == "error":
            raise InputError(msg + " (set coarse_focus.on_alias: warn to process anyway)")
        log.warning(msg, extra=IMAGE_DEFECT)
    data, t_out = specan(pre.data, t, prf, k, n_out, params.precision, params.block_range, progress)
    attrs = dict(pre.attrs)
    attrs.update(
        {
            "azimuth_sampling_rate": float(f_out),  # F_a'' (Hz)
            "deramp_rate": float(k),  # k = -f_dr,ref (Hz/s)
            "coarse_reference_range": float(r_ref),
            "aperture_start": float(t[0]),
            "aperture_end": float(t[-1]),
            "n_pulses": int(len(t)),
            "total_doppler_bandwidth": budget["total_bandwidth"],
            "deramp_spread": budget["deramp_spread"],
            "deramp_extent": budget["deramp_extent"],
            "scene_box": [float(b) for b in box],
            "aliased": bool(problems),
            "folds": [dataclasses.asdict(f) for f in folds if f.n],
        }
    )
    out = pre.derive(
        "coarse",
        data,
        ("azimuth_time", "range_time"),
        {"azimuth_time": t_out, "range_time": pre.coords["range_time"]},
        attrs=attrs,
    )
    entry = as_dict(params)
    entry.update(
        {
            "resolved_reference_range": float(r_ref),
            "resolved_azimuth_samples": int(n_out),
            "azimuth_sampling_rate": float(f_out),
            "deramp_rate": float(k),
            "deramp_spread": budget["deramp_spread"],
            "deramp_extent": budget["deramp_extent"],
            "total_doppler_bandwidth": budget["total_bandwidth"],
        }
    )
    out.history.append(history_entry("coarse_focus", entry))
    return out
