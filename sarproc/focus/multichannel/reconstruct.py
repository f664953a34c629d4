"""The ``reconstruct`` stage (paper 003, Xu et al.; Fig. 6 flow): multichannel squint raw -> one channel at N PRF.

Flow, on a ``raw_multichannel`` product (channel, azimuth_time, range_time):

1. range FFT (zero-padded so the walk correction cannot wrap), compression by the chirp phase,
   per-channel deramp of the squint Doppler history at t + tau_n and removal of the bistatic
   excess path e_n (deramp.py, channels.py eqs. 1-2);
2. conventional reconstruction: filter bank of the static-scene channel delays over the band
   |f| < N PRF / 2 (channels.py eq. 3; Tikhonov eq. 4 when ``regularization`` > 0);
3. (``method: modified``) moving targets (detection.py): CFAR detections in the azimuth-compressed
   reconstruction (or clutter-null residual); per detection, its channels are separated by a
   dechirp mask, the slant-range velocity is searched (velocity.py eq. 5), the along-track velocity
   found by autofocus, and its conventional reconstruction replaced by the modified one (its Doppler
   offset and channel delays, range acceleration matched to a static point's), leaving the other
   targets as they were; the aux table ``moving_targets`` lists them (model.MOVING_TARGET_COLUMNS);
4. inverse deramp on the N PRF grid, decompression, crop: a ``raw`` product whose phase centre is
   the transmitter, sampled at N PRF, which ``backproject`` focuses.

Clutter suppression with redundant channels: where the static clutter band |f| <= B_a / 2
covers only M < N of the N aliases of a base frequency, the channel vector is projected onto the
orthogonal complement of the M static steering vectors (columns of H, eq. 3); static scatterers
cancel and what remains is moving. The energy ratio after/before is reported in dB.
"""

from __future__ import annotations

import dataclasses
import functools
import logging
import math
from collections.abc import Callable, Iterable
from typing import TYPE_CHECKING

import numpy as np

from sarproc.dsp.rangecomp import replica_alias_power, replica_spectrum
from sarproc.focus.multichannel import channels, deramp, detection, velocity
from sarproc.product import beam, fft as sfft, moving
from sarproc.product.config import as_dict, param
from sarproc.product.errors import IMAGE_DEFECT, InputError
from sarproc.product.metadata import C, RadarMetadata
from sarproc.product.model import MOVING_TARGET_COLUMNS, Product, target_names
from sarproc.product.sorted_values import median, unique_integers

if TYPE_CHECKING:
    from sarproc.product.steps import ProgressFactory

log = logging.getLogger(__name__)


# the range compressions reconstruct can apply (range_compression_filters)
RANGE_COMPRESSION = ("stationary_phase", "replica_phase", "replica_flat", "replica_equalised")
# replica_equalised beyond B/2 (range_compression_filters): the roll-off's width, a fraction of the guard band
# (f_s - B) / 2, and the floor under it, re the flat level (docs/multichannel.md section 30)
REPLICA_ROLL_OFF = 1.0
REPLICA_FLOOR = 0.1


@dataclasses.dataclass(frozen=True)
class ReconstructParams:
    method: str = param(
        default="modified",
        choices=("conventional", "modified"),
        doc=(
            "conventional: static-scene filter bank everywhere; modified: also detect moving targets, estimate their "
            "velocities and reconstruct them with the modified filter bank"
        ),
    )
    doppler_bandwidth: float | None = param(
        "frequency",
        default=None,
        gt=0,
        doc=(
            "target Doppler band B_a for the leakage criterion and the clutter null; default 2 v cos(squint) beta / "
            "lambda from the azimuth beamwidth"
        ),
    )
    regularization: float = param(default=0.0, ge=0, doc="Tikhonov mu (relative to the largest singular value^2)")
    max_condition: float = param(default=100.0, gt=1, doc="warn when the filter bank's condition number exceeds this")
    detection: str = param(
        default="auto",
        choices=("auto", "whole"),
        doc=("auto: moving-target windows from the data; whole: the whole swath is one moving target"),
    )
    detection_velocity: float = param(
        "velocity",
        default=1.0,
        gt=0,
        doc=("a detection is static (not a mover) when its line-of-sight velocity is under this"),
    )
    detection_level: float = param(
        "decibel", default=-30.0, lt=0, doc="ignore detection-image peaks weaker than this relative to the strongest"
    )
    detection_snr: float = param(
        "decibel",
        default=15.0,
        ge=0,
        doc=(
            "lowest CFAR threshold: a detection-image peak must exceed the mean local background (clutter residual "
            "and noise, from tile medians) by this much, and by what false_alarm_rate sets"
        ),
    )
    false_alarm_rate: float = param(
        default=1e-6,
        gt=0,
        lt=1e-2,
        doc=(
            "CFAR false-alarm rate per peak of the measured background (the detection image with every examined "
            "response taken out): the threshold over the local background that this fraction of its peaks exceeds, "
            "from a generalised Pareto fit of their top 1 %; a second pass examines the peaks above it"
        ),
    )
    window_margin: int = param(
        default=16,
        ge=1,
        doc="range cells on each side of a mover's peak in its window (its own range walk and curvature must fit)",
    )
    separation_bandwidth: float = param(
        "frequency",
        default=25.0,
        gt=0,
        doc=(
            "half width of the azimuth mask that separates one mover from the others in its range cells, in the "
            "dechirped channel spectrum; movers closer than about 2.5 x this / K_a in apparent time are not separated"
        ),
    )
    max_detections: int = param(
        default=64,
        ge=1,
        doc=("at most this many detections are examined (strongest first; those an examined one explains are free)"),
    )
    radial_velocity: float | None = param("velocity", default=None, doc="use this slant-range velocity (no search)")
    along_track_velocity: float | None = param(
        "velocity", default=None, doc="use this along-track velocity (no autofocus)"
    )
    velocity_min: float = param("velocity", default=-20.0, doc="lower bound of the slant-range velocity search")
    velocity_max: float = param("velocity", default=20.0, doc="upper bound of the slant-range velocity search")
    velocity_step: float = param("velocity", default=0.1, gt=0, doc="precision of the search grid")
    coarse_step: float = param("velocity", default=2.0, gt=0, doc="first grid step of the fast search")
    search: str = param(default="fast", choices=("fast", "exhaustive"), doc="coarse-to-fine or a full grid")
    autofocus: bool = param(default=True, doc="estimate the along-track velocity by azimuth autofocus")
    autofocus_span: float = param("velocity", default=30.0, gt=0, doc="along-track search over +-span")
    clutter_suppression: bool = param(
        default=False,
        doc="null static clutter with redundant channels; report it and detect moving targets on the residual",
    )
    clutter_band: float = param(
        default=1.2,
        gt=0,
        doc=("width of the nulled static band over the Doppler bandwidth (above 1: the spectral tails of the beam)"),
    )
    range_compression: str = param(
        default="auto",
        choices=("auto", *RANGE_COMPRESSION),
        doc=(
            "range compression before the deramp, undone after the reconstruction. auto: replica_equalised for the "
            "band-limited echoes simulate records (1 / the sampled replica's spectrum within B/2, a smooth "
            "roll-off beyond, invertible in every bin), else stationary_phase (the ideal chirp's exp(j pi f^2 / K)); "
            "replica_phase and replica_flat (zero beyond B/2) are variants (docs/multichannel.md sections 16, 30)"
        ),
    )

    def validate(self) -> None:
        if self.velocity_max <= self.velocity_min:
            raise InputError("velocity_max: must be greater than velocity_min")
        if self.coarse_step < self.velocity_step:
            raise InputError("coarse_step: must be >= velocity_step")


@dataclasses.dataclass(frozen=True)
class MovingTarget:
    """One moving-target window and what was estimated for it."""

    first_cell: int
    last_cell: int
    slant_range: float  # m, window centre at its beam-centre time
    radial_velocity: float  # m/s (estimated or given)
    along_track_velocity: float  # m/s
    beam_centre_time: float  # s
    leakage: float  # eq. (5) at the estimate
    at_bound: bool
    search: np.ndarray  # (n, 2) velocity, leakage
    autofocus: np.ndarray  # (n, 2) velocity, sharpness (empty if not run)
    snr_db: float = float("nan")  # detection SNR (peak over mean local background)
    # the autofocus's own integrated signal to clutter-plus-noise ratio (power; nan: no autofocus, inf: no interference)
    autofocus_snr: float = float("nan")
    # m/s: the autofocus's v_a offset on the mover's illumination alone (illumination_pull; nan: no autofocus)
    autofocus_pull: float = float("nan")
    apparent_time: float = float("nan")  # s, where it appears (beam-centre time of its static equivalent)
    apparent_range: float = float("nan")  # m, slant range of its static equivalent at apparent_time
    # with the null fit: the output azimuth sample where the mover appears (None: eq. 5 was kept)
    null_fit_index: float | None = None
    null_fit_cell: int | None = None  # and its range cell in the window
    # m/s of v_los: half the span of the null fit's search within NULL_FIT_FLAT of its minimum (0: not by the null fit)
    null_fit_width: float = 0.0
    # m/s of v_los: eq. 5's estimate minus the null fit's where the null fit overruled a mover's eq. 5 (_null_refit)
    overruled: float = 0.0
    # the null fit replaced an eq. 5 estimate at rest (its v_los under detection_velocity; _null_refit): eq. 5 is
    # no evidence of motion, and _refocus asks the null fit whether it rules rest out
    from_rest: bool = False
    # m/s of v_los: eq. 5's 1-sigma from its independent looks' disagreement (_leakage_spread; 0: not by eq. 5)
    leakage_spread: float = 0.0
    # m/s of v_los: the same of the untapered channels where a neighbour range-tapered the final search (else
    # leakage_spread): a take-back of a weak detection weighs the larger (_static_within)
    untapered_spread: float = 0.0
    # without the clutter null: how much further eq. 5 falls from rest to its first estimate than the window's own
    # noise does (_noise_dip; <= 0: no evidence of motion; nan: not measured), and how far the noise's draw alone
    # takes a static point's at POINT_TARGET_ALPHA (noise_dip_bound; under it: motion not significant, a warning)
    noise_dip: float = float("nan")
    noise_dip_bound: float = 0.0
    # s: a mover lit past the data's start or end whose eq. 5 searched the span about its beam-centre time (_lit_span,
    # _search_lit_span): its illumination outside the data (0: none, or not corrected)
    lit_cut: float = 0.0

    def line_of_sight_velocity(self, squint: float) -> float:
        """m/s: the estimated velocity's component along the beam's line of sight (v_r cos + v_a sin)."""
        return channels.line_of_sight_velocity(self.radial_velocity, self.along_track_velocity, squint)


@dataclasses.dataclass
class _Geometry:
    prf: float
    times: np.ndarray
    out_times: np.ndarray
    dx: np.ndarray
    tau0: np.ndarray
    n: int
    velocity: float
    squint: float
    fc: float
    half_band: float
    fs: float
    # Hz: the band the null fit models a mover's reconstruction over (_NullFit; model_half_band); 0: half_band
    model_half_band: float = 0.0
    bandwidth: float = 0.0  # Hz: the chirp's range bandwidth (_window_at's range taper; 0: none)
    antenna_pattern: str = "rect"  # the recorded azimuth pattern (rect where none is recorded; _lit_span)


def _check_input(raw: Product) -> None:
    if raw.kind != "raw_multichannel":
        raise InputError(f"reconstruct needs a raw_multichannel product, got {raw.kind!r}")
    if "range_gate_offset" in raw.aux:
        raise InputError("reconstruct: a varying receive range gate (aux range_gate_offset) is not supported")
    rx = np.asarray(raw.aux.get("rx_offset", np.zeros((1, 3))), float).reshape(-1, 3)
    tx = np.asarray(raw.aux.get("tx_offset", np.zeros(3)), float).reshape(3)
    if rx.shape[0] != raw.data.shape[0]:
        raise InputError(f"reconstruct: aux rx_offset has {rx.shape[0]} rows for {raw.data.shape[0]} channels")
    if np.any(np.abs(rx[:, 1:] - tx[1:]) > 1e-9):
        raise InputError("reconstruct: receivers must be displaced along track only (aux rx_offset y, z = tx's)")
    t = np.asarray(raw.coords["azimuth_time"], float)
    if len(t) > 1 and not np.allclose(np.diff(t), 1.0 / raw.radar.prf, rtol=1e-6, atol=0):
        raise InputError("reconstruct: azimuth_time is not sampled uniformly at the radar PRF")


def _geometry(raw: Product, params: ReconstructParams) -> _Geometry:
    r = raw.radar
    rx = np.asarray(raw.aux.get("rx_offset"), float).reshape(-1, 3)
    tx = np.asarray(raw.aux.get("tx_offset", np.zeros(3)), float).reshape(3)
    dx = rx[:, 0] - tx[0]
    n = len(dx)
    t = np.asarray(raw.coords["azimuth_time"], float)
    band = params.doppler_bandwidth
    if band is None:
        if r.azimuth_beamwidth <= 0:
            raise InputError("reconstruct.doppler_bandwidth: required (the product has no azimuth beamwidth)")
        band = 2 * r.velocity * math.cos(r.squint) * r.azimuth_beamwidth / r.wavelength
    out_times = t[0] + np.arange(n * len(t)) / (n * r.prf)
    return _Geometry(
        prf=r.prf,
        times=t,
        out_times=out_times,
        dx=dx,
        tau0=channels.channel_delays(dx, r.velocity),
        n=n,
        velocity=r.velocity,
        squint=r.squint,
        fc=r.carrier_frequency,
        half_band=band / 2,
        fs=r.range_sampling_rate,
        model_half_band=model_half_band(r, band / 2, n * r.prf / 2),
        bandwidth=float(r.bandwidth),
        antenna_pattern=r.antenna_pattern or "rect",
    )


# One-sided fraction of the two-way beam's Doppler energy left outside the null fit's model band (model_half_band)
NULL_FIT_SKIRT = 1e-3


def model_half_band(radar: RadarMetadata, half_band: float, nyquist: float) -> float:
    """Hz: the half band over which the null fit models a mover's reconstruction (_NullFit.in_band).

    The clutter null cancels only what lies inside clutter_band x half_band; a beam's two-way pattern beyond it
    passes unattenuated. A sinc or gaussian beam has a skirt there (sinc: 4.1 % of its energy beyond half_band on
    each side), which a model kept to half_band does not predict: the fit then drew its minimum to a v_los whose
    in-band residual was as strong as that skirt (scene 011: v_r -17.1 m/s for the truth's -4.8, docs/multichannel.md
    section 8). The band is therefore the recorded pattern's (radar.antenna_pattern at radar.azimuth_beamwidth)
    down to NULL_FIT_SKIRT of its energy on each side (sinc 1.71, gaussian 1.96 x half_band), never under half_band
    (a rect beam's, or a pattern not recorded: the -3 dB band, as before) nor over the reconstruction's N PRF / 2.
    """
    pattern = radar.antenna_pattern or "rect"
    beamwidth = float(radar.azimuth_beamwidth)
    if pattern == "rect" or beamwidth <= 0:
        return half_band
    f = np.linspace(0.0, nyquist, 4096)
    # Doppler f = 2 v cos(theta) sin(angle) / lambda from the beam's centre
    scale = 2 * radar.velocity * math.cos(radar.squint) / radar.wavelength
    angle = np.arcsin(np.clip(f / scale, -1.0, 1.0))
    power = beam.one_way_amplitude(angle, beamwidth, pattern) ** 4
    tail = np.cumsum(power[::-1])[::-1] / power.sum()  # one side's energy beyond each f
    edge = float(f[np.argmax(tail <= NULL_FIT_SKIRT)]) if np.any(tail <= NULL_FIT_SKIRT) else nyquist
    return min(nyquist, max(half_band, edge))


def range_padding(
    n_rg: int, velocity: float, squint: float, times: np.ndarray, prf: float, fs: float
) -> tuple[int, int]:
    """(n_fft, lead): the zero-padded range FFT length and the samples added before the echo, so that the range
    walk correction (v sin(theta) t, plus 50 m/s of target motion) cannot wrap."""
    walk = (velocity * abs(math.sin(squint)) + 50.0) * float(np.max(np.abs(times)) + 1.0 / prf)
    lead = int(math.ceil(2 * walk / C * fs)) + 8
    return sfft.next_fast_len(n_rg + 2 * lead), lead


def simulated_waveform(raw: Product) -> str | None:
    """The waveform ``simulate`` recorded in the raw product's provenance (its resolved scene's
    ``simulation.waveform``: 'band_limited' or 'continuous'), or None where no simulation is recorded."""
    for entry in raw.history:
        parameters = entry.get("parameters") if isinstance(entry, dict) else None
        sim = parameters.get("simulation") if isinstance(parameters, dict) else None
        if isinstance(sim, dict) and sim.get("waveform") in ("band_limited", "continuous"):
            return str(sim["waveform"])
    return None


# Range compression of the channels before the deramp (_to_deramped) and its inverse after the reconstruction
# (_raw_echoes). A band-limited echo (simulate's simulation.waveform: band_limited) is the sampled chirp replica,
# exactly delayed: its spectrum is the replica's H_s(f) = sum_k C(f - k f_s) (the continuous chirp's Fresnel tails
# aliased into the band), the same in every pulse and channel. The stationary-phase phasor exp(+j pi f^2 / K)
# leaves the aliased part uncompressed: a coherent plateau out to c T_p / 2 from every target, which the velocity
# windows cut into cross-window ghosts (docs/multichannel.md sections 15, 16). So band-limited echoes are equalised
# with the replica's own spectrum (rangecomp.replica_spectrum, the replica backproject compresses with): 1 / H_s
# within B/2, so the compressed spectrum is flat there; beyond B/2 it rolls off instead of stopping (a hard stop's
# sinc tails ghost as well) as the replica's power there, its aliased tails summed in power, tapered to f_s / 2
# (section 30; session 42's |H_s|^2 roll-off kept the tails' beat, a copy of every response one pulse length away;
# a roll-off as |H_s| raised the noise of those bins, -1.3 dB of detection SNR). No bin of the filter is zero, so
# the re-expansion (its reciprocal) restores every bin.
# A continuous echo's aliased part changes with each fractional delay (its coherent part is C(f) alone): it, and a
# product with no simulation recorded, keep the stationary-phase phasor. replica_phase (phase only, unit modulus)
# and replica_flat (1 / H_s within B/2, zero beyond: not invertible there) are the variants measured against it.
def range_compression_filters(
    raw: Product, f_r: np.ndarray, mode: str | None = None
) -> tuple[np.ndarray, np.ndarray, str]:
    """(compression filter, the re-expansion, its name in RANGE_COMPRESSION) on the unshifted range-frequency grid
    ``f_r`` (above): replica_equalised for the band-limited echoes simulate records, else stationary_phase;
    ``mode`` overrides."""
    r = raw.radar
    if mode is None:
        mode = "replica_equalised" if simulated_waveform(raw) == "band_limited" else "stationary_phase"
    if mode == "stationary_phase":
        return deramp.compression_phasor(f_r, r.chirp_rate), deramp.compression_phasor(f_r, r.chirp_rate, -1), mode
    h = replica_spectrum(r, len(f_r))
    mag = np.abs(h)
    phase = np.where(mag > 0, np.conj(h) / np.where(mag > 0, mag, 1.0), 1.0)
    if mode == "replica_phase":
        return phase, np.conj(phase), mode
    band = np.abs(f_r) <= r.bandwidth / 2
    scale = float(np.sqrt(np.mean(mag[band] ** 2)))  # the in-band energy kept
    flat = scale / np.where(band, h, 1.0)
    if mode == "replica_flat":
        return np.where(band, flat, 0.0), np.where(band, h / scale, 0.0), mode
    ends = band & (np.abs(f_r) >= 0.49 * r.bandwidth)
    edge = float(np.mean(mag[ends]))  # |H_s| at the band's edge
    # beyond B/2 the compressed spectrum is scale (w P / P_edge + REPLICA_FLOOR (1 - w) |H_s|^2 / edge^2): P the
    # replica's power with its aliases summed in power (rangecomp.replica_alias_power), w a raised cosine from 1 at
    # B/2 to 0 at f_s / 2, then the floor, which keeps every bin invertible. |H_s|^2 there is the Fresnel tails of
    # the pulse's end and of its start beating with period 1 / T_p; a compressed spectrum that keeps the beat
    # (|H_s|^2 / edge^2 to f_s / 2, as before) puts a copy of every response one pulse length either side in
    # range, -36 dB; P is |H_s|^2 without it (docs/multichannel.md section 30)
    power = replica_alias_power(r, len(f_r))
    guard = (r.range_sampling_rate - r.bandwidth) / 2
    x = np.clip((np.abs(f_r) - r.bandwidth / 2) / (REPLICA_ROLL_OFF * guard), 0.0, 1.0)
    w = 0.5 * (1.0 + np.cos(np.pi * x))
    safe = np.maximum(mag, 1e-12 * edge)
    out = scale * (w * power / float(np.mean(power[ends])) + REPLICA_FLOOR * (1.0 - w) * safe**2 / edge**2)
    comp = np.where(band, flat, phase * out / safe)
    return comp, 1.0 / comp, mode


def _to_deramped(
    raw: Product, g: _Geometry, mode: str | None = None
) -> tuple[np.ndarray, np.ndarray, int, np.ndarray, str]:
    """Channels in (azimuth time, range frequency), compressed (range_compression_filters) and deramped; also f_r,
    the lead offset, the compression's inverse (for _raw_echoes) and its name."""
    r = raw.radar
    n_ch, n_az, n_rg = raw.data.shape
    n_fft, lead = range_padding(n_rg, g.velocity, g.squint, g.times, g.prf, g.fs)
    f_r = sfft.fftfreq(n_fft, 1.0 / g.fs)
    buf = np.zeros((n_ch, n_az, n_fft), np.complex64)
    buf[:, :, lead : lead + n_rg] = raw.data
    spec = sfft.fft(buf, axis=-1, workers=-1)
    del buf
    comp, expand, mode = range_compression_filters(raw, f_r, mode)
    excess = channels.bistatic_excess(g.dx, g.squint, r.reference_range)
    for k in range(n_ch):
        spec[k] *= deramp.deramp_phasor(g.times + g.tau0[k], f_r, g.velocity, g.squint, g.fc)
        spec[k] *= comp * deramp.path_phasor(f_r, excess[k], g.fc)
    return spec, f_r, lead, expand, mode


def _reconstruct(spec_tf: np.ndarray, bank: channels.FilterBank) -> np.ndarray:
    """(N, n_az, m) channels in azimuth time -> (N n_az, m) reconstructed spectrum (azimuth frequency)."""
    return channels.apply_filter_bank(sfft.fft(spec_tf, axis=1, workers=-1), bank)


class _Window:
    """One moving-target window: channel data in (t, f_r) over its L range cells, and its reconstruction."""

    def __init__(
        self,
        x_tf: np.ndarray,
        f_r: np.ndarray,
        g: _Geometry,
        params: ReconstructParams,
        x_criterion: np.ndarray | None = None,
    ) -> None:
        self.x, self.f_r, self.g, self.params = x_tf, f_r, g, params
        # what eq. 5's final search weighs (final_leakage): the channels range-tapered where a neighbour's range side
        # lobes reach the criterion's cells (_window_at), else None (the channels themselves)
        self.x_criterion = x_criterion
        self.out_f = sfft.fftfreq(g.n * len(g.times), 1.0 / (g.n * g.prf))
        self._banks: dict[float, channels.FilterBank] = {}
        self.cells: np.ndarray | None = None  # the criterion's range cells (None: all of the window)
        # the cells this target may take (None: all): a second target at its Doppler holds the others (_window_bounds)
        self.gate: np.ndarray | None = None
        # eq. 5 on the part of a mover's illumination symmetric about its beam-centre time, where the data cut the
        # rest (_lit_span; None: the whole output time and band)
        self.span: _LitSpan | None = None

    def keep_own_cells(self, margin: int = 2, centre: int | None = None, reach: float = math.inf) -> None:
        """Restrict the criterion to the cells holding the target (noise in the others only dilutes eq. 5).

        A cell is the target's when its energy (over all pulses and channels) rises 5 % of the way from the
        median cell (the window's floor) to the strongest, and OWN_CELL_SIGMAS robust standard deviations of the
        cells' energies (1.4826 x their median absolute deviation from the floor) over the floor; ``margin`` cells
        are added either side. The second condition matters only where the target stands a few dB over a floor of
        noise: there 5 % of the way is inside the noise cells' own spread, and many of the window's noise cells
        passed it (mover campaign scene 013 M1, detection SNR 22.5 dB, 5.9 dB over the floor in its cell: 19
        criterion cells, eq. 5's dip 0.6 % deep and taken for no point target; docs/multichannel.md section 8).

        With ``centre`` (the detection's window cell), where the strongest cell lies farther than ``reach`` from it
        (beyond any mover's own range extent: another target's response, whose main lobe or range pedestal reaches
        into the window from beyond its edge), the target's cells are those standing out by the strongest within
        ``reach`` of ``centre``, and of those only the run around it. Mover campaign scene 036 (continuous chirp, no
        clutter, noise): M4 (v_los -8.9 m/s, 47.5 dB) 17 cells and 22 Hz from the static S1 (69.5 dB), whose cell
        next to the window's edge held 71.6 dB of energy against M4's 56.7 dB: the criterion took S1's cells 329-332,
        eq. 5 read rest (v_los -0.008 m/s) and M4 was taken for static (docs/multichannel.md section 25).
        """
        p = self.cell_energy
        cells = np.arange(len(p)) if self.gate is None else self.gate
        strongest = int(cells[np.argmax(p[cells])])
        near = cells[np.abs(cells - centre) <= reach] if centre is not None else cells
        if centre is not None and abs(strongest - centre) > reach and len(near):
            own = np.nonzero(_over_floor(p, float(p[near].max())))[0]
            keep = _widened(own, len(p), margin)
            # the run around the target's strongest cell near the detection: a run apart from it is another target's
            top = int(near[np.argmax(p[near])])
            if not keep[top]:  # nothing near it stands out: its own cell and margin
                keep = _widened(np.array([top]), len(p), margin)
            run = np.zeros(len(p), bool)
            lo, hi = top, top
            while lo > 0 and keep[lo - 1]:
                lo -= 1
            while hi < len(p) - 1 and keep[hi + 1]:
                hi += 1
            run[lo : hi + 1] = True
            keep = run
        else:
            own = np.nonzero(_over_floor(p, float(p[strongest])))[0]
            keep = _widened(own, len(p), margin)
        if self.gate is not None:
            gate = np.zeros(len(p), bool)
            gate[self.gate] = True
            keep = keep & gate if np.any(keep & gate) else gate
        elif len(own) == 0:
            return
        self.cells = np.nonzero(keep)[0]

    @functools.cached_property
    def cell_energy(self) -> np.ndarray:
        """Each range cell's energy over all pulses and channels (keep_own_cells, _noise_dip)."""
        return np.sum(np.abs(sfft.ifft(self.x, axis=-1, workers=-1)) ** 2, axis=(0, 1))

    def bank(self, v_a: float) -> channels.FilterBank:
        key = round(v_a, 9)
        if key not in self._banks:
            tau = channels.channel_delays(self.g.dx, self.g.velocity, v_a)
            self._banks[key] = channels.filter_bank(
                tau, self.g.prf, len(self.g.times), regularization=self.params.regularization
            )
        return self._banks[key]

    def demodulated_spectrum(self, v_r: float, v_a: float, criterion: bool = False) -> np.ndarray:
        """Reconstructed spectrum (N n_az, L) with the trial target's Doppler offset removed (band centred on 0), of
        the channels or (``criterion``) of what eq. 5 weighs."""
        g = self.g
        v_los = channels.line_of_sight_velocity(v_r, v_a, g.squint)
        demod = deramp.doppler_shift_phasor(g.times, self.f_r, v_los, g.fc, sign=-1)
        x = self.x_criterion if criterion and self.x_criterion is not None else self.x
        return _reconstruct(x * demod[None], self.bank(v_a))

    def final_leakage(self, v_r: float, v_a: float) -> float:
        """Eq. 5 on the range-tapered channels where there are (x_criterion), else ``leakage``."""
        return self.leakage(v_r, v_a, criterion=True)

    def criterion_spectrum(self, v_r: float, v_a: float, criterion: bool = False) -> tuple[np.ndarray, float]:
        """What eq. 5 weighs and its half band: the demodulated spectrum and B_a / 2, or where a span is set (a mover
        lit past the data's start or end, _lit_span) the reconstruction kept to that span in time and its half band."""
        spec = self.demodulated_spectrum(v_r, v_a, criterion)
        if self.span is None:
            return spec, self.g.half_band
        y = sfft.ifft(spec, axis=0, workers=-1) * self.span.weight[:, None]
        return sfft.fft(y, axis=0, workers=-1), self.span.half_band

    def leakage(self, v_r: float, v_a: float, criterion: bool = False) -> float:
        spec, half_band = self.criterion_spectrum(v_r, v_a, criterion)
        if self.cells is not None:
            spec = sfft.ifft(spec, axis=1, workers=-1)[:, self.cells]
        return velocity.out_of_band_fraction(spec, self.out_f, half_band)

    def leakage_looks(self, v_r: float, v_a: float, criterion: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """Eq. 5's out-of-band and total energy per range frequency of the criterion's cells (its independent
        looks: noise is independent between them, and a point target has the same azimuth spectrum in each): their
        sums over the looks are eq. 5's numerator and denominator (Parseval)."""
        spec, half_band = self.criterion_spectrum(v_r, v_a, criterion)
        if self.cells is not None:
            spec = sfft.fft(sfft.ifft(spec, axis=1, workers=-1)[:, self.cells], axis=1, workers=-1)
        p = np.abs(spec) ** 2
        return p[np.abs(self.out_f) > half_band].sum(axis=0), p.sum(axis=0)

    def coherence_looks(
        self, v_r: float, v_a: float, cells: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Eq. 5's out-of-band and total energy per look (as leakage_looks, of what eq. 5 weighs: x_criterion where
        there is one), and both as the channels would give them were their phases unrelated (no point target):
        the filter bank's |P|^2 applied to the channels' power spectra, the cross-channel terms dropped. The looks
        are the range frequencies of ``cells`` (default: the criterion's cells)."""
        g = self.g
        cells = self.cells if cells is None else cells
        v_los = channels.line_of_sight_velocity(v_r, v_a, g.squint)
        demod = deramp.doppler_shift_phasor(g.times, self.f_r, v_los, g.fc, sign=-1)
        x = self.x_criterion if self.x_criterion is not None else self.x
        s = sfft.fft(x * demod[None], axis=1, workers=-1)  # (N, n_az, L f_r)
        if cells is not None:
            s = sfft.fft(sfft.ifft(s, axis=-1, workers=-1)[:, :, cells], axis=-1, workers=-1)
        bank = self.bank(v_a)
        s = np.moveaxis(s, 0, 1)  # (n_az, N, looks)
        z = np.abs(bank.matrix64 @ s) ** 2  # (n_az, N band, looks)
        z0 = (np.abs(bank.matrix) ** 2).astype(np.float32) @ (np.abs(s) ** 2)
        out = np.abs(self.out_f[bank.out_index]) > g.half_band  # (n_az, N band)
        return z[out].sum(axis=0), z.sum(axis=(0, 1)), z0[out].sum(axis=0), z0.sum(axis=(0, 1))

    def output(self, v_r: float, v_a: float, t_c: float, slant_range: float, focus_along_track: bool) -> np.ndarray:
        """Target reconstructed at N PRF in (t', f_r), Doppler offset restored, FM rate matched to a static point."""
        g = self.g
        y = sfft.ifft(self.demodulated_spectrum(v_r, v_a), axis=0, workers=-1)
        v_los = channels.line_of_sight_velocity(v_r, v_a, g.squint)
        y *= deramp.doppler_shift_phasor(g.out_times, self.f_r, v_los, g.fc, sign=+1)
        if focus_along_track:
            y *= self.acceleration_fix(v_r, v_a, t_c, slant_range)
        return y

    def acceleration_fix(self, v_r: float, v_a: float, t_c: float, slant_range: float) -> np.ndarray:
        g = self.g
        # R''_moving - R''_static with the same R': ((v - v_a)^2 + v_r^2 - v^2) / R (velocity.py).
        d_acc = ((g.velocity - v_a) ** 2 + v_r**2 - g.velocity**2) / slant_range
        return deramp.quadratic_phasor(g.out_times, self.f_r, d_acc, t_c, g.fc)

    def walk_rate(self, v_r: float, v_a: float) -> float:
        """Residual range walk (m/s) of the target after removing the trial Doppler offset: 0 at the true v_los.

        The leakage criterion cannot tell velocities whose Doppler offsets differ by a multiple of the PRF
        (the channel samples are the same); their range walks differ by lambda PRF / 2 per second.
        """
        g = self.g
        y = sfft.ifft(sfft.ifft(self.demodulated_spectrum(v_r, v_a), axis=0, workers=-1), axis=1, workers=-1)
        p = np.abs(y) ** 2
        cells = np.arange(p.shape[1])
        if self.gate is not None:
            p, cells = p[:, self.gate], self.gate
        # the detected target's own track only: another response in the window's cells, apart from it, pulls the
        # centroid to it where it outlasts the target (mover campaign scene 000: M5's window, cells 271-303, holds M3
        # and M4 nine cells off, alone there after M5's illumination ends: a walk of 34 m/s at M5's true v_r)
        run = _own_run(p.sum(axis=0))
        p, cells = p[:, run], cells[run]
        w = p.sum(axis=1)
        keep = w > 0.1 * w.max() if w.max() > 0 else w > 0
        centre = (p[keep] @ cells) / w[keep]
        tt = g.out_times[keep]
        if len(tt) < 3:
            return 0.0
        slope = np.polyfit(tt, centre, 1, w=np.sqrt(w[keep]))[0]
        return float(slope * C / (2 * g.fs))


def _over_floor(p: np.ndarray, top: float) -> np.ndarray:
    """Cells of a cell-energy profile ``p`` standing out of its floor (the median cell): 5 % of the way from it to
    ``top``, and OWN_CELL_SIGMAS robust standard deviations (1.4826 x the median absolute deviation) over it."""
    floor = median(p)
    spread = 1.4826 * median(np.abs(p - floor))
    return p > floor + max(0.05 * (top - floor), OWN_CELL_SIGMAS * spread)


def _widened(cells: np.ndarray, n: int, margin: int) -> np.ndarray:
    """Mask of ``n`` cells: ``cells`` and ``margin`` cells either side of each."""
    keep = np.zeros(n, bool)
    for c in cells:
        keep[max(0, c - margin) : c + margin + 1] = True
    return keep


def _own_run(profile: np.ndarray, margin: int = 2) -> np.ndarray:
    """Indices of the run of cells holding the strongest response in a cell-energy profile.

    The cells standing out of the profile's floor (_Window.keep_own_cells' test: 5 % of the way from the median cell to
    the strongest, and OWN_CELL_SIGMAS robust standard deviations over it), widened by ``margin`` cells either side,
    and of those only the connected run around the strongest cell: a target's range track (its walk at a wrong
    blind-velocity alias included) is one run of cells; a run apart from it, floor cells between, is another target's.
    All cells when none stands out.
    """
    top = int(np.argmax(profile))
    own = _over_floor(profile, float(profile[top]))
    if not np.any(own):
        return np.arange(len(profile))
    keep = _widened(np.nonzero(own)[0], len(profile), margin)
    lo, hi = top, top
    while lo > 0 and keep[lo - 1]:
        lo -= 1
    while hi < len(keep) - 1 and keep[hi + 1]:
        hi += 1
    return np.arange(lo, hi + 1)


# A criterion cell stands this many robust standard deviations of the window's cell energies over their median
# (_Window.keep_own_cells): with 33 cells, a Gaussian spread's 4 sigma passes a noise cell in about 1 window in 1000
OWN_CELL_SIGMAS = 4.0
# One-sided significance of _incoherent's test: a window without a point target passes its eq. 5 dip for one in a
# hundred (a second stage after the CFAR, whose peaks are the windows tested)
POINT_TARGET_ALPHA = 0.01
# Sets of looks with unrelated phases searched as eq. 5 is, whose t at their minimum gives the selection's shift of
# _incoherent's critical value (_selection_shift; its standard error about 1 / sqrt(sets)): this many, fewer where
# their looks would pass SELECTION_LOOKS (the CPU is the looks'), never under SELECTION_REPLICAS_MIN
SELECTION_REPLICAS = 100
SELECTION_LOOKS = 1000
SELECTION_REPLICAS_MIN = 30
SELECTION_BATCH = 25  # sets drawn at a time: a window whose t is far from the critical value stops after one batch
NULL_FIT_HALF_WIDTH = 12  # azimuth samples either side of a mover's response kept and compared (_NullFit)
NULL_FIT_CELLS = 3  # range cells either side of it
PEAK_HALF_WIDTH = 8  # output samples either side of a focused detection searched for the refocused mover's peak
# azimuth samples either side kept as the mover when the fit focuses it at its own FM rate (_NullFit.rate; resolution
# 2.5 samples): whatever else is kept is modelled as moving with it, so clutter there biases v_los (the (-3, 12) MC,
# seed 9: v_r -0.095 m/s at +-12, -0.043 at +-6)
NULL_FIT_KEPT = 6
# A detection's ambiguity on a background this much (dB) under its own is examined first (_examination_order): the
# detection sits on the static scene's leakage through the clutter null (gaussian beam, scene 007: 17-26 dB lower)
LEAKAGE_BACKGROUND_DB = 10.0
NULL_FIT_MISMATCH = 0.3  # a velocity leaving more than this fraction of the residual response unexplained is wrong
# m/s: the null fit's trial v_a, at the mover's own FM rate, when no v_r at v_a = 0 explains the residual
# (_null_refit): each |v_a| <= 20 m/s within 4 m/s of one of them
NULL_FIT_ALONG_TRACK = (8.0, -8.0, 16.0, -16.0)
# A residual under this fraction of the static model's image energy at the same samples is a static response's
# residue, and the v_a search (_null_refit) is skipped (_NullFit.static_residue: measured xu_traffic_static's two
# static detections that reached it, -39 and -18 dB; the MC movers it finds +7.4 to +13.5 dB)
NULL_FIT_STATIC_RESIDUE = 0.1
# The null fit's minimum is taken as wide as its search's trials within this mismatch of it (_minimum_width): on
# scene 011 before the model band held the beam's skirt the accepted minimum 0.190 was a flat floor from -17.7 to
# -15.5 m/s within 0.01 and -17.9 to -15.3 within 0.02, stated to 0.13 m/s (docs/multichannel.md section 8)
NULL_FIT_FLAT = 0.02
# m/s of v_los: a null fit that overrules an eq. 5 estimate which is itself a mover's (|v_los| over
# detection_velocity: not clutter's pull to 0) by more than this is reported as ambiguous and its 1-sigma made at
# least the difference (xu_traffic's one overrule, V9: eq. 5 -0.01 m/s, static)
NULL_FIT_AMBIGUOUS = 1.0
# m/s of v_r: eq. 5's first search weighs a second minimum of its curve this far or farther from its estimate
# (_rival_minimum): nearer, it is the same minimum's noise (mover campaign scene 013's M1: -12.5 and -9.0 m/s)
RIVAL_APART = 4.0
# A mover whose detection is under the measured CFAR threshold, or (without the clutter null) any mover that eq. 5's
# search estimated, is tabled only with its line-of-sight speed this many 1-sigma over detection_velocity
# (_drop_under_threshold)
STATIC_SIGMAS = 2.0
# m/s: the first central-difference step of eq. 5's looks' scores (_leakage_spread; on mover campaign scene 014 its
# three windows' sigmas change by under 5 % between 0.1 and 0.5 m/s), and the least step of its curvature
LEAKAGE_SPREAD_STEP = 0.25
# _leakage_spread's curvature is measured between this many of its score's step and half of it either side (the
# points nearer the minimum, where the noise's own dip deepens the curve, left out): on one mover in noise 4 or more
# read the mean curve's curvature at the estimate (docs/multichannel.md section 24)
LEAKAGE_CURVATURE_STEPS = 5.0
LEAKAGE_SPREAD_ROUNDS = 6  # _leakage_spread's steps, each its last sigma, until they agree to 5 %
# A neighbour whose range side lobes (unweighted sinc envelope) reach a detection over this fraction of its power
# range-tapers its final eq. 5 search (_neighbours): scene 008's M3 and M4, -24 and -22 dB at M6 and M5, pulled them
# 0.15-0.2 m/s (docs/multichannel.md section 8)
NEIGHBOUR_LEVEL = 1e-3
RANGE_TAPER_CELLS = 8  # range cells either side of a window over which its range taper is applied (_range_tapered)
# _remove_response takes this many separation_bandwidths about a detection (raised cosine to 1.5 x that): as far as
# _others notches another detection, so all a detection's own response that its notches leave goes with it
REMOVAL_BANDS = 2.5
# _half_width: a neighbour narrows a detection's separation mask only beyond this many of the pair's larger measured
# Doppler width (the narrowed mask, offset / 2.5, still passes 2 of them either side). Mover campaign scene 038's M2
# (11 samples wide, 19.4 Hz from M3) stays merged at 5 and at 2.5; at 1.875 it is separated but its v_los reads 1.57
# m/s (true 4.09): too narrow a mask cuts a defocused mover's own spectrum (docs/multichannel.md section 17)
MASK_WIDTHS = 5.0
# ... and only for a neighbour at least this fraction of its power: the level from which _merge says a merged response
# looks like another target (a weaker one is more likely its own residue)
MERGE_LEVEL = 0.25
# ... and from this level for one at the mover's apparent time resolved from it in azimuth, without the clutter null
# (_merge); chosen, not tuned (scene 038's is 12.3 dB under): a level of the first pass's 30 dB range, not measured
MERGE_LEVEL_RESOLVED = 0.01
RANGE_CUT_SAMPLES = 6  # azimuth samples either side of a detection whose range cut is no background (_range_cuts)
# How far (in standard deviations of its background's amplitude, sqrt(background / 2)) the removals must take a
# detection's amplitude down to have taken its response (_visit): the background alone moves it by a Gaussian draw
TAKEN_SIGMAS = 3.0
STATIC_CELLS = 2  # range cells either side of an examined static detection that share its answer (_visit)


class _NullFit:
    """A mover's clutter-null residual predicted from a trial velocity, against the measured one (issue 19).

    Eq. (5) weighs everything in the window's channels: static clutter in the mover's cells and at its
    apparent time modulo PRF / K_a (which the dechirp mask keeps) pulls its minimum towards v_los = 0. The
    null removes that clutter but keeps of a slow mover only its channel phase 2 pi f_v tau_n, which sets
    the residual's amplitude (to first order in v_los) and sign against the mover's focused response. Per
    trial velocity: the window's in-band reconstruction (demodulated) is compressed and kept only at the
    mover's own response (its strongest peak among the positions k PRF / K_a apart, within the ghost walk
    of the detection's cell), taken back to channels through the trial channel model
    (channels.synthesise_channels), re-modulated, nulled and compressed as the detection image was; the
    mismatch is the energy of measured minus predicted residual around the detection, over the measured
    energy: near 0 for the right velocity, near 1 for one that predicts no residual (v_los = 0).
    """

    def __init__(
        self,
        win: _Window,
        index: int,
        cell: int,
        ka: np.ndarray,
        ka0: float,
        projector: np.ndarray,
        bank: channels.FilterBank,
        ghost_cells: int,
    ) -> None:
        g = win.g
        self.win, self.ka, self.ka0, self.proj, self.static_bank = win, ka, ka0, projector, bank
        self.index, self.cell, self.ghost_cells = index, cell, ghost_cells
        self.proj64 = projector.astype(np.complex64)  # what clutter_null multiplies by, converted once
        # the compression phasors (detection.compression) by FM rate, the static one and the last trial's: the same
        # values detection.compressed / decompressed compute, once per rate instead of once per transform
        self._phasors: dict[tuple[bool, bytes], np.ndarray] = {}
        self.n_out = g.n * len(g.times)
        self.spacing = g.prf / ka0 * g.n * g.prf  # samples between a response and its ambiguities
        # the band modelled: the beam's skirt beyond half_band included up to its recorded pattern's
        # (model_half_band), as the null passes whatever of it lies beyond its own band
        self.in_band = np.abs(win.out_f) <= max(g.half_band, g.model_half_band)
        # The residual response compared: the strongest near the detection in this window's own residual image
        # (the dechirp mask and the ghost's range walk can move it a few samples and cells from the detection).
        self.rows, self.cols = self._rows(index, 4 * NULL_FIT_HALF_WIDTH), self._cols(cell, ghost_cells)
        near = np.abs(self._residual(win.x)) ** 2
        i, c = np.unravel_index(int(np.argmax(near)), near.shape)
        self.index, self.cell = int(self.rows[i]), int(self.cols[c])
        self.rows, self.cols = self._rows(self.index), self._cols(self.cell)
        self.measured = self._residual(win.x)
        self.last_peak = float(self.index)  # where the last isolated() found the mover, output samples
        self.last_cell = self.cell  # and in which of the window's cells
        # compress the trial mover at its own FM rate (rate) rather than the static one: set by _null_refit
        # once v_a is searched, as only then is the trial v_a meant as the mover's
        self.at_mover_rate = False

    def _rows(self, centre: float, half: int = NULL_FIT_HALF_WIDTH) -> np.ndarray:
        c = int(round(centre))
        return np.arange(c - half, c + half + 1) % self.n_out

    def _cols(self, cell: int, half: int = NULL_FIT_CELLS) -> np.ndarray:
        return np.arange(max(0, cell - half), min(self.win.x.shape[2], cell + half + 1))

    def _phasor(self, ka: np.ndarray, inverse: bool) -> np.ndarray:
        """detection.compression(out_f, ka), or with ``inverse`` the phasor detection.decompressed multiplies by,
        kept for the static rate and the last other one (a trial's image and its 3 isolated movers share it)."""
        key = (inverse, np.asarray(ka, float).tobytes())
        if key not in self._phasors:
            static = (inverse, np.asarray(self.ka, float).tobytes())
            for k in [k for k in self._phasors if k[0] == inverse and k != static]:
                del self._phasors[k]
            out_f = self.win.out_f
            self._phasors[key] = detection.decompression(out_f, ka) if inverse else detection.compression(out_f, ka)
        return self._phasors[key]

    def _compressed(self, y_fa: np.ndarray, ka: np.ndarray) -> sfft.Ifft2Rows:
        """detection.compressed(y_fa, out_f, ka), its rows computed on demand (bit for bit the same values)."""
        # a copy of the phasor, not the phasor: numpy then multiplies into the temporary in place (temporary elision)
        # as it does into detection.compression's, which rounds unlike a product into a new array (its SIMD loop's
        # FMA) by a unit in the last place
        return sfft.Ifft2Rows(y_fa * self._phasor(ka, inverse=False).copy(), workers=-1)

    def _residual(self, x_tf: np.ndarray) -> np.ndarray:
        """The detection image of the window's nulled channels (as _detect_and_focus's), at the compared samples."""
        res = clutter_null(sfft.fft(x_tf, axis=1, workers=-1), self.win.g, projector=self.proj64)[0]
        img = self._compressed(channels.apply_filter_bank(res, self.static_bank), self.ka)
        # C order, as img[np.ix_(rows, cols)] was: the mismatch's float32 sums run in memory order
        return np.ascontiguousarray(img[self.rows][:, self.cols])

    def static_residue(self) -> float:
        """The measured residual's energy over that of the static model's image at the same samples (the window's
        in-band reconstruction at v = 0, compressed at the static FM rate): what the clutter null kept there.

        The null cancels a static response but for its floor, a small fraction of its image at the same samples.
        A slow mover's residual is its channel-phase mismatch, which the static reconstruction puts in the same
        samples (as the mover's ambiguity) without cancelling it: about as much energy as the residual, less only
        by the clutter the null removed there."""
        spec = self.win.demodulated_spectrum(0.0, 0.0) * self.in_band[:, None]
        static = detection.compressed(spec, self.win.out_f, self.ka)[np.ix_(self.rows, self.cols)]
        total = float(np.sum(np.abs(static) ** 2))
        return float(np.sum(np.abs(self.measured) ** 2)) / total if total > 0 else math.inf

    def rate(self, v_r: float, v_a: float) -> np.ndarray:
        """The FM rate K_a(f_r) the trial image is compressed at: the static one, or with ``at_mover_rate`` the
        trial mover's, the static one scaled by R''_mover / R''_static.

        At the static rate a mover of v_a 12 m/s (R'' -0.36 %) spreads over 27 samples of its 0.76 s illumination,
        more than the +-12 kept, and lies under the clutter focused beside it, which the fit then isolated instead
        (docs/multichannel.md section 8, "Why (-3, 12) is missed"). The mover's rate is used only at a trial v_a
        meant as the mover's: at the first search's v_a = 0 the trial v_r is v_los / cos(theta), which holds
        v_a tan(theta) besides v_r, and R'' ~ ((v - v_a) cos + v_r sin)^2 then takes the FM rate of a mover whose
        v_a is off by v_a / cos^2 rather than the static rate's v_a - v_r tan(theta) (xu_traffic V11: 13.6 against
        10.2 m/s, its mismatch at eq. 5's estimate 0.38 against 0.19, and lost; section 8)."""
        if not self.at_mover_rate:
            return self.ka
        g = self.win.g
        static = velocity.range_acceleration(g.velocity, 0.0, 0.0, g.squint, 1.0)
        return self.ka * (velocity.range_acceleration(g.velocity, v_a, v_r, g.squint, 1.0) / static)

    def image(self, v_r: float, v_a: float) -> sfft.Ifft2Rows:
        """The window's in-band reconstruction for the trial velocity, demodulated and compressed (t', cell) at
        :meth:`rate` (its rows on demand: :meth:`isolated` reads a few dozen)."""
        spec = self.win.demodulated_spectrum(v_r, v_a) * self.in_band[:, None]
        return self._compressed(spec, self.rate(v_r, v_a))

    def isolated(
        self,
        v_r: float,
        v_a: float,
        shift: int,
        half_width: int | None = None,
        image: sfft.Ifft2Rows | None = None,
        cells: np.ndarray | None = None,
    ) -> np.ndarray:
        """The window's channels (N, n_az, L) of the mover alone as the trial velocity sees it (class doc).

        The mover is taken to appear ``shift`` x PRF / K_a from the detection (a slow mover's residual peaks one
        such step away from it): its strongest peak there (a local maximum, not a neighbour's skirt at the edge of
        the search), within the ghost walk of the detection's cell, is kept over +-``half_width`` samples and
        NULL_FIT_CELLS cells (``half_width`` None: NULL_FIT_HALF_WIDTH, or NULL_FIT_KEPT at the mover's FM rate).
        ``image``: :meth:`image` of the same trial, if already computed. ``cells``: the window cells the peak is
        searched in instead of the ghost walk's (those of them inside it; all of the walk's where none is).
        """
        g, win = self.win.g, self.win
        if half_width is None:
            half_width = NULL_FIT_KEPT if self.at_mover_rate else NULL_FIT_HALF_WIDTH
        img = self.image(v_r, v_a) if image is None else image
        v_los = channels.line_of_sight_velocity(v_r, v_a, g.squint)
        # removing the trial Doppler offset moves every response by 2 v_los / (lambda K_a)
        centre = self.index + 2 * v_los * g.fc / C / self.ka0 * g.n * g.prf - shift * self.spacing
        near = self._cols(self.cell, self.ghost_cells)
        if cells is not None and np.isin(near, cells).any():
            near = near[np.isin(near, cells)]
        sub = np.abs(np.ascontiguousarray(img[self._rows(centre)][:, near])) ** 2
        sub[[0, -1], :] = 0.0
        j = np.unravel_index(int(np.argmax(sub)), sub.shape)
        peak = centre - NULL_FIT_HALF_WIDTH + int(j[0])
        self.last_peak = (peak - 2 * v_los * g.fc / C / self.ka0 * g.n * g.prf) % self.n_out  # Doppler restored
        rows = self._rows(peak, half_width)
        self.last_cell = int(near[j[1]])
        cols = self._cols(self.last_cell)
        # the image kept at (rows, cols), zero elsewhere, and detection.decompressed of it: fft2 transforms only
        # the kept columns along azimuth (a zero line stays zero: sfft.fftn_of_box, bit for bit)
        own = np.zeros((self.n_out, len(cols)), np.complex64)
        own[rows] = img[rows][:, cols]
        rate = self.rate(v_r, v_a)
        # one expression of temporaries, as detection.decompressed(...) * in_band was: the same in-place products
        spec = (
            sfft.fftn_of_box(own, (0, int(cols[0])), (self.n_out, len(win.f_r)), workers=-1)
            * self._phasor(rate, inverse=True).copy()
            * self.in_band[:, None]
        )
        x_dem = sfft.ifft(channels.synthesise_channels(spec, win.bank(v_a)), axis=1, workers=-1)
        return x_dem * deramp.doppler_shift_phasor(g.times, win.f_r, v_los, g.fc, sign=+1)[None]

    def fit(self, v_r: float, v_a: float) -> tuple[float, int]:
        """(mismatch, shift): the energy of the measured residual minus the predicted one, over the measured, for
        the best of the mover's positions 0, +-1 x PRF / K_a from the detection."""
        total = float(np.sum(np.abs(self.measured) ** 2))
        if total <= 0:
            return 0.0, 0
        best = (math.inf, 0)
        img = self.image(v_r, v_a)
        for shift in (0, -1, 1):
            predicted = self._residual(self.isolated(v_r, v_a, shift, image=img))
            best = min(best, (float(np.sum(np.abs(self.measured - predicted) ** 2) / total), shift))
        return best

    def mismatch(self, v_r: float, v_a: float) -> float:
        return self.fit(v_r, v_a)[0]


@dataclasses.dataclass
class _Estimate:
    """One window's velocities as the steps of ``_estimate`` refine them."""

    v_r: float  # m/s, slant range
    v_a: float  # m/s, along track
    criterion: Callable[[float, float], float]  # of (v_r, v_a): eq. 5 (the window's leakage) or the null fit's
    result: velocity.SearchResult | None = None  # the slant-range search (None: v_r given, or no band to search)
    beyond: bool = False  # no slant-range velocity inside the bounds removes the range walk
    by_null_fit: bool = False  # the criterion is the null fit's mismatch (eq. 5 left the residual unexplained)
    null_width: float = 0.0  # m/s of v_los: the null fit's accepted minimum's half-width (_minimum_width)
    # (eq. 5's v_los, the null fit's) where the null fit overruled an eq. 5 estimate of a mover (None: it did not)
    overruled: tuple[float, float] | None = None
    from_rest: bool = False  # the null fit replaced an eq. 5 estimate under detection_velocity (_null_refit)
    # neither eq. 5 nor the null fit's search explains the clutter-null residual: (eq. 5's v_r and its mismatch,
    # the null fit's best v_r and its mismatch); None when one of them does, or without the null fit
    unexplained: tuple[float, float, float, float] | None = None
    # eq. 5's two minima its looks do not tell apart (_rival_minimum): (reported v_r, other v_r, t, critical t, the
    # reported one's range walk, the other's; at the first search's v_a); None: one minimum, or one significantly lower
    rival: tuple[float, float, float, float, float, float] | None = None
    autofocus: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros((0, 2)))  # (n, 2) v_a, sharpness
    autofocus_snr: float = math.inf  # integrated signal to clutter-plus-noise ratio the autofocus saw (_autofocus_snr)
    pull: float = float("nan")  # m/s: v_a's offset on the mover's illumination alone (illumination_pull)

    def v_los(self, g: _Geometry) -> float:
        return channels.line_of_sight_velocity(self.v_r, self.v_a, g.squint)


@dataclasses.dataclass(frozen=True)
class _Centre:
    """Where a mover's energy is centred in time: its beam-centre time and range, the cells its autofocus uses."""

    y_dem: np.ndarray  # the window's demodulated reconstruction in (t', f_r)
    t_c: float  # s, beam-centre time
    slant_range: float  # m, at t_c
    own_cells: np.ndarray | None  # the cells holding half of the null fit's isolated mover (None: eq. 5 kept)
    shift: int | None  # the null fit's ambiguity step of the mover (None: eq. 5 kept)
    cell: float  # the window cell whose walk-corrected range slant_range was taken from (the detection's)


def _search(
    est: _Estimate, params: ReconstructParams, v_a: float, lo: float, hi: float, coarse: float
) -> velocity.SearchResult:
    """Search v_r in [lo, hi] by the estimate's current criterion at along-track velocity ``v_a``."""
    criterion = est.criterion
    return velocity.fast_search(
        lambda u: criterion(u, v_a),
        lo,
        hi,
        params.velocity_step,
        coarse,
        exhaustive=params.search == "exhaustive",
    )


def _first_search(win: _Window, params: ReconstructParams, g: _Geometry, can_search: bool) -> _Estimate:
    """v_r by eq. 5 over the bounds at the given (or zero) v_a, the blind-velocity alias chosen by range walk."""
    v_a = params.along_track_velocity if params.along_track_velocity is not None else 0.0
    est = _Estimate(v_r=0.0, v_a=v_a, criterion=win.leakage)
    if params.radial_velocity is not None:
        est.v_r = params.radial_velocity
        return est
    if not can_search:
        return est
    result = _search(est, params, v_a, params.velocity_min, params.velocity_max, params.coarse_step)
    reach = _along_track_reach(params, g)
    v_r, est.beyond = _resolve_blind_velocity(win, result.estimate, v_a, params, g, reach)
    if abs(v_r - result.estimate) > params.velocity_step:
        lo, hi = (
            max(params.velocity_min - reach, v_r - params.coarse_step),
            min(params.velocity_max + reach, v_r + params.coarse_step),
        )
        alias = _search(est, params, v_a, lo, hi, params.coarse_step / 4)
        trials = np.concatenate([result.trials, alias.trials])
        result = velocity.SearchResult(
            alias.estimate, alias.at_bound, trials[np.argsort(trials[:, 0])], result.evaluations + alias.evaluations
        )
        v_r = alias.estimate
    est.v_r, est.result = v_r, result
    return est


def _rival_minimum(est: _Estimate, win: _Window, params: ReconstructParams, g: _Geometry, mover_above: float) -> None:
    """Eq. 5's curve with a second minimum, apart from the estimate's, that its looks do not tell from it.

    The first search's coarse trials may hold another local minimum at least RIVAL_APART from the estimate, in a
    basin of its own (the curve between them rises over it by half its dip under the curve's median,
    velocity.curve_median), both a mover's (|v_los| >= ``mover_above``). It is searched to the search's step, and the
    two compared look by look (_Window.leakage_looks: noise is independent between looks): d_k = O_k / T_k at the
    other minimum less at the estimate, t = mean(d) / (s / sqrt(n)). A t over the one-sided POINT_TARGET_ALPHA point
    of Student's (n - 1 degrees of freedom) keeps the estimate: eq. 5 is significantly lower there. Otherwise the data's
    eq. 5 cannot tell them apart (mover campaign scene 013 band-limited: M2, v_r 16.77 m/s, 16.9 dB in noise, partly
    lit past the data's end, its minimum at +18.2 m/s at v_a 0 and another at -17.0, 0.0038 lower, t 0.4;
    docs/multichannel.md section 32): the one with the smaller residual range walk (_Window.walk_rate, the only other
    evidence; in noise it reads far under the true walk, but in order) is kept, est.rival records both, and _estimate
    warns with both (the 1-sigma stays eq. 5's at the one kept: two discrete candidates are no spread, and one as
    wide as their difference took the scene's true M1 and M2 for static, _drop_under_threshold)."""
    if est.result is None or len(est.result.trials) < 3:
        return
    trials = est.result.trials
    coarse = trials[np.isclose(np.mod(trials[:, 0] - params.velocity_min + 1e-9, params.coarse_step), 0, atol=1e-6)]
    if len(coarse) < 3:
        return
    u, y = coarse[:, 0], coarse[:, 1]
    level = velocity.curve_median(trials)
    best, rival = est.criterion(est.v_r, est.v_a), None
    for i in range(len(u)):
        # a bound's trial is no minimum: the curve may fall on beyond it (a blind-velocity alias's basin)
        if i in (0, len(u) - 1) or abs(u[i] - est.v_r) < RIVAL_APART or y[i] > min(y[i - 1], y[i + 1]):
            continue
        if abs(channels.line_of_sight_velocity(u[i], est.v_a, g.squint)) < mover_above:
            continue
        between = y[(u > min(u[i], est.v_r)) & (u < max(u[i], est.v_r))]
        if len(between) == 0 or between.max() - max(y[i], best) < 0.5 * (level - y[i]):
            continue
        if rival is None or y[i] < rival[1]:
            rival = (float(u[i]), float(y[i]))
    if rival is None:
        return
    lo = max(params.velocity_min, rival[0] - params.coarse_step)
    hi = min(params.velocity_max, rival[0] + params.coarse_step)
    found = _search(est, params, est.v_a, lo, hi, params.coarse_step / 4)
    other = found.estimate
    o1, t1 = win.leakage_looks(est.v_r, est.v_a)
    o2, t2 = win.leakage_looks(other, est.v_a)
    d = o2 / np.maximum(t2, 1e-300) - o1 / np.maximum(t1, 1e-300)
    if len(d) < 2:
        return
    from scipy.special import stdtrit  # Student's t (scipy.stats' import costs about 0.5 s of CPU)

    sd, mean = float(np.std(d, ddof=1)), float(np.mean(d))
    t = mean / (sd / math.sqrt(len(d))) if sd > 0 else (math.inf if mean > 0 else 0.0)
    critical = float(stdtrit(len(d) - 1, 1 - POINT_TARGET_ALPHA))
    log.debug(
        "reconstruct: eq. 5's other minimum %.2f m/s (estimate %.2f): higher by t %.2f (apart: > %.2f)",
        other,
        est.v_r,
        t,
        critical,
    )
    if t > critical:
        return
    walk, walk_other = abs(win.walk_rate(est.v_r, est.v_a)), abs(win.walk_rate(other, est.v_a))
    if walk_other < walk:
        est.v_r, other, walk, walk_other = other, est.v_r, walk_other, walk
        merged = np.concatenate([trials, found.trials])
        est.result = velocity.SearchResult(est.v_r, found.at_bound, merged[np.argsort(merged[:, 0])], len(merged))
    est.rival = (est.v_r, other, t, critical, walk, walk_other)


def _minimum_width(result: velocity.SearchResult, margin: float = NULL_FIT_FLAT) -> float:
    """Half the span (m/s) of a search's trials within ``margin`` of its least criterion value: how flat the minimum
    it accepted is (a noisy floor gives no one velocity, whatever the parabola through its least three says)."""
    trials = result.trials
    if len(trials) == 0:
        return 0.0
    near = trials[trials[:, 1] <= trials[:, 1].min() + margin, 0]
    return float(near.max() - near.min()) / 2


def _null_refit(
    est: _Estimate,
    params: ReconstructParams,
    null_fit: _NullFit,
    mover_above: float | None = None,
    squint: float = 0.0,
) -> None:
    """When eq. 5's v_r leaves more than NULL_FIT_MISMATCH of the null residual unexplained, search v_r by the null
    fit instead and keep that criterion if its estimate explains the residual.

    The fit first models the mover at the first search's v_a (0 unless given) and the static FM rate. When no v_r
    explains the residual there (a mover whose v_a spreads it beside focused clutter: (-3, 12) m/s), v_r is searched
    again at each of NULL_FIT_ALONG_TRACK with the fit at the trial mover's FM rate (_NullFit.rate), and the best
    kept with its v_a (the autofocus's starting point) and that rate; not where the residual is a static response's
    residue (_NullFit.static_residue under NULL_FIT_STATIC_RESIDUE), which no mover's velocity explains.

    Where it is kept: the width of its minimum (_minimum_width, in v_los), and with ``mover_above`` (m/s,
    detection_velocity; ``squint`` the geometry's) whether it overruled an eq. 5 estimate that is a mover's by
    more than NULL_FIT_AMBIGUOUS (eq. 5 pulled by clutter reads near 0 and is overruled as the fit intends:
    xu_traffic V9)."""
    v_r, v_a = est.v_r, est.v_a
    if est.result is None or (eq5 := null_fit.mismatch(v_r, v_a)) <= NULL_FIT_MISMATCH:
        return

    def refit_at(u_a: float) -> tuple[velocity.SearchResult, float]:
        found = velocity.fast_search(
            lambda u: null_fit.mismatch(u, u_a),
            params.velocity_min,
            params.velocity_max,
            params.velocity_step,
            params.coarse_step,
            exhaustive=params.search == "exhaustive",
        )
        return found, null_fit.mismatch(found.estimate, u_a)

    refit, best = refit_at(v_a)
    refit_v_a = v_a
    log.debug(
        "reconstruct: eq. 5 gives %.2f m/s (null-fit mismatch %.2f), the null fit %.2f m/s (%.2f)",
        v_r,
        eq5,
        refit.estimate,
        best,
    )
    if best > NULL_FIT_MISMATCH and params.along_track_velocity is None:
        kept = null_fit.static_residue()
        if kept < NULL_FIT_STATIC_RESIDUE:
            # a static response's residue (xu_traffic_static: two beside S2, 25 s of searching each for nothing)
            log.debug("reconstruct: the null kept %.3g of the static image at the detection: v_a not searched", kept)
        else:
            null_fit.at_mover_rate = True
            for u_a in NULL_FIT_ALONG_TRACK:
                trial, m = refit_at(u_a)
                log.debug(
                    "reconstruct: the null fit at v_a %.0f m/s, its FM rate: %.2f m/s (%.2f)", u_a, trial.estimate, m
                )
                if m < best:
                    refit, best, refit_v_a = trial, m, u_a
            null_fit.at_mover_rate = refit_v_a != v_a and best <= NULL_FIT_MISMATCH
    if best > NULL_FIT_MISMATCH:
        est.unexplained = (v_r, eq5, refit.estimate, best)
    else:
        log.info(
            "reconstruct: eq. 5 gave %.2f m/s, which leaves the clutter-null residual unexplained; the null fit "
            "gives %.2f m/s at v_a %.0f m/s",
            v_r,
            refit.estimate,
            refit_v_a,
        )
        los_eq5 = channels.line_of_sight_velocity(v_r, v_a, squint)
        los_fit = channels.line_of_sight_velocity(refit.estimate, refit_v_a, squint)
        est.null_width = _minimum_width(refit) * math.cos(squint)
        if mover_above is not None and abs(los_eq5) >= mover_above and abs(los_eq5 - los_fit) > NULL_FIT_AMBIGUOUS:
            est.overruled = (los_eq5, los_fit)
        est.from_rest = mover_above is not None and abs(los_eq5) < mover_above
        log.debug(
            "reconstruct: the null fit's minimum spans +-%.2f m/s of v_los within %.2f of its mismatch",
            est.null_width,
            NULL_FIT_FLAT,
        )
        est.v_r, est.v_a, est.result, est.criterion, est.by_null_fit = (
            refit.estimate,
            refit_v_a,
            refit,
            null_fit.mismatch,
            True,
        )


def _leakage_spread(
    win: _Window, v_r: float, v_a: float, step: float = LEAKAGE_SPREAD_STEP, criterion: bool = False
) -> float:
    """1-sigma (m/s of the searched v_r, at ``v_a``) of eq. 5's minimum at ``v_r`` from its looks' disagreement.

    Eq. 5's estimate minimises L(u) = sum_k O_k(u) / sum_k T_k(u) over the looks k (_Window.leakage_looks); at the
    minimum sum_k s_k = L'(u) = 0 with s_k = (O_k' - L T_k') / T. Where the window holds one point target and noise,
    each s_k is noise with mean 0, and the M-estimator's (sandwich) variance is var(sum_k s_k) / L''^2, var(sum s_k)
    estimated by n / (n - 1) sum_k s_k^2: the curvature of eq. 5 relative to how far the looks' own minima disagree.
    Where the window holds a mixture (clutter scatterers, side lobes), the looks see it mixed differently and their
    minima disagree however high the SNR (mover campaign scene 014's clutter read at v_r -1.34 m/s: looks' minima
    from -2 to beyond +1.7 m/s; eq. 5 only 3.4 % under its value at rest): the SNR's curvature bound misses that.

    Noise is not smooth in u: as the trial Doppler moves, the noise's Doppler bins cross the band's edges one by one,
    so its part of L is a random walk (its increments' variance grows as |du|, measured from 0.01 to 1 m/s), and the
    minimum's scatter is that of a parabola plus a random walk (Chernoff's), not -L' / L'' at any fixed step. Two
    things follow (docs/multichannel.md section 24). (1) The score's central difference over h has the walk's variance
    sigma_w^2 / 2h: it is taken over the estimate's own sigma (h iterated to sigma(h), from ``step``, no finer than
    the search's step, over which its parabola takes the estimate, nor one output Doppler bin; at most 4 ``step``),
    where the linear sandwich gives the parabola-plus-walk's scatter (Chernoff's variance 0.26) to 3 %. (2) The
    curvature at the estimate is where the walk made a dip: over ``step`` it read 1.3-1.6x the mean curve's (one mover
    at -5 dB per sample), and varied 42 % from draw to draw; it is measured as the difference of L at +-H and +-H / 2
    (H = LEAKAGE_CURVATURE_STEPS x h, at least ``step``), the dip at the minimum left out. Before both, the stated
    sigma was 0.6-0.7 of the scatter over 64 noise draws. 0 where there is no minimum (that curvature <= 0) or fewer
    than 2 looks."""
    # ``criterion``: the looks of the range-tapered channels (final_leakage) where a neighbour tapered the final
    # search, else of the channels themselves
    g = win.g
    # m/s of v_r: the search's step (its parabola's differences are over it) or one output Doppler bin
    finest = max(win.params.velocity_step, C / g.fc * g.prf / (2 * len(g.times) * math.cos(g.squint)))
    cache: dict[float, tuple[np.ndarray, np.ndarray]] = {}

    def looks(du: float) -> tuple[np.ndarray, np.ndarray]:
        if du not in cache:
            cache[du] = win.leakage_looks(v_r + du, v_a, criterion)
        return cache[du]

    def at(du: float) -> float:
        o, t = looks(du)
        total = float(t.sum())
        return float(o.sum()) / total if total > 0 else math.nan

    o0, t0 = looks(0.0)
    n, total = len(o0), float(t0.sum())
    if n < 2 or total <= 0:
        return 0.0
    h, spread = step, 0.0
    for _ in range(LEAKAGE_SPREAD_ROUNDS):
        wide = max(step, LEAKAGE_CURVATURE_STEPS * h)
        curvature = ((at(wide) + at(-wide)) - (at(wide / 2) + at(-wide / 2))) / (0.75 * wide**2)
        (om, tm), (op, tp) = looks(-h), looks(h)
        if not curvature > 0 or tm.sum() <= 0 or tp.sum() <= 0:
            return 0.0
        score = ((op - om) - at(0.0) * (tp - tm)) / (2 * h * total)
        spread = float(math.sqrt(n / (n - 1) * float(np.sum(score**2))) / curvature)
        following = min(max(spread, finest), 4 * step)
        if abs(following - h) <= 0.05 * h:
            break
        h = following
    return spread


def _centre(
    win: _Window, g: _Geometry, est: _Estimate, centre_range: float, centre_cell: float, null_fit: _NullFit | None
) -> _Centre:
    """The mover's beam-centre time (its energy's centroid in t') and the slant range there (``centre_range``, the
    walk-corrected range of window cell ``centre_cell``, less the walk to t_c; _autofocus refines both)."""
    y_dem = sfft.ifft(win.demodulated_spectrum(est.v_r, est.v_a), axis=0, workers=-1)
    own_cells = None
    shift = None
    if null_fit is not None and est.by_null_fit:
        # The clutter that outweighs the mover in its window also pulls its beam-centre time and autofocus (clutter
        # is sharpest at v_a = 0): both use only the range cells holding half of the isolated mover's peak.
        shift = null_fit.fit(est.v_r, est.v_a)[1]
        iso = null_fit.isolated(est.v_r, est.v_a, shift)
        iso_power = np.sum(np.abs(sfft.ifft(iso, axis=-1, workers=-1)) ** 2, axis=(0, 1))
        own_cells = np.nonzero(iso_power >= 0.5 * iso_power.max())[0]
    if win.gate is not None:  # another target at its Doppler in the window's other cells
        own_cells = win.gate if own_cells is None else np.intersect1d(own_cells, win.gate)
    p = np.sum(np.abs(y_dem if own_cells is None else sfft.ifft(y_dem, axis=1, workers=-1)[:, own_cells]) ** 2, axis=1)
    t_c = float(np.sum(g.out_times * p) / np.sum(p)) if np.sum(p) > 0 else 0.0
    slant_range = centre_range - g.velocity * math.sin(g.squint) * t_c
    return _Centre(y_dem, t_c, slant_range, own_cells, shift, centre_cell)


# Power, as a fraction of the lit plateau, at which a mover's sharp (rect beam) illumination edge is located: the
# separation's pass band (detection.extract) smooths the edge symmetrically about it, amplitude 1/2 there
LIT_EDGE = 0.25


@dataclasses.dataclass(frozen=True)
class _LitSpan:
    """Eq. 5 on a mover lit past the data's start or end (_lit_span)."""

    weight: np.ndarray  # (N n_az,) float32 over the output time: the span, its envelope flattened; 0 outside
    half_band: float  # Hz: K_a h, the Doppler half band the span holds
    ka: float  # Hz/s: the azimuth FM rate at the mover's range
    cut: float  # s: the mover's illumination outside the data
    t_0: float  # s: its beam-centre time, from its lit edge inside the data
    middle: float  # s: the middle of its lit part, t_0 -+ cut / 2 (where the autofocus measures R'', _autofocus)
    at_end: bool  # cut by the data's end (its band's low Doppler lost), else by their start (its high Doppler)


def _lit_span(
    y_dem: np.ndarray, cells: np.ndarray | None, g: _Geometry, reach: float, slant_range: float
) -> _LitSpan | None:
    """Where a rect beam's mover is lit past the data's start or end: the span of output time symmetric about its
    beam-centre time that the data hold, over which eq. 5 is unbiased again (None: lit whole, or no sharp edge to
    tell it by).

    A rect beam lights a point for t_ill = B_a / K_a; past the data's end its Doppler band lacks K_a c on one side (c
    the time cut). Eq. 5's band |f| <= B_a / 2 then lets the narrower band slide into the cut at no cost, and its
    minimum settles in it (docs/multichannel.md sections 18 and 21). The lit edge inside the data is the beam's: the
    beam-centre time is t_0 = t_1 + t_ill / 2 (start edge t_1, the end cut; mirrored for the start), and the
    reconstruction kept to |t' - t_0| <= h, h = (data end - ``reach``) - t_0, holds the band |f| <= K_a h whole at
    the true velocity, its two edges made alike by the same cut. ``reach`` (s) keeps the span off the data's edge,
    where the separation's pass band smooths the mover's energy and wraps it to the other end; within the span the
    envelope is flattened (its power smoothed over one pulse, divided out) so the ripple that smoothing leaves does
    not weigh one band edge over the other.

    ``y_dem`` (t', f_r) the window's demodulated reconstruction at the first estimate, ``cells`` the criterion's
    range cells (None: all). The edges: the longest run of output samples over LIT_EDGE of the plateau (the median
    over half the peak), interpolated. Only a rect beam has such an edge; the run must be shorter than t_ill by
    more than one output sample, longer than half of it, and touch one data edge (within ``reach``) only."""
    y = sfft.ifft(y_dem, axis=1, workers=-1)
    if cells is not None:
        y = y[:, cells]
    p = np.sum(np.abs(y) ** 2, axis=1)
    if not p.max() > 0:
        return None
    if g.antenna_pattern != "rect":
        return _pattern_span(p, g, reach, slant_range)
    plateau = median(p[p > 0.5 * p.max()])
    level = LIT_EDGE * plateau
    d = np.diff(np.concatenate([[0], (p > level).astype(np.int8), [0]]))
    starts, ends = np.nonzero(d == 1)[0], np.nonzero(d == -1)[0]
    k = int(np.argmax(ends - starts))
    i1, i2 = int(starts[k]), int(ends[k]) - 1
    t = g.out_times
    dt = 1.0 / (g.n * g.prf)
    t_start, t_end = float(t[0]), float(t[-1]) + dt
    t1 = float(t[i1] - dt * (p[i1] - level) / (p[i1] - p[i1 - 1])) if i1 > 0 else t_start
    t2 = float(t[i2] + dt * (p[i2] - level) / (p[i2] - p[i2 + 1])) if i2 < len(p) - 1 else t_end
    ka, t_ill = _illumination(g, slant_range)
    at_end, at_start = t_end - t2 < reach, t1 - t_start < reach
    if at_end == at_start or not t_ill / 2 < t2 - t1 < t_ill - dt:
        return None
    if at_end:  # the start edge t1 is the beam's
        t_0, cut, middle = t1 + t_ill / 2, t1 + t_ill - t_end, (t1 + t_end) / 2
        h = t_end - reach - t_0
    else:
        t_0, cut, middle = t2 - t_ill / 2, t_start - (t2 - t_ill), (t_start + t2) / 2
        h = t_0 - (t_start + reach)
    if not (cut > dt and h > t_ill / 4):
        return None
    smooth = np.convolve(p, np.ones(g.n) / g.n, mode="same")
    inside = np.abs(t - t_0) <= h
    weight = np.zeros(len(p), np.float32)
    weight[inside] = 1.0 / np.sqrt(np.maximum(smooth[inside], 1e-6 * plateau))
    return _LitSpan(weight, ka * h, ka, cut, t_0, middle, at_end)


def _illumination(g: _Geometry, slant_range: float) -> tuple[float, float]:
    """A static point's azimuth FM rate K_a at ``slant_range`` (eq. 7 at the carrier: :func:`detection.fm_rate` at
    f_r = 0, written as 2 (v cos theta)^2 / (lambda R) so the lit spans keep their bits) and the time
    t_ill = B_a / K_a the beam's band lights it for (the lit span's and the pattern span's scale)."""
    ka = 2 * (g.velocity * math.cos(g.squint)) ** 2 / (C / g.fc * slant_range)
    return ka, 2 * g.half_band / ka


def _pattern_envelope(f: np.ndarray, g: _Geometry) -> np.ndarray:
    """The two-way power of the recorded (non-rect) azimuth pattern at Doppler ``f`` (Hz) from the beam's centre, 1
    there; the -3 dB one-way band is 2 g.half_band (small angles: the pattern's angle over its beamwidth is f / B_a)."""
    return beam.one_way_amplitude(1e-3 * f / (2 * g.half_band), 1e-3, g.antenna_pattern) ** 4


def _pattern_span(p: np.ndarray, g: _Geometry, reach: float, slant_range: float) -> _LitSpan | None:
    """_lit_span for a beam with no sharp edge (sinc, gaussian): the beam-centre time t_0 from the recorded pattern's
    two-way envelope P(K_a (t' - t_0)) fitted (least squares, free amplitude) to the reconstruction's power ``p``
    within the data (``reach`` off either edge, where the separation smooths and wraps it), and the span
    |t' - t_0| <= h, h the lesser of the data's hold either side of t_0 (less ``reach``) and t_ill / 2 (eq. 5's
    band B_a / 2: the pattern's -3 dB band), its envelope flattened as the rect beam's. Over the span the mover's
    demodulated spectrum at its true velocity is flat and symmetric about 0 whatever the pattern, so eq. 5 on it is
    unbiased where the data cut the pattern's skirt (model_half_band) on one side more than on the other (the
    sinc's skirt, 1.71 B_a / 2, lasts 0.775 s on xu_small's radar: past 0.6 s of data wherever the mover is;
    docs/multichannel.md section 26). None where the data hold the skirt whole or h is under t_ill / 4. ``cut`` is
    the skirt's one-sided excess: how much more of it the nearer data edge cuts."""
    t = g.out_times
    dt = 1.0 / (g.n * g.prf)
    t_start, t_end = float(t[0]), float(t[-1]) + dt
    ka, t_ill = _illumination(g, slant_range)
    skirt = max(g.model_half_band, g.half_band) / ka
    inner = (t >= t_start + reach) & (t <= t_end - reach)
    if np.count_nonzero(inner) < 3:
        return None
    # t_0: the envelope smoothed over one pulse and kept every k-th sample (it varies over tens of ms), searched on
    # that coarse grid, then on the output samples within k of the best, then a parabola through the best and its
    # neighbours (the cost is that of a few thousand envelopes, not of the output samples squared)
    smooth = np.convolve(p, np.ones(g.n) / g.n, mode="same")
    k = max(1, int(np.count_nonzero(inner)) // 256)
    tk, pk = t[inner][::k], smooth[inner][::k]

    def score(centres: np.ndarray) -> np.ndarray:
        m = _pattern_envelope(ka * (tk[None, :] - centres[:, None]), g)
        return (m @ pk) ** 2 / np.maximum(np.sum(m**2, axis=1), 1e-300)

    j = int(np.argmax(score(tk)))
    fine = t[inner][max(0, j * k - k) : j * k + k + 1]
    s_fine = score(fine)
    j = int(np.argmax(s_fine))
    t_0 = float(fine[j])
    if 0 < j < len(fine) - 1:
        a, b, c = s_fine[j - 1], s_fine[j], s_fine[j + 1]
        if a - 2 * b + c < 0:
            t_0 += dt * 0.5 * (a - c) / (a - 2 * b + c)
    left, right = t_0 - t_start, t_end - t_0
    if min(left, right) >= skirt:  # the data hold the skirt whole: eq. 5 on the whole band as before
        return None
    h = min(left - reach, right - reach, t_ill / 2)
    if not h > t_ill / 4:
        return None
    at_end = right < left
    cut = min(skirt, max(left, right)) - min(skirt, min(left, right))
    plateau = float(p.max())
    inside = np.abs(t - t_0) <= h
    weight = np.zeros(len(p), np.float32)
    weight[inside] = 1.0 / np.sqrt(np.maximum(smooth[inside], 1e-6 * plateau))
    # _autofocus runs on the span itself, the cubic term about t_0 taken out: R'' is measured at t_0 (middle = t_0)
    return _LitSpan(weight, ka * h, ka, cut, t_0, t_0, at_end)


def _incoherent(
    est: _Estimate, win: _Window, g: _Geometry, flat_above: float, params: ReconstructParams | None = None
) -> bool:
    """No point target: eq. 5 has no dip at the estimate (over ``flat_above`` of the curve's median over the span
    searched, velocity.curve_median), or as much energy out of band as white noise has (1 - B_a / (N PRF)), or its
    dip is not significantly lower than the same channels with unrelated phases give (_coherence_t's Student's t
    under its one-sided POINT_TARGET_ALPHA point moved up by what the search's choice of its minimum gives noise,
    _selection_shift; computed only where t lies between that point and the Bonferroni point of every trial the
    search can reach).

    The significance test asks what eq. 5's dip is made of. A point target's channels are related by the phases of
    its velocity: reconstructed at it, its energy comes together in band, and eq. 5 falls below what the same
    channels with unrelated phases give (the filter bank's |P|^2 on their power spectra, _Window.coherence_looks).
    Noise has no such relation: whatever dip its eq. 5 has (the extraction's band, where the trial Doppler centres
    it: mover campaign scenes 016 and 017, two noise detections at 20-21 dB, 0.941 of the curve's median) the
    unrelated phases give too (0.994, 0.997 of it). Session 34 kept those out by the trials' plain median (crowded
    at the minima) where no criterion cell stands out of the window's floor, and so missed movers there; the test
    replaces that switch. The dip itself is still asked for: a static point at 18.6 dB (scene 015's S2, eq. 5's
    minimum pulled to 8.8 m/s by the noise, 0.972 of the curve's median) is coherent at any trial velocity
    (docs/multichannel.md section 8, sig35 bullet).

    The null fit's estimates (its mismatch, not eq. 5, is the criterion) are tested by the fit itself: no point
    target where the fit at the estimate leaves more than NULL_FIT_MISMATCH of the clutter-null residual
    unexplained. Windows with no mover (seeded noise and clutter-residue windows of tests/focus/test_movers.py's
    slowish scene, its mover moved away) leave 0.67-1.00 at the fit's best over every velocity it searches: none
    of them passes, and the gate is 7 of their standard deviations under their mean (docs/multichannel.md section
    8, nf37 bullet). Session 34's comparison it replaces (the mismatch under ``flat_above`` of its curve's median
    where a criterion cell stands out, of the trials' plain median elsewhere) passed most of those windows: only
    the same gate in _null_refit kept them out. Eq. 5's unrelated-phase test does not apply there: the window's
    channels hold the clutter the null cancels, a point target at v = 0 coherent at any trial velocity
    (_coherence_t 12-79 at the fit's best velocity in windows with clutter and no mover)."""
    assert est.result is not None
    at = est.criterion(est.v_r, est.v_a)
    if est.by_null_fit:
        return at > NULL_FIT_MISMATCH
    if at >= 1 - 2 * g.half_band / (g.n * g.prf) or at > flat_above * velocity.curve_median(est.result.trials):
        return True
    t, dof = _coherence_t(win, est.v_r, est.v_a)
    if dof < 1:
        return False  # one look: nothing to test with; kept
    from scipy.special import stdtrit  # Student's t (scipy.stats' import costs about 0.5 s of CPU)

    critical = float(stdtrit(dof, 1 - POINT_TARGET_ALPHA))
    log.debug("reconstruct: eq. 5's coherence t %.2f, %d degrees of freedom (a point target: > %.2f)", t, dof, critical)
    if not t > critical:
        return True
    params = params if params is not None else ReconstructParams()
    span = round((params.velocity_max - params.velocity_min) / params.velocity_step) + 1
    # a t over the Bonferroni bound of every trial the search can reach is significant at its minimum too
    if t > float(stdtrit(dof, 1 - POINT_TARGET_ALPHA / span)):
        return False
    n = len(win.cells) if win.cells is not None else win.x.shape[-1]
    shift = _selection_shift(win, est.v_a, n, _reference_cells(win), params, t - critical)
    log.debug("reconstruct: the search's minimum shifts t by %.2f (a point target: > %.2f)", shift, critical + shift)
    return not t > critical + shift


def _noise_dip(win: _Window, v_r: float, v_a: float) -> tuple[float, float]:
    """How much further eq. 5 of the criterion's cells falls from rest to (``v_r``, ``v_a``) than the window's noise
    alone makes it fall there: (L(0) - L(v)) - s (F(0) - F(v)), L eq. 5 of the criterion's cells, F of the window's
    noise cells (its far cells, _far_cells, that hold no target: not over the cell-energy floor, _over_floor), s the
    noise's share of the criterion's energy (a noise cell's mean energy over a criterion cell's, at rest); and the
    bound a static point's value passes with probability POINT_TARGET_ALPHA from the noise's draw alone (below).
    nan, 0 where there are no criterion cells or fewer than 3 noise cells.

    Eq. 5 of noise alone has its own dip: the window's channels are the detection's extraction band, and its noise
    leaks least where the trial Doppler centres that band (mover campaign scenes 015 and 017: the far cells' minimum
    at +8.25 to +12.75 m/s, 4-10 % under their value at rest; docs/multichannel.md section 10.1). The criterion's
    cells hold a share s of that noise, whose fall from rest to v is s (F(0) - F(v)) in expectation. A static point
    adds nothing out of band at rest and its leakage O_s(v) > 0 at v: its cells fall by s (F(0) - F(v)) - O_s(v) / T,
    less than the noise's own. A point mover at v adds nothing out of band at v and O_m(0) > 0 at rest: its cells fall
    by s (F(0) - F(v)) + O_m(0) / T, more. So a fall no further than the noise's is no evidence of motion, whatever
    the SNR: the noise's dip pulls a weak static's eq. 5 minimum off rest by more than the SNR's 1-sigma says (a bias,
    which no spread of the looks measures; scene 017's S2: 7.5 m/s, 2.4 sigma), and the fall measures it.

    That is the sign of an expectation. The criterion's cells and the noise cells hold different draws of the noise, so
    the value scatters around it: where a static point's own O_s(v) / T is small (a weak static pulled far by the
    noise's dip), it is as often above 0 as below (scene 015's static over noise seeds: -0.0167 to +0.0104;
    docs/multichannel.md section 13). The scatter is the noise's, from the noise cells themselves: each cell's
    linearised share of the noise's fall, r_c = (O0_c - F(0) T0_c) / mean T0 - (Ov_c - F(v) Tv_c) / mean Tv (the delta
    method for a ratio of sums), has variance V over the noise cells (range cells of noise are nearly independent: lag-1
    correlation of r -0.20 to +0.32 on the campaign's noise windows, but 0.68-0.70 where a static's skirt reaches the
    far cells, scene 006, whose sigma is then too small by up to 1.5); the criterion's noise fall is s times the mean of
    n_crit such terms and the noise cells' estimate s times the mean of n_noise, so their difference has the standard
    deviation s sqrt(V (1 / n_crit + 1 / n_noise)). The bound is that draw's one-sided POINT_TARGET_ALPHA point
    (Student's, n_noise - 1 degrees of freedom: V is estimated): the significance a detection's eq. 5 dip must have to
    be a point target at all (_incoherent), asked of whether that point moves. The signal's cross terms with the noise
    are left out (they matter only where the signal's own leakage is large, and there the fall is far over the bound:
    scene 004's movers at 134-188 of these sigmas, 013's at 5.4-8.2). The bound does not decide (the sign does): the
    weakest true mover in noise measured, scene 016's M1, stands at 0.40 of its sigma, under two noise-pulled statics
    (_warn_within_noise)."""
    if win.cells is None or (far := _far_cells(win)) is None:
        return float("nan"), 0.0
    profile = win.cell_energy
    noise = far[~_over_floor(profile, float(profile.max()))[far]]
    if len(noise) < 3:
        return float("nan"), 0.0
    out = np.abs(win.out_f) > win.g.half_band

    def cells(u: float) -> tuple[np.ndarray, np.ndarray]:  # per cell: eq. 5's out-of-band energy and total
        p = np.abs(sfft.ifft(win.demodulated_spectrum(u, v_a), axis=1, workers=-1)) ** 2
        return p[out].sum(axis=0), p.sum(axis=0)

    (ov, tv), (o0, t0) = cells(v_r), cells(0.0)
    crit = win.cells
    if not (t0[crit].sum() > 0 and tv[crit].sum() > 0 and t0[noise].sum() > 0 and tv[noise].sum() > 0):
        return float("nan"), 0.0
    fall = o0[crit].sum() / t0[crit].sum() - ov[crit].sum() / tv[crit].sum()
    f0, fv = o0[noise].sum() / t0[noise].sum(), ov[noise].sum() / tv[noise].sum()
    share = float(np.mean(t0[noise]) / np.mean(t0[crit]))
    r = (o0[noise] - f0 * t0[noise]) / np.mean(t0[noise]) - (ov[noise] - fv * tv[noise]) / np.mean(tv[noise])
    sigma = share * math.sqrt(float(np.sum(r**2)) / (len(noise) - 1) * (1 / len(crit) + 1 / len(noise)))
    from scipy.special import stdtrit  # Student's t (scipy.stats' import costs about 0.5 s of CPU)

    return float(fall - share * (f0 - fv)), float(stdtrit(len(noise) - 1, 1 - POINT_TARGET_ALPHA)) * sigma


def _coherence_t(win: _Window, v_r: float, v_a: float) -> tuple[float, int]:
    """Student's t of eq. 5's dip under its unrelated-phase level over the criterion's looks, and its degrees of
    freedom (0: no test).

    Per look k (a range frequency of the criterion's cells: noise is independent between them, and a point target
    has the same azimuth spectrum in each), d_k = O_k / T_k - O0_k / T0_k: eq. 5 of the look less what its channels
    give with their phases unrelated (_Window.coherence_looks). Without a point target (noise, or channels with no
    common velocity) each d_k has mean 0 (the cross-channel terms' phases are uniform); a point target at (v_r,
    v_a) makes every d_k negative. t = -mean(d) / (s / sqrt(n)), s the spread of d over looks with no point target
    in them: the looks of the window's noise cells (_reference_cells: far from the criterion's, and over its range
    side lobes; noise with the same processing, and d is free of the noise's level) where there are 3 or more, with
    n_far - 1 degrees of freedom; else the criterion's own looks, n - 1. Student's under no point target either
    way: the far looks are independent of the criterion's."""
    d = _coherence_d(*win.coherence_looks(v_r, v_a))
    far = _reference_cells(win)
    spread = d if far is None else _coherence_d(*win.coherence_looks(v_r, v_a, far))
    return _t(d, spread)


def _reference_cells(win: _Window) -> np.ndarray | None:
    """_coherence_t's noise cells: the far cells (_far_cells) whose energy is over the criterion's range side-lobe
    envelope there (each criterion cell's energy times the unweighted sinc's, detection.sinc_sidelobes, at its
    distance in range resolutions), where 3 or more are (None: the criterion's own looks are the spread's).

    A cell under that envelope may hold the criterion's own side lobes, coherent at its velocity, not noise: in a
    noise-free window (xu_small's radar, sinc beam, band-limited echoes, a mover at v_r 8 m/s at the beam centre;
    docs/multichannel.md sections 26.1 and 29) the 22 far cells held only the mover's side lobes (-33 to -44 dB of
    its peak, 3-10 dB under the envelope), whose d was -0.19 in most looks and up to +0.28 at the range band's edge:
    their spread, the side lobes' structure over the band, put t at 2.65 against a bar of 3.42 and the mover was
    missed. Noise cells stand over the envelope (18 dB or more under a noise criterion cell: 3 cells or more off, at
    the 1.2 cells per resolution of xu_small's and the campaign's radars), so noise windows keep every far cell and
    their test is unchanged (300 of 300 seeded noise windows); a neighbour's cells over it stay (campaign scene 039's
    M3: 9 far cells over the envelope, all M4's)."""
    far = _far_cells(win)
    if far is None or win.cells is None:
        return far
    energy = win.cell_energy
    width = max(1.0, win.g.fs / win.g.bandwidth) if win.g.bandwidth > 0 else 1.0
    offset = np.abs(far[:, None] - win.cells[None, :]) / width  # >= 3 cells: far cells are more than 2 away
    envelope = np.max(energy[win.cells][None, :] / (np.pi * offset) ** 2, axis=1)  # detection.sinc_sidelobes
    noise = far[energy[far] > envelope]
    return noise if len(noise) >= 3 else None


def _coherence_d(o: np.ndarray, t: np.ndarray, o0: np.ndarray, t0: np.ndarray) -> np.ndarray:
    """Per look, eq. 5 less its value with the channels' phases unrelated (_Window.coherence_looks' four arrays)."""
    return o / np.maximum(t, 1e-300) - o0 / np.maximum(t0, 1e-300)


def _far_cells(win: _Window) -> np.ndarray | None:
    """The window's cells more than 2 from any criterion cell, where there are 3 or more (None: no criterion cells,
    or too few far from them)."""
    if win.cells is None:
        return None
    far = np.nonzero(~_widened(win.cells, win.x.shape[-1], 2))[0]
    return far if len(far) >= 3 else None


def _t(d: np.ndarray, spread: np.ndarray) -> tuple[float, int]:
    """One-sided Student's t of mean(d) under 0 with the spread of ``spread``'s looks, and its degrees of freedom."""
    n = len(d)
    if n < 1 or len(spread) < 2:
        return 0.0, 0
    sd = float(np.std(spread, ddof=1))
    mean = float(np.mean(d))
    if not sd > 0:
        return (math.inf if mean < 0 else 0.0), len(spread) - 1
    return -mean / (sd / math.sqrt(n)), len(spread) - 1


def _selection_shift(
    win: _Window, v_a: float, n: int, source: np.ndarray | None, params: ReconstructParams, margin: float | None = None
) -> float:
    """How far the eq. 5 search's choice of its minimum moves _coherence_t's t up where there is no point target.

    The search takes the trial velocity where eq. 5 of the criterion's looks is lowest, and with it where their d_k
    happen to be lowest: at the minimum, t is Student's shifted up (synthetic noise windows, docs/multichannel.md
    section 8: mean 0.47, sd 1.01, 2.6 % over the one-sided 1 % point). The shift is the window's own: its
    channels' azimuth power spectra (averaged over the ``source`` cells: the far cells, or all where there are
    none), drawn with unrelated phases as sets of ``n`` independent looks, each set searched as eq. 5 is (the
    bounds, coarse step and step of ``params``); the shift is the mean of their standardised -mean(d) at their own
    minimum (d's spread over the batch's drawn looks at that trial). SELECTION_REPLICAS sets (fewer where ``n`` is
    large), drawn SELECTION_BATCH at a time (a fixed seed: the same draws for every window); with ``margin`` (t
    less its Student's critical value), the draws stop once ``margin`` is 3 standard errors from their mean (the
    decision is made).
    """
    x = sfft.ifft(win.x_criterion if win.x_criterion is not None else win.x, axis=-1, workers=-1)
    if source is not None:
        x = x[..., source]
    power = np.mean(np.abs(sfft.fft(x, axis=1, workers=-1)) ** 2, axis=-1)  # (N, n_az)
    rng = np.random.default_rng(0)
    replicas = max(SELECTION_REPLICAS_MIN, min(SELECTION_REPLICAS, math.ceil(SELECTION_LOOKS / n)))
    shifts: list[float] = []
    drawn = 0
    while drawn < replicas:
        batch = min(SELECTION_BATCH, replicas - drawn)
        shifts += _replica_shifts(win, v_a, n, power, rng, batch, params)
        drawn += batch
        if margin is not None and len(shifts) >= 2:
            se = float(np.std(shifts, ddof=1)) / math.sqrt(len(shifts))
            if abs(margin - float(np.mean(shifts))) > 3 * se:
                break
    return float(np.mean(shifts)) if shifts else 0.0


def _replica_shifts(
    win: _Window,
    v_a: float,
    n: int,
    power: np.ndarray,
    rng: np.random.Generator,
    replicas: int,
    params: ReconstructParams,
) -> list[float]:
    """_selection_shift's standardised -mean(d) at the search's minimum of ``replicas`` sets of ``n`` looks drawn
    with the azimuth power spectra ``power`` (N, n_az) and unrelated phases."""
    g = win.g
    k = replicas * n
    draw = rng.standard_normal((*power.shape, k)) + 1j * rng.standard_normal((*power.shape, k))
    noise = sfft.ifft(draw * np.sqrt(power / 2)[..., None], axis=1, workers=-1)
    bank = win.bank(v_a)
    out = np.abs(win.out_f[bank.out_index]) > g.half_band
    p2 = (np.abs(bank.matrix) ** 2).astype(np.float32)
    cache: dict[float, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}

    def looks(u: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        key = round(u, 9)
        if key not in cache:
            v_los = channels.line_of_sight_velocity(key, v_a, g.squint)
            demod = deramp.doppler_shift_phasor(g.times, np.zeros(1), v_los, g.fc, sign=-1)  # (n_az, 1)
            s = np.moveaxis(sfft.fft(noise * demod[None], axis=1, workers=-1), 0, 1)  # (n_az, N, looks)
            z = np.abs(bank.matrix64 @ s) ** 2
            z0 = p2 @ (np.abs(s) ** 2)
            o, t = z[out].sum(axis=0), z.sum(axis=(0, 1))
            cache[key] = (o, t, _coherence_d(o, t, z0[out].sum(axis=0), z0.sum(axis=(0, 1))))
        return cache[key]

    shifts = []
    for r in range(replicas):
        a = slice(r * n, (r + 1) * n)

        def criterion(u: float, a: slice = a) -> float:
            o, t, _ = looks(u)
            return float(o[a].sum() / max(float(t[a].sum()), 1e-300))

        res = velocity.fast_search(
            criterion,
            params.velocity_min,
            params.velocity_max,
            params.velocity_step,
            params.coarse_step,
            exhaustive=params.search == "exhaustive",
        )
        d = looks(float(res.trials[int(np.argmin(res.trials[:, 1])), 0]))[2]
        sd = float(np.std(d, ddof=1))
        if sd > 0:
            shifts.append(-float(np.mean(d[a])) / (sd / math.sqrt(n)))
    return shifts


def _tone_offset(z: np.ndarray, f_az: np.ndarray, reach: float) -> float | None:
    """Frequency (Hz) of the strongest bin of the cell-summed power of ``z`` (n_out, cells) within +-``reach`` Hz,
    refined by a parabola through it and its neighbours; None if the strongest is on the edge of the reach."""
    p = np.sum(np.abs(z) ** 2, axis=1)
    inside = np.nonzero(np.abs(f_az) <= reach)[0]
    if len(inside) < 3:
        return None
    k = int(inside[np.argmax(p[inside])])
    n = len(p)
    if np.abs(f_az[(k - 1) % n]) > reach or np.abs(f_az[(k + 1) % n]) > reach:
        return None
    a, b, c = float(p[(k - 1) % n]), float(p[k]), float(p[(k + 1) % n])
    den = a - 2 * b + c
    frac = 0.5 * (a - c) / den if den < 0 else 0.0
    return float(f_az[k] + frac * (f_az[1] - f_az[0]))


def _acceleration_keeping_los(g: _Geometry, v_los: float, u: float, slant_range: float) -> float:
    """Range acceleration at ``slant_range`` of a mover of along-track velocity ``u`` and line-of-sight velocity
    ``v_los`` (its v_r follows from both)."""
    vr_u = (v_los - u * math.sin(g.squint)) / math.cos(g.squint)
    return velocity.range_acceleration(g.velocity, u, vr_u, g.squint, slant_range)


def _along_track_for(acc: float, v_los: float, g: _Geometry, slant_range: float, guess: float) -> float:
    """The along-track velocity u (m/s) at which a mover of line-of-sight velocity ``v_los`` at ``slant_range`` has
    range acceleration ``acc`` (velocity.range_acceleration, decreasing in u near the platform's velocity):
    bisection within +-10 m/s of ``guess``."""

    def acc_at(u: float) -> float:
        return _acceleration_keeping_los(g, v_los, u, slant_range)

    lo, hi = guess - 10.0, guess + 10.0
    if not (acc_at(lo) - acc) * (acc_at(hi) - acc) <= 0:
        return guess
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if (acc_at(lo) - acc) * (acc_at(mid) - acc) <= 0:
            hi = mid
        else:
            lo = mid
    return 0.5 * (lo + hi)


def _autofocus(
    est: _Estimate, win: _Window, params: ReconstructParams, g: _Geometry, centre: _Centre, can_search: bool
) -> tuple[float, float]:
    """v_a by azimuth autofocus at the line-of-sight velocity found, then v_r refined with v_a known.

    The quadratic the autofocus finds is the range acceleration R'' at the mover's beam-centre time t_0 (the middle
    of its illumination; a cubic term is odd about it and leaves it); v_a follows from R'' through the slant range
    at t_0, R(t_0) = (walk-corrected range) - v sin(theta) t_0, and dR'' / R'' = -dR / R: 1 ms of t_0 (2.6 m)
    moves v_a by v / 2 x 4.3e-6 = 0.016 m/s. The energy centroid of the mover's cells (``centre.t_c``) is pulled by
    the clutter in them (xu_traffic V9: +19 ms, v_a +0.31 m/s). Dechirped about t_c with the right R'', the
    mover is one tone at f = 2 R'' (t_0 - t_c) / lambda: t_0 from the tone's frequency, v_a again from the same
    R'' at R(t_0) (the sharpness against R'' does not depend on t_c: only a linear phase changes). Returns
    (t_0, R(t_0)), the beam-centre time and slant range the mover's reconstruction uses.
    """
    v_los = est.v_los(g)
    # Autofocus on the mover's own range cells (its energy above 1 % of its strongest cell), with the
    # FM rate at the carrier (the range-frequency spread of R'' is 0.3 %): one azimuth FFT per trial.
    y_cells = sfft.ifft(centre.y_dem, axis=1, workers=-1)
    cell_power = np.sum(np.abs(y_cells) ** 2, axis=0)
    keep = cell_power >= 0.01 * cell_power.max() if centre.own_cells is None else centre.own_cells
    y_cells = np.ascontiguousarray(y_cells[:, keep])
    t_c, slant_range = centre.t_c, centre.slant_range
    # a beam with no sharp edge cut by the data (_pattern_span): the autofocus on the span symmetric about the
    # beam-centre time its pattern gives, the cubic term about that time taken out with the trial's R'' (jerk -3 R'
    # R'' / R), so the sharpness measures R'' there. On the whole output time the data's two edges cut the skirt
    # unequally and the reconstruction past N PRF / 2 from the mover's Doppler (|t' - t_0| > 0.28 s here) is no
    # mover's: R'' carried from the lit energy's centroid by the jerk read v_a -1.77 ... +0.79 m/s at +-300 ... +-625 m,
    # the cubic about t_0 alone -1.36 ... +0.0, the span alone -0.09 ... +0.16; both within 0.015 (section 26)
    cubic_about = None
    if win.span is not None and g.antenna_pattern != "rect":
        cubic_about = win.span.t_0
        y_cells = np.ascontiguousarray(y_cells * (win.span.weight > 0)[:, None])

    def crit(u: float) -> float:  # keep the line-of-sight velocity found by the search while v_a varies
        acc = _acceleration_keeping_los(g, v_los, u, slant_range)
        if cubic_about is not None:
            rdot = v_los - g.velocity * math.sin(g.squint)  # -(v - v_a) sin(theta) + v_r cos(theta)
            dt = g.out_times - cubic_about
            jerk = -3 * rdot * acc / slant_range
            ph = np.exp(2j * np.pi * g.fc / C * (acc * dt**2 + jerk * dt**3 / 3)).astype(np.complex64)[:, None]
        else:
            ph = deramp.quadratic_phasor(g.out_times, np.zeros(1), acc, t_c, g.fc)
        return velocity.sharpness(sfft.fft(y_cells * ph, axis=0, workers=-1))

    v_a, af = velocity.maximise(crit, est.v_a - params.autofocus_span, est.v_a + params.autofocus_span, 1.0)
    v_a, af2 = velocity.maximise(crit, v_a - 1.0, v_a + 1.0, 0.05)
    est.autofocus = np.concatenate([af, af2])
    # The beam-centre time from the focused tone (docstring), searched within a quarter of the illumination time of
    # the centroid (clutter pulls the centroid by a fraction of that; a tone beyond it is clutter's).
    lam = C / g.fc
    vr_a = (v_los - v_a * math.sin(g.squint)) / math.cos(g.squint)
    acc = velocity.range_acceleration(g.velocity, v_a, vr_a, g.squint, slant_range)
    if win.span is not None and cubic_about is None:
        # a mover lit past the data's start or end (_lit_span): the sharpness measures R'' where its lit part is
        # centred (the cubic term is odd about that time, not about t_0), R''(t_0) + jerk (middle - t_0) with jerk
        # = -3 R' R'' / R; 2.9 ms off t_0 at 5.7 ms of cut is +0.14 m/s of v_a (docs/multichannel.md section 21)
        rdot = -(g.velocity - v_a) * math.sin(g.squint) + vr_a * math.cos(g.squint)
        acc -= -3 * rdot * acc / slant_range * (win.span.middle - win.span.t_0)
    t_ill = 2 * g.half_band * lam * slant_range / (2 * (g.velocity * math.cos(g.squint)) ** 2)
    f_az = sfft.fftfreq(len(g.out_times), 1.0 / (g.n * g.prf))
    ph = deramp.quadratic_phasor(g.out_times, np.zeros(1), acc, t_c, g.fc)
    f_tone = _tone_offset(sfft.fft(y_cells * ph, axis=0, workers=-1), f_az, 2 * acc * 0.25 * t_ill / lam)
    walk_corrected = slant_range + g.velocity * math.sin(g.squint) * t_c
    if f_tone is not None:
        t_c = t_c + f_tone * lam / (2 * acc)
    # ... and its range there from the focused mover too: the detection's cell, where slant_range came from, is a
    # cell of the mover's response in the detection image, which for a detection at the mover's ambiguity (the
    # null leaves a slow mover's energy mostly there) walks 4-5 cells from the mover (scripts/movers_sigma_003.py
    # seed 2 (4, -6): -19.5 m, v_a +0.13 m/s), and is whole cells in any case (12.5 m: 0.08 m/s)
    rdot = -(g.velocity - v_a) * math.sin(g.squint) + vr_a * math.cos(g.squint)
    jerk = -3 * rdot * acc / slant_range
    cell = _focused_cell(centre.y_dem, win.f_r, g, acc, jerk, t_c, t_ill, np.arange(centre.y_dem.shape[1])[keep])
    if cell is not None:
        # y_dem has the walk v_los t removed about t = 0 (demodulated_spectrum): the mover sits at R(t_0) - v_los t_0
        walk_corrected += (cell - centre.cell) * C / (2 * g.fs) + v_los * t_c
    slant_range = walk_corrected - g.velocity * math.sin(g.squint) * t_c
    v_a = _along_track_for(acc, v_los, g, slant_range, v_a)
    vr_a = (v_los - v_a * math.sin(g.squint)) / math.cos(g.squint)
    acc = velocity.range_acceleration(g.velocity, v_a, vr_a, g.squint, slant_range)
    own = np.zeros((1, centre.y_dem.shape[1]), np.complex64)
    own[0, np.arange(centre.y_dem.shape[1])[keep]] = 1.0
    y_own = sfft.fft(sfft.ifft(centre.y_dem, axis=1, workers=-1) * own, axis=1, workers=-1)  # (t', f_r), own cells
    rdot = -(g.velocity - v_a) * math.sin(g.squint) + vr_a * math.cos(g.squint)
    jerk = -3 * rdot * acc / slant_range
    est.autofocus_snr = _autofocus_snr(y_own, win.f_r, g, acc, t_c, t_ill, params.separation_bandwidth, jerk)
    # the autofocus again on the mover's illumination alone: its offset is the pull of the clutter outside it
    d_u = 0.5
    acc_hi, acc_lo = (_acceleration_keeping_los(g, v_los, u, slant_range) for u in (v_a + d_u, v_a - d_u))
    est.pull = illumination_pull(
        y_cells, g.out_times, g.fc, acc, (acc_hi - acc_lo) / (2 * d_u), jerk, t_c, t_ill, params.autofocus_span
    )
    est.v_a = v_a
    est.v_r = (v_los - v_a * math.sin(g.squint)) / math.cos(g.squint)
    if params.radial_velocity is None and can_search:
        # Refine v_r with the along-track velocity known (the channel delays depend on it).
        span = 5 * params.velocity_step
        lo, hi = max(params.velocity_min, est.v_r - span), min(params.velocity_max, est.v_r + span)
        if not est.by_null_fit and win.x_criterion is not None:
            # a neighbour's range side lobes in the criterion's cells: the final search on the range-tapered
            # channels (_window_at; the first search, the static test and the autofocus as without a neighbour)
            est.criterion = win.final_leakage
        fine = _search(est, params, v_a, lo, hi, params.velocity_step)
        assert est.result is not None  # searched above: can_search and no radial velocity given
        trials = np.concatenate([est.result.trials, fine.trials])
        est.result = velocity.SearchResult(
            fine.estimate, False, trials[np.argsort(trials[:, 0])], est.result.evaluations + fine.evaluations
        )
        est.v_r = fine.estimate
        if est.by_null_fit:
            # the minimum's width at the final v_a, which the fit's first search at v_a 0 over-states (xu_traffic V9:
            # +-0.17 m/s of v_los there, within 0.02 only the estimate itself here)
            est.null_width = _minimum_width(fine) * math.cos(g.squint)
    return t_c, slant_range


def _focused_cell(
    y_tf: np.ndarray,
    f_r: np.ndarray,
    g: _Geometry,
    acc: float,
    jerk: float,
    t_0: float,
    t_ill: float,
    cells: np.ndarray,
) -> float | None:
    """The window cell (fractional) of the mover focused in ``y_tf`` (t', f_r): dechirped at each range frequency
    with R'' = ``acc`` and the cubic term ``jerk`` about ``t_0`` over the illumination ``t_ill`` (which also
    straightens its range curvature), summed over t' (the tone at f = 0), its range profile's peak among ``cells``
    +-1, interpolated (the band-limited profile at 1/20 cell about the strongest cell, then a parabola). None when
    that is no local maximum of the profile, or there are too few samples."""
    inside = np.abs(g.out_times - t_0) <= t_ill / 2
    if inside.sum() < 8 or len(cells) == 0:
        return None
    dt = g.out_times[inside] - t_0
    ph = deramp.quadratic_phasor(g.out_times[inside], f_r, acc, t_0, g.fc)
    ph *= np.exp(2j * np.pi * np.outer(dt**3, (g.fc + f_r) * jerk / (3 * C)))
    spec = np.sum(y_tf[inside] * ph, axis=0)  # (n_f,)
    n = len(f_r)
    profile = np.abs(sfft.ifft(spec, workers=-1)) ** 2
    near = unique_integers(np.clip(np.concatenate([cells - 1, cells, cells + 1]), 0, n - 1))
    k = int(near[np.argmax(profile[near])])
    if profile[k] < max(profile[(k - 1) % n], profile[(k + 1) % n]):  # rising beyond them: not the mover's peak
        return None
    x = k + np.arange(-20, 21) / 20.0
    fine = np.abs(np.exp(2j * np.pi * np.outer(x, f_r / g.fs)) @ spec) ** 2
    j = int(np.argmax(fine))
    if 0 < j < len(x) - 1:
        a, b, c = fine[j - 1 : j + 2]
        den = a - 2 * b + c
        return float(x[j] + (0.5 * (a - c) / den if den < 0 else 0.0) * (x[1] - x[0]))
    return float(x[j])


def _autofocus_snr(
    y_tf: np.ndarray,
    f_r: np.ndarray,
    g: _Geometry,
    acc: float,
    t_0: float,
    t_ill: float,
    mask_half_width: float,
    jerk: float = 0.0,
) -> float:
    """The integrated signal to clutter-plus-noise ratio of the autofocus's data (power ratio; inf: no interference).

    The FM-rate estimate's variance 90 / (snr T^4) (_uncertainties) needs the mover's energy over the interference's
    density where the mover is in time and frequency. ``y_tf`` (t', f_r): the autofocus's own range cells, dechirped
    at each range frequency with the range acceleration found (which also straightens the range curvature: in one
    range cell the mover would be a shorter burst, its tone wider), about the beam-centre time t_0, kept over the
    illumination time T. The mover is then one tone at f = 0 (peak power P = E M, M samples), sinc^2-shaped (rect
    illumination); whatever else the separation mask kept there (clutter within +-``mask_half_width`` Hz of the
    mover's apparent Doppler, noise) spreads over the bins, M x its density per bin. P over the mean power of the
    bins 2 / T to ``mask_half_width`` from the tone, less the tone's own sinc^2 side lobes there, is E / density:
    the detection SNR's counterpart that counts the clutter in the mover's cells, which the null hid from detection.
    """
    inside = np.abs(g.out_times - t_0) <= t_ill / 2
    if inside.sum() < 8:
        return math.inf
    dt = g.out_times[inside] - t_0
    ph = deramp.quadratic_phasor(g.out_times[inside], f_r, acc, t_0, g.fc)
    # and the cubic term jerk dt^3 / 6 (jerk = -3 R' R'' / R: 3.8 rad at the beam edges at 20 deg squint, 600 km)
    ph *= np.exp(2j * np.pi * np.outer(dt**3, (g.fc + f_r) * jerk / (3 * C)))
    p = np.sum(np.abs(sfft.fft(y_tf[inside] * ph, axis=0, workers=-1)) ** 2, axis=1)
    f = sfft.fftfreq(len(p), 1.0 / (g.n * g.prf))
    t_w = inside.sum() / (g.n * g.prf)  # the window's duration (s): the tone's sinc width is 1 / t_w
    f0 = _tone_offset(p[:, None] ** 0.5, f, mask_half_width)  # near 0 unless t_0 is off (f = 2 R'' dt / lambda)
    f0 = 0.0 if f0 is None else f0
    k = int(np.argmin(np.abs(f - f0)))
    peak = float(p[k]) / max(float(np.sinc((f[k] - f0) * t_w)) ** 2, 0.5)
    ring = (np.abs(f - f0) >= 2.0 / t_w) & (np.abs(f - f0) <= mask_half_width)
    if not ring.any() or peak <= 0:
        return math.inf
    # less the focused mover's own residue there (AUTOFOCUS_SELF: what noise-free clean movers leave)
    interference = float(np.mean(p[ring] - peak * np.sinc((f[ring] - f0) * t_w) ** 2)) - peak * AUTOFOCUS_SELF
    return peak / interference if interference > 0 else math.inf


def illumination_pull(
    y_cells: np.ndarray,
    times: np.ndarray,
    fc: float,
    acc: float,
    dacc_dva: float,
    jerk: float,
    t_0: float,
    t_ill: float,
    span: float,
) -> float:
    """How far (m/s) the autofocus's v_a moves when its data are kept to the mover's own illumination: the offset of
    the sharpness maximum on |t' - ``t_0``| <= ``t_ill`` / 2 from that at R'' = ``acc``.

    ``y_cells`` (t', cells): the autofocus's own data. Trial R'' = ``acc`` + ``dacc_dva`` u about t_0, with the
    cubic term ``jerk`` dt^3 / 6; sharpness over u in +-``span`` at 1 m/s, then +-0.5 m/s at 0.1 zero-padded to
    twice the window, each refined by a parabola. The autofocus runs on the whole output time (``_autofocus``),
    where the mover's cells also hold clutter illuminated before and after it, whose focus pulls the sharpness
    maximum (SLOWISH: -0.71 of its +0.62 m/s v_a error). The data outside hold nothing of the mover, so without such
    interference both estimates measure the same R'' and differ by noise only (variance var_full - var_window):
    the offset is the pull itself, estimated from the data, not from a model of it.
    """
    inside = np.abs(times - t_0) <= t_ill / 2
    if inside.sum() < 8:
        return float("nan")
    dt = times[inside] - t_0
    base = y_cells[inside] * np.exp(2j * np.pi * fc / C * (acc * dt**2 + jerk * dt**3 / 3))[:, None]
    phase = (2 * np.pi * fc / C * dacc_dva * dt**2)[:, None]
    m = int(inside.sum())

    def crit(u: float, n_fft: int) -> float:
        return velocity.sharpness(sfft.fft(base * np.exp(1j * u * phase), n=n_fft, axis=0, workers=-1))

    # the whole span unpadded (a gross pull, scripts/movers_sigma_003.py seed 1 (4, -6): -6.1 m/s, with a local
    # maximum near 0), then the peak zero-padded to twice the window against scalloping
    u, _ = velocity.maximise(lambda x: crit(x, sfft.next_fast_len(m)), -span, span, 1.0)
    padded = sfft.next_fast_len(2 * m)
    return velocity.maximise(lambda x: crit(x, padded), u - 0.5, u + 0.5, 0.1)[0]


def _bound_notes(est: _Estimate, params: ReconstructParams) -> tuple[bool, list[str]]:
    """(at_bound, notes): whether the estimate is on the search bound or its true velocity beyond it, and why."""
    v_r = est.v_r
    on_bound = (
        est.result is not None
        and min(abs(v_r - params.velocity_min), abs(v_r - params.velocity_max)) < params.velocity_step
    )
    notes: list[str] = []
    if est.beyond:
        notes.append(
            f"no slant-range velocity in [{params.velocity_min:g}, {params.velocity_max:g}] m/s removes "
            f"its range walk (best {v_r:.2f} m/s): it moves faster than the search bound, or the window "
            "holds more than one mover"
        )
    elif on_bound:
        notes.append(
            f"slant-range velocity estimate {v_r:.2f} m/s is on the search bound "
            f"[{params.velocity_min:g}, {params.velocity_max:g}] m/s; the target may move faster"
        )
    return bool(est.beyond or on_bound), notes


def _estimate(
    win: _Window,
    params: ReconstructParams,
    g: _Geometry,
    centre_range: float,
    centre_cell: float,
    static_below: float | None = None,
    flat_above: float | None = None,
    null_fit: _NullFit | None = None,
    crowded: bool = False,
) -> tuple[MovingTarget | None, list[str]]:
    """Slant-range velocity by the leakage search, along-track by autofocus, then a refined search.

    Returns the target and the reasons to doubt it (true statements, for the caller to warn with the
    window's location). With ``static_below``, a window whose line-of-sight velocity from the first
    search is below it (m/s) is a static target: (None, ["static <v_los>"]); with ``flat_above``, one whose eq. 5 at the
    estimate is not significantly lower than its channels with unrelated phases give, or at white noise's
    out-of-band fraction (or, by the null fit, whose mismatch is over NULL_FIT_MISMATCH), has no
    velocity that explains it (noise, or a response that is no point target): (None, ["incoherent"];
    _incoherent). With ``null_fit`` (a detection on the clutter-null residual), an eq. 5
    estimate that leaves more than NULL_FIT_MISMATCH of that residual unexplained was pulled by the clutter
    in the window: the velocity is searched again by the null fit (_NullFit), and that criterion kept. ``crowded``:
    another target's detection shares the window (_crowded; no pattern span).

    Steps: _first_search (eq. 5, blind velocity), _null_refit, the static test, _centre (beam-centre time),
    _incoherent, _autofocus (v_a, then v_r refined), _bound_notes; the null fit then locates the mover.
    """
    can_search = g.n * g.prf > 2 * g.half_band
    if not can_search and params.radial_velocity is None:
        log.warning(
            "reconstruct: N PRF = %.4g Hz leaves no band outside the Doppler band %.4g Hz; "
            "slant-range velocity not estimated (0 used)",
            g.n * g.prf,
            2 * g.half_band,
        )
    est = _first_search(win, params, g, can_search)
    if null_fit is not None:
        _null_refit(est, params, null_fit, static_below, g.squint)
    if static_below is not None and abs(v_los_first := est.v_los(g)) < static_below:
        return None, [f"static {v_los_first:.6g}"]
    if static_below is not None and not est.by_null_fit and params.radial_velocity is None:
        _rival_minimum(est, win, params, g, static_below)
    if flat_above is not None and est.unexplained is not None:
        # A residual that no velocity explains is no point mover (xu_traffic_static: V5's ambiguity residue
        # -1 x PRF / K_a from it, 16.2 dB, eq. 5 5.70 m/s leaving 1.00 of it, the null fit's best 0.32).
        e5, m5, nf, mf = est.unexplained
        log.info(
            "reconstruct: no velocity explains the clutter-null residual: eq. 5's %.2f m/s leaves %.2f of it, the "
            "null fit's best %.2f m/s %.2f (a mover's: <= %.2f)",
            e5,
            m5,
            nf,
            mf,
            NULL_FIT_MISMATCH,
        )
        return None, ["incoherent"]
    centre = _centre(win, g, est, centre_range, centre_cell, null_fit)
    if flat_above is not None and est.result is not None and _incoherent(est, win, g, flat_above, params):
        return None, ["incoherent"]
    noise_dip, noise_dip_bound = float("nan"), 0.0
    if flat_above is not None and null_fit is None and est.result is not None and not est.by_null_fit:
        # without the clutter null eq. 5 is the only evidence of motion: how much of its fall from rest the noise's
        # own dip does not explain (_refocus takes the mover back where none is left; _warn_within_noise warns where
        # what is left is within the noise's draw)
        noise_dip, noise_dip_bound = _noise_dip(win, est.v_r, est.v_a)
        log.debug(
            "reconstruct: eq. 5 falls %.4f further from rest to %.2f m/s than the window's noise (its draw reaches "
            "%.4f)",
            noise_dip,
            est.v_r,
            noise_dip_bound,
        )
    lit_cut = 0.0
    if can_search and params.radial_velocity is None and est.result is not None and not est.by_null_fit:
        # a mover lit past the data's start or end: eq. 5 on its span about its beam-centre time (_lit_span)
        # a beam with no sharp edge (_pattern_span) only where the window holds the mover alone: a neighbour's
        # response (range-tapered criterion, or a gate) is in the envelope the pattern is fitted to, and a sinc pair
        # 4 cells apart read M5 0.129 m/s off that way (tests/focus/test_movers.py, docs/multichannel.md section 26).
        # Nor under the clutter null (null_fit): its residue is in that envelope too, and the span's sigma does not
        # hold it: mover campaign scenes 007 M1 (gaussian) and 012 M2 (sinc) read -0.606 +- 0.040 and +1.786 +- 0.122
        # m/s that way, against +0.836 +- 0.523 and +1.255 +- 0.414 without the span (section 27). Nor beside a
        # detection that will be merged with it as another target (_crowded): scene 038's M2 (12.3 dB under M3, 25
        # samples off in azimuth, the same cell) left 0.20 of the envelope's fit unexplained (a mover alone 2e-6) and
        # M3 read -0.704 +- 0.083 m/s, +0.605 +- 0.188 without the span (section 28)
        alone = g.antenna_pattern == "rect" or (
            win.x_criterion is None and win.gate is None and null_fit is None and not crowded
        )
        span = (
            _lit_span(centre.y_dem, win.cells, g, 1.0 / params.separation_bandwidth, centre.slant_range)
            if alone
            else None
        )
        if span is not None and _search_lit_span(est, win, params, g, span):
            lit_cut = span.cut
            centre = _centre(win, g, est, centre_range, centre_cell, null_fit)
    t_c, slant_range = centre.t_c, centre.slant_range
    if params.autofocus and params.along_track_velocity is None:
        t_c, slant_range = _autofocus(est, win, params, g, centre, can_search)
        # _first_search chose the blind-velocity alias at v_a = 0, but v_a moves a v_los's v_r by v_a tan(theta):
        # with v_a known another alias may be the one inside the bounds without range walk (v_r 18, v_a 10 m/s at
        # 20 deg reads 21.6 m/s at v_a = 0); centre and autofocus again at it
        if can_search and params.radial_velocity is None:
            v_r, beyond = _resolve_blind_velocity(win, est.v_r, est.v_a, params, g)
            if abs(v_r - est.v_r) > params.velocity_step:
                est.v_r, est.beyond = v_r, beyond
                centre = _centre(win, g, est, centre_range, centre_cell, null_fit)
                t_c, slant_range = _autofocus(est, win, params, g, centre, can_search)
    leak = win.leakage(est.v_r, est.v_a) if can_search else float("nan")
    # eq. 5's own 1-sigma from its looks (v_r searched at fixed v_a: v_los's is cos(theta) of it)
    searched = can_search and params.radial_velocity is None and est.result is not None and not est.by_null_fit
    spread = _leakage_spread(win, est.v_r, est.v_a) * math.cos(g.squint) if searched else 0.0
    # where a neighbour range-tapered the final search, the looks of the channels it weighed: the untapered ones see
    # the neighbour's side lobes the taper took out (scene 008 M4-M6: 0.16-0.26 m/s of v_los against 0.02 tapered)
    spread_weighed = spread
    if searched and est.criterion is not None and est.criterion == win.final_leakage:
        spread_weighed = _leakage_spread(win, est.v_r, est.v_a, criterion=True) * math.cos(g.squint)
    appears = appears_cell = None
    if null_fit is not None and centre.shift is not None:
        # where it is, with its final velocity, in the cells the autofocus focused (_centre's own_cells): a static
        # response as bright as the mover a few cells away in the ghost walk's box is no candidate (the slowish scene
        # band-limited: clutter 8 cells short by 0.13 dB, the mover placed 31 m off; docs/multichannel.md section 9)
        null_fit.isolated(est.v_r, est.v_a, null_fit.fit(est.v_r, est.v_a)[1], cells=centre.own_cells)
        appears, appears_cell = null_fit.last_peak, null_fit.last_cell
    at_bound, notes = _bound_notes(est, params)
    if est.overruled is not None:
        cos = math.cos(g.squint)
        notes.append(
            f"v_r ambiguous: eq. 5 gives {est.overruled[0] / cos:.2f} m/s, the null fit "
            f"{est.overruled[1] / cos:.2f} m/s (at v_a 0; eq. 5 leaves the clutter-null residual unexplained, "
            f"the null fit's model may not hold here); the 1-sigma is at least their difference"
        )
    if est.rival is not None:
        kept, other, t, critical, walk, walk_other = est.rival
        notes.append(
            f"v_r ambiguous: eq. 5 has two minima, {kept:.2f} and {other:.2f} m/s at the first search's v_a, that "
            f"its looks do not tell apart (t {t:.2f}, apart over {critical:.2f}); {kept:.2f} taken, its range walk "
            f"the smaller ({walk:.2f} against {walk_other:.2f} m/s), the other as likely by eq. 5"
        )
    return MovingTarget(
        first_cell=0,
        last_cell=0,
        slant_range=slant_range,
        radial_velocity=float(est.v_r),
        along_track_velocity=float(est.v_a),
        beam_centre_time=t_c,
        leakage=leak,
        at_bound=at_bound,
        search=est.result.trials if est.result is not None else np.zeros((0, 2)),
        autofocus=est.autofocus,
        null_fit_index=appears,
        null_fit_cell=appears_cell,
        autofocus_snr=est.autofocus_snr if len(est.autofocus) else float("nan"),
        autofocus_pull=est.pull if len(est.autofocus) else float("nan"),
        null_fit_width=est.null_width,
        overruled=est.overruled[0] - est.overruled[1] if est.overruled is not None else 0.0,
        from_rest=est.from_rest,
        leakage_spread=spread_weighed,
        untapered_spread=spread,
        noise_dip=noise_dip,
        noise_dip_bound=noise_dip_bound,
        lit_cut=lit_cut,
    ), notes


def _search_lit_span(est: _Estimate, win: _Window, params: ReconstructParams, g: _Geometry, span: _LitSpan) -> bool:
    """v_r searched again by eq. 5 on ``span`` (set on the window for the later steps: the autofocus's refined search
    and eq. 5's spread) around the first estimate, over the whole cut's Doppler K_a c either side (eq. 5 on the whole
    band settles within it) and a coarse step more; the search's trials are the span's alone.

    Kept only where it moves v_los out of the cut, by no more than its Doppler lambda / 2 K_a c (and a search step
    of slack either way): the whole band's minimum lies in the cut (its band slid to the lost side: v_los read low
    where the end cut the low Doppler). Otherwise the run of lit samples was no beam's edge (another response in the
    criterion's cells, a mover lit whole): the first estimate, its search and the whole band are restored (False)."""
    first = (est.v_r, est.result)
    win.span = span
    reach = C / g.fc / 2 * span.ka * span.cut
    width = reach / math.cos(g.squint) + params.coarse_step / 4
    if g.antenna_pattern != "rect":
        # a skirt's cut moves eq. 5 far less than its Doppler says (its energy is low): xu_small's sinc movers at
        # +-300 ... +-625 m moved 0.2-1.0 m/s, where lambda / 2 K_a c is 1.8-5.4 m/s
        width = min(width, params.coarse_step)
    lo, hi = max(params.velocity_min, est.v_r - width), min(params.velocity_max, est.v_r + width)
    log.debug(
        "reconstruct: lit %.1f ms past the data's edge: eq. 5 on |t' - %.4f s| <= h, band %.0f Hz, v_r in [%.2f, %.2f]",
        1e3 * span.cut,
        span.t_0,
        span.half_band,
        lo,
        hi,
    )
    est.result = _search(est, params, est.v_a, lo, hi, max(params.velocity_step, (hi - lo) / 8))
    est.v_r = est.result.estimate
    moved = (est.v_r - first[0]) * math.cos(g.squint) * (1 if span.at_end else -1)
    slack = params.velocity_step * math.cos(g.squint)
    if -slack <= moved <= reach + slack:
        return True
    log.debug("reconstruct: the lit span moved v_los %.3f m/s (the cut's reach %.3f): not kept", moved, reach)
    win.span = None
    est.v_r, est.result = first
    return False


def blind_velocity_period(g: _Geometry) -> float:
    """Slant-range velocity step lambda PRF / (2 cos(theta)) whose Doppler offset is one PRF (m/s)."""
    return C / g.fc * g.prf / (2 * math.cos(g.squint))


def _along_track_reach(params: ReconstructParams, g: _Geometry) -> float:
    """m/s of v_r beyond the search bounds where a mover inside them appears to a search at v_a = 0: it reads
    v_los / cos(theta) = v_r + v_a tan(theta), and the autofocus finds v_a within +-autofocus_span (0 when v_a is
    given or not estimated: the search then runs at the mover's own v_a)."""
    if not params.autofocus or params.along_track_velocity is not None:
        return 0.0
    return params.autofocus_span * abs(math.tan(g.squint))


def _resolve_blind_velocity(
    win: _Window, estimate: float, v_a: float, params: ReconstructParams, g: _Geometry, reach: float = 0.0
) -> tuple[float, bool]:
    """Among the leakage minimum and its blind-velocity aliases inside the bounds, the one without range walk.

    Returns (velocity, beyond): ``beyond`` when even the best candidate keeps a residual walk of more than
    half the walk step lambda PRF / 2 between aliases, i.e. the true velocity is an alias outside the bounds.
    Then, with ``reach`` (m/s, _along_track_reach), the aliases up to ``reach`` beyond the bounds are tried too, and
    one that removes the walk is taken (not beyond): a mover inside the bounds whose v_a tan(theta) takes it outside
    them at this v_a (mover campaign scene 010's M2, v_r -17.14, v_a -13.03 m/s at 15.8 deg: -20.83 m/s at v_a = 0;
    its alias +19.74 was kept, its v_a autofocused at that wrong v_los to -6.1 m/s, v_r read +20.00 on the bound and
    the mover placed one PRF / K_a from where it appears: a false alarm and a miss).
    """
    period = blind_velocity_period(g)

    def aliases(lo: float, hi: float) -> list[float]:
        k_lo = math.ceil((lo - estimate) / period - 1e-9)
        k_hi = math.floor((hi - estimate) / period + 1e-9)
        return [estimate + k * period for k in range(k_lo, k_hi + 1)]

    candidates = aliases(params.velocity_min, params.velocity_max) or [estimate]
    walks = [abs(win.walk_rate(u, v_a)) for u in candidates]
    best = int(np.argmin(walks))
    step = C / g.fc * g.prf / 2
    if walks[best] > 0.5 * step and reach > 0:
        outside = [u for u in aliases(params.velocity_min - reach, params.velocity_max + reach) if u not in candidates]
        if outside:
            walks_out = [abs(win.walk_rate(u, v_a)) for u in outside]
            j = int(np.argmin(walks_out))
            if walks_out[j] <= 0.5 * step:
                return float(outside[j]), False
    return float(candidates[best]), bool(walks[best] > 0.5 * step)


def clutter_projector(n_az: int, g: _Geometry, band_factor: float = 1.0) -> tuple[np.ndarray, int]:
    """(n_az, N, N) projector of each base bin onto the complement of the static clutter steering vectors.

    Also returns the fewest redundant channels over the base bins.
    """
    n = len(g.tau0)
    fo = channels.band_frequencies(n_az, g.prf, n)
    h = np.exp(2j * np.pi * g.tau0[None, :, None] * fo[:, None, :])  # (n_az, N, N), eq. (3)
    clutter = np.abs(fo) <= g.half_band * band_factor  # aliases the static band covers
    a = h * clutter[:, None, :]
    return np.eye(n)[None] - a @ np.linalg.pinv(a, rcond=1e-10), int(n - clutter.sum(axis=1).max())


def clutter_null(
    spec_fa: np.ndarray, g: _Geometry, band_factor: float = 1.0, projector: np.ndarray | None = None
) -> tuple[np.ndarray, int]:
    """Project channel spectra (N, n_az, m) onto the complement of the static clutter steering vectors.

    Returns the residual (same shape) and the fewest redundant channels over the base bins.
    """
    n, n_az = spec_fa.shape[:2]
    proj, dof = clutter_projector(n_az, g, band_factor) if projector is None else (projector, -1)
    s = np.moveaxis(spec_fa, 0, 1).reshape(n_az, n, -1)
    res = (proj.astype(np.complex64) @ s).reshape((n_az, n) + spec_fa.shape[2:])
    return np.moveaxis(res, 1, 0), dof


def _swath_centre_range(raw: Product) -> float:
    rt = np.asarray(raw.coords["range_time"], float)
    return C / 4 * (rt[0] + rt[-1])


def _peak_half_width(mt: MovingTarget, g: _Geometry, spacing: _Spacing) -> int:
    """Output samples either side of a detection within which the refocused mover peaks (:func:`_refine_peak`).

    The detection image compresses every response with the static FM rate; a mover's differs by
    dK / K = R''(v_r, v_a) / R''(0, 0) - 1 (0.46 % for v_r 11.5, v_a -14 m/s at 15 deg squint), so its response there
    is smeared over dK / K x the illumination time T, and the band the conventional reconstruction leaves at one
    alias (or the clutter null notches) peaks anywhere within that: mover campaign scene 009's M4 was detected 30
    samples (3.0 ms) from where the modified reconstruction focuses it, outside the +-8 searched before, and tabled
    on the window's noise 49.5 m from its apparent position. The search covers PEAK_HALF_WIDTH plus that smear.
    """
    mover = velocity.range_acceleration(
        g.velocity, mt.along_track_velocity, mt.radial_velocity, g.squint, mt.slant_range
    )
    static = velocity.range_acceleration(g.velocity, 0.0, 0.0, g.squint, mt.slant_range)
    smear = abs(mover / static - 1.0) * spacing.t_ill * g.n * g.prf
    return PEAK_HALF_WIDTH + math.ceil(smear)


def _refine_peak(
    y_win_tf: np.ndarray,
    ka: np.ndarray,
    out_f: np.ndarray,
    index: int,
    spacing: float,
    n_out: int,
    only_here: bool = False,
    cell: int | None = None,
    half_width: int = PEAK_HALF_WIDTH,
) -> tuple[float, float]:
    """Sub-sample (azimuth index, window cell) of a refocused mover in its window's detection image.

    The detection may be one of the mover's ambiguities (``spacing`` = PRF / K_a in samples apart; the
    clutter null leaves a mover's energy mostly there): the strongest of them after the modified
    reconstruction, which puts the energy where the mover appears, is taken; with ``only_here`` (``index`` is
    where the null fit isolated the mover) only that one, as clutter brighter than the mover may sit at the others.
    With ``cell`` (the null fit's too) only the range cells within NULL_FIT_CELLS of it. Each alias is searched
    within ``half_width`` samples (:func:`_peak_half_width`: the detection's own offset from where the mover focuses).
    """
    spec = sfft.fft(y_win_tf, axis=0, workers=-1) * detection.compression(out_f, ka)
    power = detection.intensity(sfft.ifft2(spec, workers=-1))
    best = None
    k_max = int(n_out // spacing) + 1
    for k in [0] if only_here else range(-k_max, k_max + 1):
        centre = int(round(index + k * spacing))
        if not 0 <= centre < n_out:
            continue
        rows = np.arange(centre - half_width, centre + half_width + 1) % n_out
        sub = power[rows]
        if cell is not None:
            sub = sub.copy()
            sub[:, np.abs(np.arange(sub.shape[1]) - cell) > NULL_FIT_CELLS] = 0.0
        i, c = np.unravel_index(int(np.argmax(sub)), sub.shape)
        if best is None or sub[i, c] > best[0]:
            best = (sub[i, c], centre - half_width, i, c)
    if best is None:
        raise ValueError(f"no alias of index {index} falls inside the {n_out} output cells")
    _, lo, i, c = best
    return detection.band_limited_peak(spec, lo + int(i), int(c))


@dataclasses.dataclass
class _Detections:
    """CFAR detections in the azimuth-compressed detection source (``_detect``)."""

    out_f: np.ndarray  # azimuth frequencies of the N PRF output (Hz)
    r_mid: float  # swath-centre slant range (m): the FM rates' range
    image: np.ndarray  # compressed detection source; each examined detection's response is taken out of it
    bg: np.ndarray  # CFAR background of its power
    dets: list[detection.Detection]
    dropped: int  # detections over 20 max_detections, never examined
    static_peaks: list[detection.Detection]  # the conventional image's (residual mode only)
    probes: dict[int, _TruthProbe]  # _probe_truth's, for the miss reasons of the truth movers
    cfar_db: float  # threshold over the local background: detection_snr, then the measured background's (_second_pass)
    range_width: float  # range cells per range resolution (find_detections' side-lobe test)
    side_lobes: int  # residual peaks dropped as side lobes of static_peaks the null passed (both passes)
    static: detection.StaticSources | None  # static_peaks as those side lobes' sources (residual mode only)
    tail: detection.TailFit | None = None  # the measured background's tail (_second_pass)
    background_peaks: np.ndarray | None = None  # sorted z of the measured background's peaks (_second_pass)
    pulse_cells: int = 0  # range cells a response's range pedestal reaches either side (the chirp's T_p, _second_pass)


@dataclasses.dataclass(frozen=True)
class _Spacing:
    """Apparent-time spacing of a mover's ambiguities, and when two detections are separate targets."""

    ka0: float  # azimuth FM rate at f_r = 0 (Hz/s)
    ambiguity: float  # apparent-time spacing the channel samples cannot tell apart (s)
    sep: float  # apparent time the separation mask spans (s)
    t_ill: float  # illumination time (s)
    ghost_cells: int  # range cells a static point's ambiguity is smeared over either side

    def apart(self, d1: detection.Detection, d2: detection.Detection, cells: int, sep: float | None = None) -> bool:
        dt = (d1.time - d2.time) / self.ambiguity
        k = round(dt)
        sep = self.sep if sep is None else sep
        return (
            abs(d1.cell - d2.cell) > (cells if k == 0 else max(cells, self.ghost_cells))
            or abs(dt - k) * self.ambiguity > sep
        )


@dataclasses.dataclass(frozen=True)
class _Removed:
    """An examined detection whose response was taken out of the detection image (_remove_response), and what it
    was found to be: what a later detection it takes out with it is said to be explained by (the miss reasons)."""

    det: detection.Detection
    lo: int  # the range cells it was taken out of, [lo, hi)
    hi: int
    kind: str  # "mover", "static" or "incoherent"


@dataclasses.dataclass(frozen=True)
class _MergedResponse:
    """A response _merge counted as part of mover ``mover`` that looks like another target sharing its window: warned
    of once _drop_under_threshold has numbered the movers kept (_warn_merged)."""

    mover: int
    under_db: float
    cell: int
    offset: int
    spread: float
    place: str
    cause: str

    def said(self, subject: str) -> str:
        """The response, where it lies, against ``subject`` (the mover it was merged with, as numbered in the end)."""
        return (
            f"a response {self.under_db:.1f} dB under {subject}, in range cell {self.cell} ({self.offset} cells from "
            f"its peak; its own range extent {self.spread:.0f} cells) {self.place}"
        )


@dataclasses.dataclass
class _Tally:
    """What the detections examined so far have found (``_detect_and_focus``)."""

    dropped: int
    counts: dict[str, int]
    movers: list[MovingTarget] = dataclasses.field(default_factory=list)
    peaks: list[detection.Detection] = dataclasses.field(default_factory=list)  # each mover's detection
    rejected: list[dict] = dataclasses.field(default_factory=list)  # examined, no mover (for the miss reasons)
    flat: list[detection.Detection] = dataclasses.field(default_factory=list)  # those with no velocity dip
    # examined and found static, with their line-of-sight velocity: the detections they make static (_visit)
    statics: list[tuple[detection.Detection, float]] = dataclasses.field(default_factory=list)
    ambiguity_residues: list[str] = dataclasses.field(default_factory=list)  # incoherent ones at a mover's ambiguity
    removed: list[_Removed] = dataclasses.field(default_factory=list)  # examined, their responses taken out
    # mover index: what its refocus added to y_tr, for the movers _drop_under_threshold may take back
    undo: dict[int, np.ndarray] = dataclasses.field(default_factory=dict)
    # and the null fit's mismatch at its estimate and at rest (v_r = v_a = 0)
    at_rest: dict[int, tuple[float, float]] = dataclasses.field(default_factory=dict)
    # a response merged with a mover that could not be separated from it: (mover index, what to warn of), warned of
    # once _drop_under_threshold has said which movers stay (_warn_merged)
    merged: list[_MergedResponse] = dataclasses.field(default_factory=list)
    examined: int = 0
    visited: list[detection.Detection] = dataclasses.field(default_factory=list)  # _visit's detections so far


@dataclasses.dataclass
class _Scan:
    """What every detection's examination reads (and the two images it updates in place)."""

    params: ReconstructParams
    g: _Geometry
    bank: channels.FilterBank
    projector: np.ndarray | None  # clutter projector, residual mode only
    found: _Detections
    spacing: _Spacing
    x_tr: np.ndarray  # channel data in (t, range time)
    # the channel data as the removals so far left it (_remove_response): each removal takes its response out of
    # this, not out of x_tr, so overlapping windows never take one response twice nor add a notch's edge each time
    x_left: np.ndarray
    y_tr: np.ndarray  # reconstruction in (t', range time): each mover's modified one replaces its conventional one
    rt0: float  # first range time of the input (s)
    lead: int
    n_out: int
    n_cells: int
    # pairs of detections at one apparent time found to be two targets in range (_two_in_range), decided once
    split: dict[frozenset[detection.Detection], bool] = dataclasses.field(default_factory=dict)


@dataclasses.dataclass
class _DetWindow:
    """One detection's range cells and its channels separated from the rest of them."""

    a: int  # first range cell
    b: int  # one past the last
    f_w: np.ndarray  # range frequencies of the window (Hz)
    ka_w: np.ndarray  # azimuth FM rate per range frequency (Hz/s)
    x_w: np.ndarray  # channel data of the window in (t, f_r)
    ext: np.ndarray  # this detection's channels (detection.extract)
    win: _Window
    lo: int  # the cells its target takes, [lo, hi) (_window_bounds): [a, b) unless another target shares its Doppler
    hi: int


def _detect(
    raw: Product,
    params: ReconstructParams,
    g: _Geometry,
    src: np.ndarray,
    y: np.ndarray,
    f_r: np.ndarray,
    lead: int,
    residual_mode: bool,
) -> _Detections:
    """CFAR detections in the compressed ``src`` (and, residual mode, the conventional ``y``'s static peaks)."""
    r = raw.radar
    n_out = y.shape[0]
    out_f = sfft.fftfreq(n_out, 1.0 / (g.n * g.prf))
    r_mid = _swath_centre_range(raw)
    ka = detection.fm_rate(g.velocity, g.squint, r_mid, g.fc, f_r)
    image = detection.compressed(src, out_f, ka)
    power = (image.real**2 + image.imag**2).astype(np.float32)
    bg = detection.background(power)
    cfar_db = params.detection_snr
    range_width = max(1.0, g.fs / r.bandwidth)  # range cells per resolution cell
    static_peaks: list[detection.Detection] = []
    conv = bg_conv = static = None
    if residual_mode:
        # What the conventional image holds above the CFAR threshold (static points, clutter, the movers):
        # a mover's reconstruction must leave the static ones as they are (see _spared below).
        conv = detection.detection_image(y, out_f, ka)
        bg_conv = detection.background(conv)
        static_peaks = detection.find_detections(
            conv,
            bg_conv,
            g.out_times,
            params.detection_snr,
            params.detection_level,
            range_width,
            20 * params.max_detections,
        )[0]
        static = _static_sources(raw, g, params, static_peaks, r_mid)
    dets, dropped, side_lobes = detection.find_detections(
        power,
        bg,
        g.out_times,
        cfar_db,
        params.detection_level,
        range_width,
        20 * params.max_detections,
        static=static,
    )
    probes = _probe_truth(raw, params, g, lead, power, bg, conv, bg_conv)
    return _Detections(
        out_f,
        r_mid,
        image,
        bg,
        dets,
        dropped,
        static_peaks,
        probes,
        cfar_db,
        range_width,
        side_lobes,
        static,
        pulse_cells=math.ceil(r.pulse_duration * g.fs) + 2,
    )


def _static_sources(
    raw: Product, g: _Geometry, params: ReconstructParams, peaks: list[detection.Detection], r_mid: float
) -> detection.StaticSources:
    """The conventional image's peaks as sources of side lobes the clutter null passes (detection.StaticSources):
    their range response reaches about T_p (the chirp's aliased spectral tails; measured 52-57 cells at 12 MHz,
    5 us), the null passes their spectrum from (clutter_band - 1) half_band past the band edge on."""
    ka0 = float(detection.fm_rate(g.velocity, g.squint, r_mid, g.fc, 0.0))
    cells = math.ceil(raw.radar.pulse_duration * g.fs) + 2
    return detection.StaticSources(peaks, cells, max(0.0, params.clutter_band - 1) * g.half_band / ka0 * g.n * g.prf)


def _second_pass(scan: _Scan, tally: _Tally) -> list[detection.Detection]:
    """CFAR against the measured background: the detection image with every examined response taken out.

    The first pass (detection_snr over the tile-median background, detection_level under the strongest peak) finds
    the strong responses; each examined one is removed from the image (_remove_response). What is left is the
    background: clutter-null residue, noise and the movers too weak to be seen beside the strong ones' side lobes.
    Its peaks' normalised powers are fitted by a generalised Pareto tail (detection.peak_cfar) and the threshold
    set where they exceed it with probability false_alarm_rate (at least detection_snr); its peaks above that and
    above detection_level of its own strongest, off the side-lobe envelopes of the first pass's detections and not
    already seen, are the second pass's detections. The truth probes get the residual
    SNR where each mover appears and how many background peaks exceed it (the miss reasons say so).
    """
    params, found, g = scan.params, scan.found, scan.g
    power = (found.image.real**2 + found.image.imag**2).astype(np.float32)
    bg = detection.background(power)
    # the known responses' range cuts are no background where there is none besides them (no clutter null): under
    # the null, left in, they keep the threshold over the clutter residue (mover campaign scene 007: a false alarm at
    # 47.9 dB, v_r +0.20 m/s, with them left out; docs/multichannel.md section 23)
    cuts = _range_cuts(found, power.shape) if scan.projector is None else None
    cfar_db, tail, z = detection.peak_cfar(power, bg, params.false_alarm_rate, params.detection_snr, exclude=cuts)
    found.bg, found.cfar_db, found.tail, found.background_peaks = bg, cfar_db, tail, z
    dets, dropped, side_lobes = detection.find_detections(
        power,
        bg,
        g.out_times,
        cfar_db,
        params.detection_level,
        found.range_width,
        20 * params.max_detections,
        known=sorted(found.dets, key=lambda d: -d.power),
        static=found.static,
    )
    found.side_lobes += side_lobes
    new = [
        d
        for d in dets
        if not any(abs(d.cell - p.cell) <= 2 and abs(d.index - p.index) <= max(2.0, p.width) for p in found.dets)
    ]
    tally.dropped += dropped
    if cuts is not None:
        on_pedestal = [_on_range_pedestal(d, found, scan.n_out) for d in new]
        new = [d for d, dropped_here in zip(new, on_pedestal) if not dropped_here]
        tally.counts["range_pedestal"] = sum(on_pedestal)
    found.dets.extend(new)
    for probe in found.probes.values():
        i, c = probe.peak_index, probe.peak_cell
        rows = np.arange(i - PROBE_SAMPLES, i + PROBE_SAMPLES + 1) % scan.n_out
        cols = slice(max(0, c - 3), min(scan.n_cells, c + 4))
        level = float(np.max(power[rows, cols] / np.maximum(bg[rows, cols], 1e-30)))
        probe.residual_snr_db = 10 * math.log10(level) if level > 0 else -math.inf
        probe.background_peaks_above = int(len(z) - np.searchsorted(z, level, side="right"))
    log.info(
        "reconstruct: measured background (%d peaks, tail xi %.2f): CFAR threshold %.1f dB for a false-alarm rate "
        "%.3g per peak; %d new detection(s)%s",
        len(z),
        tail.xi if tail is not None else float("nan"),
        cfar_db,
        params.false_alarm_rate,
        len(new),
        f" ({n} more on a detection's range pedestal)" if (n := tally.counts.get("range_pedestal", 0)) else "",
    )
    return new


def _on_range_pedestal(det: detection.Detection, found: _Detections, n_az: int) -> bool:
    """Whether a second-pass candidate lies on a stronger earlier detection's range cut as _range_cuts spans it
    (RANGE_CUT_SAMPLES azimuth samples either side, pulse_cells in range: the cells the CFAR left out of the
    background as that response's structure) and under its range side-lobe envelope with SIDELOBE_MARGIN
    (detection.side_lobe_of's). find_detections applies that envelope only within max(2, width) samples of the
    detection's azimuth index; a mover's ambiguity, skewed by its range-azimuth coupling, has its range side lobes
    further off its index (mover campaign scene 025 band-limited: two candidates in cells 134 and 168, either side of
    M2's -1 x PRF / K_a response in cells 150-151, 6 samples off its index, 45.7 / 45.9 dB under it and 18.5-19.3 dB
    under the envelope, read as a static point and a false mover at v_r 12.3 m/s; docs/multichannel.md section 34).
    Only without the clutter null, as _range_cuts (with it, the cuts hold clutter residue that is background)."""
    for d in found.dets:
        if d.power <= det.power:
            continue
        dt = abs(det.index - d.index)
        dt = min(dt, n_az - dt)
        dr = abs(det.cell - d.cell)
        if dt > RANGE_CUT_SAMPLES or dr > found.pulse_cells:
            continue
        envelope = detection.SIDELOBE_MARGIN * detection.sinc_sidelobes(max(dr / found.range_width, 0.5))
        if det.power < d.power * envelope:
            log.debug(
                "reconstruct: candidate at cell %d, %.4f s (SNR %.1f dB) on the range cut of the detection at cell %d, "
                "%.4f s, %.1f dB under it (its side-lobe envelope %.1f dB under): its range pedestal, not examined",
                det.cell,
                det.time,
                det.snr_db,
                d.cell,
                d.time,
                10 * math.log10(d.power / det.power),
                -10 * math.log10(envelope),
            )
            return True
    return False


def _range_cuts(found: _Detections, shape: tuple[int, ...]) -> np.ndarray:
    """Cells (True) on the range cuts of the detections made so far: RANGE_CUT_SAMPLES azimuth samples either side of
    each and its pulse_cells in range, where its range pedestal lies (the chirp's spectral tails; on the continuous
    chirp's echoes out to T_p at -42 dB of the peak, 10-11 dB over the 1 / (pi x)^2 envelope). Those peaks are the
    known responses' structure, not the background: in a scene without noise or clutter they were the measured
    background's strongest peaks, whose tail fit (xi 0.8-0.9) set the threshold 64-69 dB over it, over two movers
    the take-out had left whole (mover campaign scene 039, docs/multichannel.md section 20)."""
    n_az, n_cells = shape
    out = np.zeros(shape, bool)
    rows = np.arange(-RANGE_CUT_SAMPLES, RANGE_CUT_SAMPLES + 1)
    for d in found.dets:
        cols = slice(max(0, d.cell - found.pulse_cells), min(n_cells, d.cell + found.pulse_cells + 1))
        out[(d.index + rows) % n_az, cols] = True
    return out


def _cfar_info(found: _Detections, params: ReconstructParams) -> dict:
    """The CFAR threshold and the measured background's tail it was set from (product metadata)."""
    peaks = found.background_peaks
    out: dict = {
        "threshold_db": found.cfar_db,
        "false_alarm_rate": params.false_alarm_rate,
        "floor_db": params.detection_snr,
        "set_by": "floor" if found.tail is None or found.cfar_db <= params.detection_snr else "false_alarm_rate",
        "background_peaks": 0 if peaks is None else len(peaks),
        "expected_false_alarms": 0.0 if peaks is None else params.false_alarm_rate * len(peaks),
    }
    if found.tail is not None:
        t = found.tail
        out["tail"] = {"u": t.u, "p_u": t.p_u, "xi": t.xi, "sigma": t.sigma, "peaks": t.n}
    return out


def _spacing(g: _Geometry, params: ReconstructParams, r_mid: float) -> _Spacing:
    ka0 = float(detection.fm_rate(g.velocity, g.squint, r_mid, g.fc, 0.0))
    # An ambiguity k PRF / K_a away keeps the mover's range history while a static point there walks by
    # lambda k PRF / 2 m/s: over the illumination time it is smeared over this many cells either side.
    t_ill = 2 * g.half_band / ka0
    ghost_cells = 2 + math.ceil(C / g.fc * g.prf / 2 * t_ill / 2 * 2 * g.fs / C)
    return _Spacing(ka0, g.prf / ka0, 1.5 * params.separation_bandwidth / ka0, t_ill, ghost_cells)


def _detect_and_focus(
    raw: Product,
    params: ReconstructParams,
    g: _Geometry,
    spec: np.ndarray,
    src: np.ndarray,
    y: np.ndarray,
    f_r: np.ndarray,
    lead: int,
    info: dict,
    progress: ProgressFactory | None,
    bank: channels.FilterBank,
    residual_mode: bool,
) -> list[MovingTarget]:
    """Detect movers on ``src`` (detection.py), estimate and refocus each one in ``y`` (f_a, f_r), in place.

    Each detection's channels are separated from the rest of its range cells (detection.extract); its
    conventional reconstruction in ``y`` is replaced by its modified one (linear: static targets and the
    other movers are untouched). Detections whose line-of-sight velocity is under ``detection_velocity``
    are static targets (or the clutter null's residue) and are left as they are.
    """
    found = _detect(raw, params, g, src, y, f_r, lead, residual_mode)
    spacing = _spacing(g, params, found.r_mid)
    x_tr = sfft.ifft(spec, axis=-1, workers=-1)
    y_tr = sfft.ifft(sfft.ifft(y, axis=0, workers=-1), axis=1, workers=-1)
    projector = clutter_projector(len(g.times), g, params.clutter_band)[0] if residual_mode else None
    n_out, n_cells = y.shape
    rt0 = float(raw.coords["range_time"][0])
    scan = _Scan(params, g, bank, projector, found, spacing, x_tr, x_tr.copy(), y_tr, rt0, lead, n_out, n_cells)
    counts = {"detections": len(found.dets), "static": 0, "ambiguous": 0, "incoherent": 0, "explained": 0}
    tally = _Tally(found.dropped, counts)
    first = _examination_order(found.dets, scan)
    for det in progress(first) if progress is not None else first:
        _visit(det, scan, tally)
    second = _second_pass(scan, tally)
    counts["detections"] += len(second)
    counts["second_pass"] = len(second)
    for det in _examination_order(second, scan):
        _visit(det, scan, tally)
    kept = _drop_under_threshold(scan, tally)
    _warn_within_noise(tally)
    _warn_merged(tally, kept)
    _warn_unseparated(scan, tally)
    _warn_unexamined(tally, params, found.cfar_db)
    counts["not_examined"] = tally.dropped
    counts["static_side_lobes"] = found.side_lobes
    if found.side_lobes:
        log.info(
            "reconstruct: %d residual peak(s) dropped as side lobes of a brighter static response that the clutter "
            "null passed (under its side-lobe envelope, mirrored about it or deep under it)",
            found.side_lobes,
        )
    del scan, x_tr
    y[:] = sfft.fft(sfft.fft(y_tr, axis=1, workers=-1), axis=0, workers=-1)
    info["detections"] = counts
    info["detection_cfar"] = _cfar_info(found, params)
    info["_probes"] = (found.probes, tally.rejected, spacing.ambiguity * g.n * g.prf)
    return tally.movers


def _on_leakage(det: detection.Detection, clean: detection.Detection) -> bool:
    """Whether ``det`` stands on a background LEAKAGE_BACKGROUND_DB over ``clean``'s (its ambiguity's)."""
    return clean.background * 10 ** (LEAKAGE_BACKGROUND_DB / 10) < det.background


def _examination_order(dets: list[detection.Detection], scan: _Scan) -> list[detection.Detection]:
    """The order detections are examined in: strongest (power) first, but on the clutter null's residual each one's
    ambiguity family (the detections k != 0 times PRF / K_a from it in apparent time, within the ghost walk in
    range and 2.5 x separation_bandwidth / K_a of the exact ambiguity: _ambiguity_of's reach) is examined from its
    member of highest SNR over the local background.

    An examined detection's response is taken out of the image with its ambiguities (_remove_response), so the member
    examined first decides for the whole family. With a beam whose Doppler spectrum has skirts (gaussian, sinc), a
    mover's own response at its apparent position (k = 0) survives the null as a narrow peak on the static scene's
    leakage, 9-10 dB brighter than its ambiguities but on a background 14-25 dB higher, where neither eq. 5 nor
    the null fit explains it: examined first it was taken for no point target and took the mover with it (mover
    campaign scene 007: all four movers; docs/multichannel.md section 8). Its ambiguity on the clean background has
    the higher SNR, and the null fit explains it. So a member moves up only from a background LEAKAGE_BACKGROUND_DB
    under the detection's (scene 007: 17-26 dB; xu_traffic's rect-beam families differ by 3-7 dB and keep their
    order). Examining every detection in SNR order finds scene 007's movers too, but examines weak static responses
    before the bright ones whose removal explains them (xu_traffic: 4 more found static, 3.3 x the CPU); moving up
    every family's best SNR still 2 (2.6 x)."""
    if scan.projector is None:
        return list(dets)
    sp = scan.spacing
    reach = 2.5 * scan.params.separation_bandwidth / sp.ka0

    def family(d: detection.Detection, e: detection.Detection) -> bool:
        k = round((e.time - d.time) / sp.ambiguity)
        off = e.time - d.time - k * sp.ambiguity
        return k != 0 and abs(e.cell - d.cell) <= sp.ghost_cells and abs(off) <= reach

    order: list[detection.Detection] = []
    placed: set[int] = set()
    for d in dets:
        if id(d) in placed:
            continue
        cleaner = (e for e in dets if id(e) not in placed and family(d, e) and _on_leakage(d, e))
        best = max(cleaner, key=lambda e: e.snr_db, default=d)
        for e in (best, d) if best.snr_db > d.snr_db else (d,):
            order.append(e)
            placed.add(id(e))
    return order


def _visit(det: detection.Detection, scan: _Scan, tally: _Tally) -> None:
    """Merge ``det`` into a mover found, pass it as explained or unexamined, or examine it."""
    params, found, sep = scan.params, scan.found, scan.spacing.sep
    threshold = 10 ** (found.cfar_db / 10)
    left = found.image[det.index, det.cell]
    # under the threshold once the removals took their responses out, and taken down by them by more than its own
    # background could move it (TAKEN_SIGMAS): a target of its own that the removals spared (notched) loses only the
    # background they took with them, and one that passed the threshold by less than that falls under it without
    # being explained by anything (mover campaign scene 027, clutter null: M4 at SNR 15.1 dB, notched 289 Hz off in
    # a brighter mover's removal, kept its response but lost the clutter residue and noise the complement took: 1.9
    # dB, an amplitude drop of 1.6 of its background's sigmas; docs/multichannel.md section 25)
    drop = math.sqrt(det.power) - abs(left)
    explained = abs(left) ** 2 < threshold * found.bg[det.index, det.cell] and drop > TAKEN_SIGMAS * math.sqrt(
        det.background / 2
    )
    explained = explained or _under_side_lobes(det, float(abs(left) ** 2), scan, tally)
    tally.visited.append(det)
    same = [k for k, p in enumerate(tally.peaks) if _shares_window(det, k, scan, tally)]
    if same:
        _merge(det, same[0], scan, tally)
        return
    if explained:
        tally.counts["explained"] += 1  # a response of a detection already examined, no target of its own
        tally.rejected.append(
            {
                "cell": det.cell,
                "index": det.index,
                "snr_db": det.snr_db,
                "kind": "explained",
                "by": _explained_by(det, scan, tally),
                "threshold_db": found.cfar_db,  # the threshold it fell under (the first pass's: detection_snr)
            }
        )
        log.debug(
            "reconstruct: detection at cell %d, %.4f s (SNR %.1f dB) explained by those examined",
            det.cell,
            det.time,
            det.snr_db,
        )
        return
    static = [v for s, v in tally.statics if abs(det.cell - s.cell) <= STATIC_CELLS and abs(det.time - s.time) <= sep]
    if static:
        # In the range cell of a detection examined and found static and inside its separation mask: the same
        # channels, the same answer; examining it again costs the null fit's search (xu_traffic_static: 21
        # detections in one range cell within 15 ms, each static at v_los 0.00-0.14 m/s, 5-12 s each).
        _reject(det, [f"static {static[0]:.6g}"], tally, examined=False)
        return
    if tally.examined >= params.max_detections:
        tally.dropped += 1
        return
    tally.examined += 1
    _examine(det, scan, tally)


def _under_side_lobes(det: detection.Detection, left_power: float, scan: _Scan, tally: _Tally) -> bool:
    """Whether what the removals left of ``det`` lies under the side-lobe envelope of a stronger detection visited
    before it (detection.side_lobe_of, with that detection's power as detected): the side-lobe test ``det`` passed
    when it was detected, applied again to what is left, as _second_pass applies it to its candidates. A target of
    its own keeps its power through the other removals (their notches spare it); a pixel the removals took down
    under a stronger response's envelope held that response's side lobes and the removals' residue. Mover campaign
    scene 000: a pixel in M5's range cell 33 Hz from M5's response at its second ambiguity (22.0 dB under it, 0.3 dB
    over its envelope) held 2.5 dB of power; the removals left -6.2 dB, 8.4 dB under the envelope but still over the
    CFAR threshold, and its examination read a false mover (v_r -5.08, v_a -18.3 m/s, SNR 28.4 dB)."""
    stronger = [d for d in tally.visited if d.power > det.power]
    return bool(stronger) and any(
        detection.side_lobe_of(d, left_power, det.index, det.cell, scan.n_out, scan.found.range_width) for d in stronger
    )


def _explained_by(det: detection.Detection, scan: _Scan, tally: _Tally) -> _Removed | None:
    """The examined detection whose response took ``det``'s out with it: of those taken out of ``det``'s range cell,
    the nearest to it in apparent time modulo PRF / K_a (a response is taken out with its ambiguities); None if none."""
    amb = scan.spacing.ambiguity

    def off(r: _Removed) -> float:
        k = (det.time - r.det.time) / amb
        return abs(k - round(k))

    near = [r for r in tally.removed if r.lo <= det.cell < r.hi]
    return min(near, key=off) if near else None


def _shares_window(det: detection.Detection, k: int, scan: _Scan, tally: _Tally) -> bool:
    """Whether ``det`` lies in mover k's window and separation mask (or an ambiguity of it): the same channels. At the
    same apparent time (k = 0) only inside the range cells of its window, which _window_bounds may have narrowed."""
    p, mt = tally.peaks[k], tally.movers[k]
    sep = 1.5 * max(_half_width(det, scan), _half_width(p, scan)) / scan.spacing.ka0
    if scan.spacing.apart(det, p, scan.params.window_margin, sep):
        return False
    return round((det.time - p.time) / scan.spacing.ambiguity) != 0 or mt.first_cell <= det.cell < mt.last_cell


def _response_spread(v_los: float, n_amb: int, scan: _Scan) -> float:
    """Walk-corrected range cells a mover at ``v_los`` spreads over either side of its peak (_range_extent), at its
    ambiguity ``n_amb`` (k PRF / K_a) further: that walks by lambda k PRF / 2 m/s against the mover."""
    g, sp = scan.g, scan.spacing
    return _range_extent(v_los, scan) + abs(n_amb) * C / g.fc * g.prf / 2 * sp.t_ill * 2 * g.fs / C


def _another_target(det: detection.Detection, peak: detection.Detection, spread: float, scan: _Scan) -> bool:
    """Whether ``det``, sharing the window of the mover examined at ``peak`` (_shares_window), looks like another
    target there rather than the mover's own response (_merge warns of it): as strong as MERGE_LEVEL of it and
    beyond its range extent ``spread`` there (cells either side of its peak, _response_spread) or its azimuth width,
    or, at its apparent time without the clutter null, resolved from it in azimuth and over its side-lobe envelope
    there."""
    g, sp = scan.g, scan.spacing
    n_amb = round((det.time - peak.time) / sp.ambiguity)
    # beyond its range extent, or beyond its own azimuth width (the same range cells, a different apparent azimuth)
    d_samples = abs((det.time - peak.time) - n_amb * sp.ambiguity) * g.n * g.prf
    apart_azimuth = d_samples > 2 * max(peak.width, det.width) + 2
    # the mover's own response on the static leakage, examined from its ambiguity instead (_examination_order)
    on_leakage = n_amb != 0 and _on_leakage(det, peak)
    apart = abs(det.cell - peak.cell) > spread or apart_azimuth
    # At its apparent time (k = 0), without the clutter null, a response resolved from the mover in azimuth (their -3 dB
    # half widths apart twice over) and 12 dB over its side-lobe envelope there (twice find_detections' margin: a rect
    # beam's mover had a response 5 samples off at -11.8 dB, on that envelope) is no structure of the mover's own
    # (mover campaign scene 038: M2, defocused, 11 samples wide, 25 samples and 19 Hz from M3, 12.3 dB under it,
    # merged with no warning, and M3's v_r read 3.41 for 2.80 m/s; docs/multichannel.md section 20)
    resolved = n_amb == 0 and scan.projector is None and d_samples > peak.width + det.width + 2
    if resolved:  # (not at the mover's own apparent time: there the envelope has no value)
        lobe = detection.SIDELOBE_MARGIN**2 * detection.sinc_sidelobes(d_samples / peak.width) * peak.power
        resolved = det.power > lobe
    level = MERGE_LEVEL_RESOLVED if resolved else MERGE_LEVEL
    return det.power > level * peak.power and (apart or resolved) and not on_leakage


def _merge(det: detection.Detection, k: int, scan: _Scan, tally: _Tally) -> None:
    """Count ``det`` as part of mover ``k``; warn when it looks like another target sharing its window."""
    g, sp = scan.g, scan.spacing
    peak = tally.peaks[k]
    tally.counts["ambiguous"] += 1
    tally.rejected.append({"cell": det.cell, "index": det.index, "snr_db": det.snr_db, "kind": "merged", "mover": k})
    log.debug("reconstruct: detection at cell %d, %.4f s merged with mover %d", det.cell, det.time, k)
    # A mover spreads over its range walk |v_los| T and curvature R'' T^2 / 8 in walk-corrected range:
    # a response inside that is its own; one beyond it and as strong is another target.
    n_amb = round((det.time - peak.time) / sp.ambiguity)
    spread = _response_spread(tally.movers[k].line_of_sight_velocity(g.squint), n_amb, scan)
    if _another_target(det, peak, spread, scan):
        if n_amb == 0:
            where = f"{1e3 * (det.time - peak.time):+.1f} ms from it in apparent time"
            cause = "another mover there shares its window and its velocity estimate"
        else:
            # At an ambiguity the response may be the mover's own residue (xu_traffic_static: V9's at -2 x PRF / K_a,
            # 16 cells off, where no truth mover is): nothing here tells which, so both are said.
            where = (
                f"{n_amb:+d} x PRF / K_a {1e3 * (det.time - peak.time - n_amb * sp.ambiguity):+.1f} ms from it in "
                "apparent time (at its ambiguity)"
            )
            cause = "its ambiguity's residue, or another mover there sharing its window (not examined on its own)"
        under_db = 10 * math.log10(peak.power / det.power)
        tally.merged.append(_MergedResponse(k, under_db, det.cell, det.cell - peak.cell, spread, where, cause))


def _crowded(det: detection.Detection, w: _DetWindow, scan: _Scan, tally: _Tally) -> bool:
    """Whether a detection not yet visited lies in ``det``'s window at its apparent time (k = 0), inside its target's
    cells and separation mask (_shares_window: it will be merged with this mover), and looks like another target
    there (_another_target, its range extent that of the search bound's |v_los|: the widest a mover's own response
    can be): the product will warn that it shares the mover's window and velocity estimate (_warn_merged)."""
    sp, params = scan.spacing, scan.params
    seen = {id(d) for d in tally.visited}
    spread = _response_spread(max(abs(params.velocity_min), abs(params.velocity_max)), 0, scan)
    for d in scan.found.dets:
        if id(d) in seen or round((d.time - det.time) / sp.ambiguity) != 0 or not w.lo <= d.cell < w.hi:
            continue
        sep = 1.5 * max(_half_width(d, scan), _half_width(det, scan)) / sp.ka0
        if not sp.apart(d, det, params.window_margin, sep) and _another_target(d, det, spread, scan):
            return True
    return False


def _examine(det: detection.Detection, scan: _Scan, tally: _Tally) -> None:
    """Estimate ``det``'s velocities in its window, take its response out of the image, refocus it if it moves."""
    params, g = scan.params, scan.g
    w = _window_at(det, scan, tally)
    if scan.projector is not None:
        _log_null_survival(det, w.ext, scan)
    centre_range = C / 2 * (scan.rt0 + (det.cell - scan.lead) / g.fs)
    # A criterion with no dip at any velocity: no point target (noise, a side lobe, clutter residue).
    null_fit = (
        _NullFit(
            w.win,
            det.index,
            det.cell - w.a,
            w.ka_w,
            scan.spacing.ka0,
            scan.projector,
            scan.bank,
            scan.spacing.ghost_cells,
        )
        if scan.projector is not None
        else None
    )
    mt, notes = _estimate(
        w.win,
        params,
        g,
        centre_range,
        det.cell - w.a,
        static_below=params.detection_velocity,
        flat_above=0.95,
        null_fit=null_fit,
        crowded=_crowded(det, w, scan, tally),
    )
    # The other targets in this window (detected anywhere in its cells, not at this one's position or
    # ambiguities) keep their own reconstruction; everything else in the window takes this mover's. So do those
    # up to window_margin cells beyond its cells: their range side lobes in its cells, given this mover's
    # reconstruction and cut at its edge, focus beside them (the session 42 trial, docs/multichannel.md section
    # 22: static S 4 cells below M3's window, v_r 12 m/s, left -27.9 dB of its peak 4 cells from it in range; M1
    # and M3 in each other's reach -34.8 and -35.2 dB; notched, -47.4, -47.2, -47.2 dB, as each alone).
    others = _others(det, w, scan)
    band = _half_width(det, scan)
    kept = _others(det, w, scan, params.window_margin)
    whole = detection.extract(w.x_w, g.times, g.prf, det.time, w.ka_w, band, notches=kept)
    _remove_response(det, others, w, scan)
    # The reconstruction also spares the static targets the null hid from the detections (bright points in
    # the conventional image, in this window's cells, not at this detection's apparent time modulo PRF / K_a).
    spared = _spared(det, w, scan, params.window_margin)
    if spared:
        whole = detection.extract(w.x_w, g.times, g.prf, det.time, w.ka_w, band, notches=kept + spared)
    kind = "mover" if mt is not None else "incoherent" if notes == ["incoherent"] else "static"
    tally.removed.append(_Removed(det, w.lo, w.hi, kind))
    if mt is None:
        _reject(det, notes, tally, ambiguity_of=_ambiguity_of(det, scan, tally) if notes == ["incoherent"] else None)
        return
    for note in notes:
        log.warning("reconstruct: mover in range cells %d-%d at %.3f s: %s", w.lo, w.hi - 1, det.time, note)
    _refocus(det, mt, w, whole, scan, tally, null_fit)


def _range_extent(v_los: float, scan: _Scan) -> float:
    """Walk-corrected range cells a mover's response spreads over (either side of its peak, with 2 cells of range
    resolution): its range walk |v_los| T and curvature R'' T^2 / 8 over the illumination time T."""
    g, sp = scan.g, scan.spacing
    curvature = g.velocity**2 * math.cos(g.squint) ** 2 / scan.found.r_mid * sp.t_ill**2 / 8
    return (abs(v_los) * sp.t_ill + curvature) * 2 * g.fs / C + 2


def _window_bounds(det: detection.Detection, scan: _Scan) -> tuple[int, int]:
    """The range cells [lo, hi) ``det``'s target may take: window_margin cells either side, but only up to half way to
    another detection at the same apparent time (inside the separation mask, k = 0) farther than any mover's own range
    extent (the search bound's |v_los|): a second target there. The mask cannot tell the two apart (the same
    Doppler), their range cells do; a target taking both mixed their velocities and merged the second into the
    first (mover campaign scene 003: two movers 7 cells apart at one apparent azimuth, one missed, the other's v_r
    1.07 m/s off with a warning blaming the search bound). The weaker of the two must rise over the stronger's
    side-lobe envelope and stand over its mirror (_two_in_range; a mover's range side lobe, off its azimuth index by
    its range-azimuth coupling, is not a second target: 29 dB under a mover 14 cells away, it became one)."""
    params, sp, m = scan.params, scan.spacing, scan.params.window_margin
    a, b = max(0, det.cell - m), min(scan.n_cells, det.cell + m + 1)
    reach = _range_extent(max(abs(params.velocity_min), abs(params.velocity_max)), scan)
    for d in scan.found.dets:
        gap = d.cell - det.cell
        if d is det or abs(gap) <= reach or sp.apart(d, det, m) or round((d.time - det.time) / sp.ambiguity) != 0:
            continue
        if not _two_in_range(det, d, scan):
            continue
        if gap > 0:
            b = min(b, det.cell + math.ceil(gap / 2))
        else:
            a = max(a, det.cell + math.floor(gap / 2) + 1)
    return a, b


def _two_in_range(d1: detection.Detection, d2: detection.Detection, scan: _Scan) -> bool:
    """Whether two detections at one apparent time, farther apart in range than a mover's extent, are two targets:
    the weaker rises over the stronger's side-lobe envelope there, stands over its mirror image about the stronger
    and the detection image dips between them by 6 dB under the weaker. A mover's response at an ambiguity with the
    clutter null is smeared in range by its walk against the mover (lambda k PRF / 2 m/s) into a ridge of several
    peaks with no dip between (tests/focus/test_movers.py's movers_in_clutter: V2's at +1 x PRF / K_a, 4-5 cells
    long, two false alarms when split). Decided the first time the pair is seen, before either's response is taken
    out of the image.

    All three in two dimensions (on the stronger's range cut, the weaker at its azimuth index, they are as before).
    The envelope is the range side-lobe envelope as find_detections asks times the stronger's own azimuth profile
    measured on its range cut at the weaker's azimuth offset (_azimuth_level): a point's response is separable, so
    its side lobe 8 cells and 5 samples off is the product of the two (mover campaign scene 006: M1 at -21.0 dB of
    the static point S3, 0.6 dB under S3's range envelope alone, 10.7 dB over the product; taken for S3's side lobe
    and missed, before), and a smeared or unresolved response is measured as wide as it is (a pair of movers' lobe 3
    samples off its cut, a false alarm when the range envelope was applied on the cut only). The mirror is the range
    reflection at the weaker's azimuth, the point reflection (a skewed response) and the stronger's range side lobe
    on its cut carried to the weaker's azimuth offset by that profile; the dip is along the straight path between
    them. Both were over the rectangle the two span, which holds the stronger's range side lobes on its own cut: a
    weak target off the cut stood under them. In the clutter null's residual image (residual mode) they are as before,
    the range envelope alone over that rectangle: there a static point's response is what the null left of it, with
    the clutter's residue beside it, and the product does not bound it (mover campaign scene 007: a detection 13 cells
    and 21 samples from the static point S1's residue, 26.1 dB under it, 8.8 dB over the product, split off into a
    window of 10 cells: a false alarm, v_r +5.86 m/s)."""
    key = frozenset((d1, d2))
    if key not in scan.split:
        top, low = (d1, d2) if d1.power >= d2.power else (d2, d1)
        image, n = scan.found.image, scan.n_out
        c0, c1 = sorted((d1.cell, d2.cell))
        m = 2 * top.cell - low.cell  # the mirror's cells: a side lobe has its mirror image about the stronger peak
        cells = np.arange(max(0, m - 1), min(scan.n_cells, m + 2))
        if scan.found.static is None:
            # conventional image: two-dimensional (the docstring)
            def level(centre: int) -> float:
                v = image[np.ix_(np.arange(centre - 1, centre + 2) % n, cells)]
                return float(np.max(v.real**2 + v.imag**2)) if v.size else 0.0

            azimuth = _azimuth_level(top, low.index, scan)
            dt = (low.index - top.index + n // 2) % n - n // 2
            cols = np.arange(c0 + 1, c1)
            centre = np.rint(top.index + dt * (cols - top.cell) / (low.cell - top.cell)).astype(int)
            path = image[(centre + np.arange(-1, 2)[:, None]) % n, cols]
            valley = float(np.min(np.max(path.real**2 + path.imag**2, axis=0)))
            mirrored = max(level(low.index), level(2 * top.index - low.index), azimuth * level(top.index))
        else:
            # clutter-null residual: over the rectangle the two span, the range envelope alone (the docstring)
            azimuth = 1.0
            i0, i1 = sorted((d1.index, d2.index))
            rows = np.arange(i0 - 1, i1 + 2) % n
            between = image[np.ix_(rows, np.arange(c0 + 1, c1))]
            valley = float(np.min(np.max(between.real**2 + between.imag**2, axis=0)))
            mirror = image[np.ix_(rows, cells)]
            mirrored = float(np.max(mirror.real**2 + mirror.imag**2)) if mirror.size else 0.0
        envelope = (
            detection.SIDELOBE_MARGIN * detection.sinc_sidelobes((d1.cell - d2.cell) / scan.found.range_width) * azimuth
        )
        scan.split[key] = (
            low.power > envelope * top.power
            and valley < 0.25 * low.power
            and low.power > detection.MIRROR_MARGIN * mirrored
        )
    return scan.split[key]


def _azimuth_level(top: detection.Detection, index: int, scan: _Scan) -> float:
    """The envelope of ``top``'s azimuth profile as measured on its range cut (its cell) at azimuth sample ``index``,
    relative to ``top``'s power and at most 1: the most the cut holds from |dt| - 1 to 2 |dt| + 1 samples either side
    of ``top`` (dt: ``index``'s offset from it). A response's side lobes fall off outward, so the most beyond an
    offset bounds them there: a point's sinc lobes, not the null between two (scene 006's S3: -11.3 dB 5 samples
    out), and a smeared response or several unresolved ones as far as they reach (two points 4 samples apart:
    -1.1 dB 5 samples from the stronger, tests/focus/test_movers.py)."""
    n = scan.n_out
    dt = abs((index - top.index + n // 2) % n - n // 2)
    k = np.arange(max(dt - 1, 0), 2 * dt + 2)
    cut = scan.found.image[np.concatenate((top.index + k, top.index - k)) % n, top.cell]
    return min(1.0, float(np.max(cut.real**2 + cut.imag**2)) / top.power) if top.power > 0 else 1.0


def _neighbours(det: detection.Detection, scan: _Scan, tally: _Tally | None) -> int:
    """How many other detections (or movers found) lie in ``det``'s separation pass band (under 1.5
    separation_bandwidth from it in dechirped Doppler, modulo PRF), beyond any mover's own range extent from it (as
    _window_bounds) and within 2 window_margin cells, whose range side lobes reach it over NEIGHBOUR_LEVEL of its
    power and over its local background (on the unweighted sinc envelope, as _two_in_range): the targets _window_at's
    range taper is for. Nearer in range a response is the mover's own structure or a neighbour whose main lobe the
    taper does not take out; under the background (clutter residual, noise) the taper's loss of 1.8 dB of the
    mover's SNR outweighs them (scene 012: a detection at SNR 16.0 dB with side lobes 20 dB under it read v_r 1.16
    m/s tapered, a false alarm; 0.9 untapered, taken back as static)."""
    g, sp, params = scan.g, scan.spacing, scan.params
    band, m = params.separation_bandwidth, params.window_margin
    reach = _range_extent(max(abs(params.velocity_min), abs(params.velocity_max)), scan)
    peaks = tally.peaks if tally is not None else []
    n = 0
    for d in {id(d): d for d in (*scan.found.dets, *peaks)}.values():
        gap = abs(d.cell - det.cell)
        if d is det or not reach < gap <= 2 * m:
            continue
        f_d = (sp.ka0 * (d.time - det.time) + g.prf / 2) % g.prf - g.prf / 2
        envelope = detection.sinc_sidelobes(gap / scan.found.range_width)
        if abs(f_d) < 1.5 * band and d.power * envelope >= max(NEIGHBOUR_LEVEL * det.power, det.background):
            log.debug(
                "reconstruct: detection at cell %d, %.4f s: a neighbour at cell %d, %+.1f Hz, %+.1f dB (its side lobes "
                "%+.1f dB here)",
                det.cell,
                det.time,
                d.cell,
                f_d,
                10 * math.log10(d.power / det.power),
                10 * math.log10(d.power * envelope / det.power),
            )
            n += 1
    return n


def _range_tapered(scan: _Scan, a: int, b: int) -> np.ndarray:
    """Channels of range cells [a, b) in (t, f_r) with a Hann taper over the chirp's band: what a target's range
    side lobes leave in the cells is -31 dB of its peak and falls fast, instead of the unweighted sinc's -13 dB
    falling as 1 / n^2. The taper is applied over RANGE_TAPER_CELLS more cells either side (its kernel's reach), so
    the cells kept hold the line's weighted response."""
    g = scan.g
    a_e, b_e = max(0, a - RANGE_TAPER_CELLS), min(scan.n_cells, b + RANGE_TAPER_CELLS)
    f_e = sfft.fftfreq(b_e - a_e, 1.0 / g.fs)
    hann = np.where(np.abs(f_e) <= g.bandwidth / 2, 0.5 + 0.5 * np.cos(2 * np.pi * f_e / g.bandwidth), 0.0)
    x_e = sfft.ifft(sfft.fft(scan.x_tr[:, :, a_e:b_e], axis=-1, workers=-1) * hann, axis=-1, workers=-1)
    return sfft.fft(x_e[:, :, a - a_e : b - a_e], axis=-1, workers=-1)


def _half_width(det: detection.Detection, scan: _Scan) -> float:
    """Half width (Hz) of ``det``'s separation mask: separation_bandwidth, or narrower where another detection that
    its range cells cannot tell from it (within any mover's own range extent of it, the search bound's |v_los|, as
    _window_bounds and _neighbours) at the same apparent time (k = 0) sits nearer in dechirped Doppler than 2.5 x
    that, yet resolved from it: that offset / 2.5, so the neighbour is notched (_others' rule), not taken with it.
    Resolved: over MASK_WIDTHS of the pair's larger measured -3 dB width in Doppler (K_a width / output rate; a
    defocused response is wider), so the narrowed mask still passes MASK_WIDTHS / 2.5 of them either side. Mover
    campaign scene 020: M1 and M2 (v_r 17.32 / 17.52 m/s, v_a 6.96 / -3.29 m/s) one range cell and 3.9 ms apart,
    22.8 Hz at K_a 5852 Hz/s, widths 2 samples (1.6 Hz): under the fixed 25 Hz (2.5 x: 62.5 Hz) M1 was merged with
    M2 as its own response; at 9.1 Hz both are found. A neighbour farther in range than a mover's extent is resolved
    there: its own gate (_window_bounds) and the range taper (_neighbours) keep it out, and a narrowed mask only cuts
    the mover's own spectrum (scene 008's M4 and M5, 4 cells and 23 Hz apart on a sinc beam: narrowed to 9.2 Hz,
    their eq. 5 read v_r off by several stated sigma; docs/multichannel.md sections 17, 20)."""
    band, g, sp = scan.params.separation_bandwidth, scan.g, scan.spacing
    if scan.projector is not None:
        # On the clutter null's residual a mover's own response is split where the null cut its spectrum: V1 of
        # test_movers.py's movers_in_clutter, two peaks 3 cells, 5.4 ms (28.6 Hz) and 1.2 dB apart; narrowing for
        # them moved its v_r to -12.16 m/s (true -12.0). Two detections there are no evidence of two targets.
        return band
    rate = g.n * g.prf  # output samples per second
    params = scan.params
    reach = _range_extent(max(abs(params.velocity_min), abs(params.velocity_max)), scan)
    near = [d for d in scan.found.dets if d is not det and abs(d.cell - det.cell) <= reach]
    half, offsets = band, []
    for d in near:
        # a neighbour at the same apparent time (k = 0): one near an ambiguity k PRF / K_a of it may be its own
        # response there (campaign scene 007's gaussian-beam family) or alias onto it (scene 000's M6 40 Hz from M5)
        if abs(d.time - det.time) >= sp.ambiguity / 2 or d.power < MERGE_LEVEL * det.power:
            continue  # as _merge: weaker ones are this one's residue
        f_d = sp.ka0 * (d.time - det.time)
        own = sp.ka0 * max(d.width, det.width) / rate
        if MASK_WIDTHS * own < abs(f_d) < 2.5 * band:
            half = min(half, abs(f_d) / 2.5)
            offsets.append((f_d, own))
    # ... and that neighbour's ambiguities (k != 0), at its offset modulo PRF within 2 of its widths: scene 020's M1
    # at +1 x PRF / K_a lies 21.6 Hz from M2 (M1 itself 22.8 Hz); unnotched, M2's removal took it
    for d in near:
        f_d = (sp.ka0 * (d.time - det.time) + g.prf / 2) % g.prf - g.prf / 2
        if any(abs(f_d - f) <= 2 * own for f, own in offsets) and abs(d.time - det.time) >= sp.ambiguity / 2:
            half = min(half, abs(f_d) / 2.5)
    return half


def _window_at(det: detection.Detection, scan: _Scan, tally: _Tally | None = None) -> _DetWindow:
    """The range cells of ``det``'s window (_window_bounds) and its channels separated from the rest of them.

    With another target in its separation pass band and range reach (_neighbours), the final eq. 5 search (after
    the autofocus, _Window.final_leakage) weighs the window's channels range-tapered (_range_tapered); the first
    search, the static test, the autofocus, the null fit, the reconstruction and the removal keep the untapered ones.
    Eq. 5 weighs every response in the criterion's cells, and a neighbour's range side lobes there pull it: mover
    campaign scene 008 (sinc beam, no clutter or noise), M6 read v_r -0.19 m/s off (5.5 stated sigma) with M3's side
    lobes (7.8 dB brighter, 21 cells and 28 Hz away) at 0.3 % of its cells' energy, M5 +0.18 with M4's (4 cells and
    23 Hz away) at 1.8 %; alone, -0.04 and 0.00; tapered, -0.01 and +0.01. Cutting the Doppler pass band half way to
    the neighbour takes it out too, but eq. 5 on a sinc beam moves by up to 0.1 m/s with the cut's place on the
    mover alone; tapering the autofocus's data as well moved the v_a of movers sharing range cells by up to 1.1 m/s
    (docs/multichannel.md section 8)."""
    params, g, m = scan.params, scan.g, scan.params.window_margin
    a, b = max(0, det.cell - m), min(scan.n_cells, det.cell + m + 1)
    # The window keeps all its cells (its range processing and the separation see whole responses); the target
    # takes only its gate [lo, hi): its velocity criterion, centre, autofocus, reconstruction and removal.
    lo, hi = _window_bounds(det, scan)
    f_w = sfft.fftfreq(b - a, 1.0 / g.fs)
    ka_w = detection.fm_rate(g.velocity, g.squint, scan.found.r_mid, g.fc, f_w)
    x_w = sfft.fft(scan.x_tr[:, :, a:b], axis=-1, workers=-1)
    band = _half_width(det, scan)
    ext = detection.extract(x_w, g.times, g.prf, det.time, ka_w, band)
    criterion = None
    if g.bandwidth > 0 and _neighbours(det, scan, tally):
        log.debug(
            "reconstruct: detection at cell %d, %.4f s: a neighbour in its pass band, eq. 5 range-tapered",
            det.cell,
            det.time,
        )
        criterion = detection.extract(_range_tapered(scan, a, b), g.times, g.prf, det.time, ka_w, band)
    win = _Window(ext, f_w, g, params, criterion)
    if (lo, hi) != (a, b):
        win.gate = np.arange(lo - a, hi - a)
    if scan.projector is None:
        # the criterion's cells are the detection's own, not those of a brighter target beyond its range extent
        # (under the null the window's channels hold the clutter the null takes out: its cells are left as they were)
        reach = _range_extent(max(abs(params.velocity_min), abs(params.velocity_max)), scan)
        win.keep_own_cells(centre=det.cell - a, reach=reach)
    else:
        win.keep_own_cells()
    return _DetWindow(a, b, f_w, ka_w, x_w, ext, win, lo, hi)


def _log_null_survival(det: detection.Detection, ext: np.ndarray, scan: _Scan) -> None:
    """Log the energy of this detection's channels that survives the clutter null.

    Static points leave the null's floor, a mover its channel-phase mismatch (v_r) or band shift (v_los).
    """
    e_fa = sfft.fft(ext, axis=1, workers=-1)
    kept = float(np.sum(np.abs(clutter_null(e_fa, scan.g, projector=scan.projector)[0]) ** 2))
    total = float(np.sum(np.abs(e_fa) ** 2))
    null_db = 10 * math.log10(kept / total) if kept > 0 and total > 0 else -math.inf
    log.debug(
        "reconstruct: detection at cell %d, %.4f s: %.1f dB of its energy survives the clutter null",
        det.cell,
        det.time,
        null_db,
    )


def _others(det: detection.Detection, w: _DetWindow, scan: _Scan, reach: int = 2) -> list[float]:
    """Doppler offsets (Hz, modulo PRF) of the other detections in ``w``'s cells (or ``reach`` cells beyond them)
    that its mask can separate from ``det``: 2.5 separation_bandwidth or more from it (the parameter's "not
    separated", _ambiguity_of's reach).

    A notch stops +-separation_bandwidth about its detection and tapers to 1.5 x it (detection.extraction_mask), as
    ``det``'s own mask does: one nearer than 2.5 x stops part of ``det``'s own pass band, and the removal leaves that
    part of ``det``'s response in the image to be examined as a target of its own. Mover campaign scene 000's M5 + M6
    (docs/multichannel.md section 8): M5's removal notched M6's detections 40 and 43 Hz and a side lobe 38 Hz from M5
    (their full stop reaching to 13-18 Hz from M5, inside its +-25 Hz pass band) and left |4.2| of |9.3| of M5's own
    response 0.1135 s from its second ambiguity (M5 alone: its removal takes all of it), which the null fit read as
    a false mover (v_r -18.43 m/s, SNR 55.7 dB). Scene 007: a static detection's removal with such notches added a
    response one PRF / K_a from it, a second-pass detection examined for 12.7 s. The mask's half width is
    ``det``'s own (_half_width)."""
    g, ka0, band = scan.g, scan.spacing.ka0, _half_width(det, scan)
    others = []
    for d in scan.found.dets:
        f_d = ka0 * (d.time - det.time)
        f_d = (f_d + g.prf / 2) % g.prf - g.prf / 2
        if d is not det and w.a - reach <= d.cell < w.b + reach and abs(f_d) >= 2.5 * band:
            others.append(f_d)
    return others


def _spared(det: detection.Detection, w: _DetWindow, scan: _Scan, reach: int = 2) -> list[float]:
    """Doppler offsets (Hz, modulo PRF) of the conventional image's static peaks in ``w``'s cells (or ``reach``
    cells beyond them), off ``det``'s."""
    g, ka0, band = scan.g, scan.spacing.ka0, _half_width(det, scan)
    return [
        f_d
        for d in scan.found.static_peaks
        if w.a - reach <= d.cell < w.b + reach
        and abs(f_d := (ka0 * (d.time - det.time) + g.prf / 2) % g.prf - g.prf / 2) > 1.5 * band
    ]


def _remove_response(det: detection.Detection, others: list[float], w: _DetWindow, scan: _Scan) -> None:
    """Take one examined detection's whole response (ambiguities, clutter-null artefacts) out of the image.

    The response is cut from the channels as the earlier removals left them (scan.x_left), and taken out of them
    too, so the detection image stays the compressed image of scan.x_left: a window overlapping earlier ones takes
    only what they left (cut from the original channels every time, seven windows over one mover's cells each took
    a notch-edge piece of it again, a false companion 5.2 dB under it; a neighbour's side lobe its notch spared
    stayed a false alarm, mover campaign scene 000, docs/multichannel.md section 8).

    Only REMOVAL_BANDS x separation_bandwidth about the detection (modulo PRF: its ambiguities too) is taken, not
    everything in its cells but the other detections' notches: an undetected target in those cells (under
    detection_level of the strongest in the first pass) stays in the image for the second pass. Mover campaign
    scene 039: the static S1's removal took the movers M2 and M4 (569 and 120 Hz from it) 46 and 28 dB down, and
    neither was found. Not on the clutter null's residual: there the complement also takes the clutter residue in
    the detection's cells, and left in the image it made three second-pass false alarms in scene 012 (SNR 15-16 dB,
    v_r +1.1 to +1.3 m/s; docs/multichannel.md section 20)."""
    g = scan.g
    x_w = sfft.fft(scan.x_left[:, :, w.a : w.b], axis=-1, workers=-1)
    band = _half_width(det, scan)
    ext = detection.extract(x_w, g.times, g.prf, det.time, w.ka_w, band, notches=others)
    if scan.projector is None:
        ext = detection.extract(ext, g.times, g.prf, det.time, w.ka_w, REMOVAL_BANDS * band)
    scan.x_left[:, :, w.lo : w.hi] -= sfft.ifft(ext, axis=-1, workers=-1)[:, :, w.lo - w.a : w.hi - w.a]
    x_fa = sfft.fft(ext, axis=1, workers=-1)
    if scan.projector is not None:
        x_fa = clutter_null(x_fa, scan.g, projector=scan.projector)[0]
    scan.found.image[:, w.lo : w.hi] -= detection.compressed(
        channels.apply_filter_bank(x_fa, scan.bank), scan.found.out_f, w.ka_w
    )[:, w.lo - w.a : w.hi - w.a]


def _ambiguity_of(det: detection.Detection, scan: _Scan, tally: _Tally) -> str | None:
    """The mover found whose ambiguity ``det`` sits at (k != 0 times PRF / K_a in apparent time, within the ghost walk
    in range and within 2.5 x separation_bandwidth / K_a of the exact ambiguity: what the masks cannot separate),
    the nearest one, said in words; None if none."""
    sp = scan.spacing
    reach = 2.5 * scan.params.separation_bandwidth / sp.ka0
    best: tuple[float, str] | None = None
    for i, p in enumerate(tally.peaks):
        k = round((det.time - p.time) / sp.ambiguity)
        off = det.time - p.time - k * sp.ambiguity
        if k != 0 and abs(det.cell - p.cell) <= sp.ghost_cells and abs(off) <= reach:
            where = (
                f"{k:+d} x PRF / K_a {1e3 * off:+.1f} ms from mover {i} (range cell {p.cell}, SNR {p.snr_db:.1f} dB)"
            )
            if best is None or abs(off) < best[0]:
                best = (abs(off), where)
    return None if best is None else best[1]


def _reject(
    det: detection.Detection,
    notes: list[str],
    tally: _Tally,
    examined: bool = True,
    ambiguity_of: str | None = None,
) -> None:
    """Record a detection that is no mover: static, or no point target (no velocity dip, or a clutter-null residual
    that no velocity explains). ``examined``: False for one made static by an examined neighbour (_visit);
    ``ambiguity_of``: the mover whose ambiguity an incoherent detection sits at (_ambiguity_of)."""
    kind = "incoherent" if notes == ["incoherent"] else "static"
    tally.counts[kind] += 1
    if kind == "static" and examined:
        tally.statics.append((det, float(notes[0].split()[1])))
    if kind == "incoherent":
        tally.flat.append(det)
        if ambiguity_of is not None:
            tally.ambiguity_residues.append(ambiguity_of)
    tally.rejected.append(
        {
            "cell": det.cell,
            "index": det.index,
            "snr_db": det.snr_db,
            "kind": kind,
            "v_los": float(notes[0].split()[1]) if kind == "static" else None,
        }
    )
    log.info(
        "reconstruct: detection at range cell %d, %.3f s (SNR %.1f dB) is %s",
        det.cell,
        det.time,
        det.snr_db,
        ("no point target" + (f", at {ambiguity_of}: its ambiguity's residue" if ambiguity_of else ""))
        if kind == "incoherent"
        else "static"
        if examined
        else "static, as the one examined in its range cell and separation mask",
    )


def _refocus(
    det: detection.Detection,
    mt: MovingTarget,
    w: _DetWindow,
    whole: np.ndarray,
    scan: _Scan,
    tally: _Tally,
    null_fit: _NullFit | None = None,
) -> None:
    """Replace the mover's conventional reconstruction by its modified one in ``y_tr``; locate and record it; keep
    what that changed where _drop_under_threshold may take it back (``null_fit``: the window's, or None)."""
    g, sp = scan.g, scan.spacing
    win_whole = _Window(whole, w.f_w, g, scan.params)
    y_mod = win_whole.output(
        mt.radial_velocity, mt.along_track_velocity, mt.beam_centre_time, mt.slant_range, focus_along_track=True
    )
    y_conv = sfft.ifft(_reconstruct(whole, w.win.bank(0.0)), axis=0, workers=-1)
    change = sfft.ifft(y_mod - y_conv, axis=1, workers=-1)[:, w.lo - w.a : w.hi - w.a]
    scan.y_tr[:, w.lo : w.hi] += change
    ka = w.ka_w
    if (w.lo, w.hi) != (w.a, w.b):
        ka = detection.fm_rate(g.velocity, g.squint, scan.found.r_mid, g.fc, sfft.fftfreq(w.hi - w.lo, 1.0 / g.fs))
    index, cell = _refine_peak(
        sfft.fft(scan.y_tr[:, w.lo : w.hi], axis=1, workers=-1),
        ka,
        scan.found.out_f,
        det.index if mt.null_fit_index is None else int(round(mt.null_fit_index)),
        sp.ambiguity * g.n * g.prf,
        scan.n_out,
        mt.null_fit_index is not None,
        None if mt.null_fit_cell is None else min(max(mt.null_fit_cell + w.a - w.lo, 0), w.hi - w.lo - 1),
        # the null fit's index is where it modelled the mover; a detection's is where its defocused response peaked
        PEAK_HALF_WIDTH if mt.null_fit_index is not None else _peak_half_width(mt, g, sp),
    )
    t_app = g.out_times[0] + index / (g.n * g.prf)
    wc_range = C / 2 * (scan.rt0 + (w.lo + cell - scan.lead) / g.fs)
    tally.movers.append(
        dataclasses.replace(
            mt,
            first_cell=w.lo,
            last_cell=w.hi,
            snr_db=det.snr_db,
            apparent_time=t_app,
            apparent_range=wc_range - g.velocity * math.sin(g.squint) * t_app,
        )
    )
    tally.peaks.append(det)
    if null_fit is None and (
        mt.noise_dip <= 0 or (len(mt.search) and not mt.at_bound and _static_within(tally.movers[-1], scan) is not None)
    ):
        # No clutter null: the detection image holds the static scene at full strength, so a detection's strength
        # says nothing of motion and eq. 5's velocity is the only evidence of it; a candidate for
        # _drop_under_threshold whatever the CFAR threshold where
        # - eq. 5 falls from rest to the estimate no further than the window's noise alone does (_noise_dip): its
        #   minimum is the noise's dip (mover campaign scene 017's static S2 band-limited, 16.2 dB, read at v_r
        #   7.90 m/s, 2.4 sigma over detection_velocity; docs/multichannel.md section 11). The sign, not the noise
        #   draw's bound: a weak true mover stands inside that bound too (scene 016's M1, 0.40 of its sigma, under
        #   two noise-pulled statics of scene 015 at 0.55 and 0.68; section 13); one kept inside it is warned of
        #   (_warn_within_noise), or
        # - rest within STATIC_SIGMAS of the tabled v_los is not ruled out (scene 015's static S2 band-limited,
        #   16.8 dB: eq. 5's minimum pulled to v_r 4.97 m/s by the noise's own dip, 1-sigma 2.40; section 10). Not on
        #   the search bound: there eq. 5 falls towards the bound, away from rest, and the 1-sigma is the bound's
        #   (tests/focus/test_movers.py: v_r 24 m/s tabled at 20, 73.7 dB, 1.96 sigma)
        tally.undo[len(tally.movers) - 1] = change
    elif null_fit is not None and (mt.from_rest or _static_within(tally.movers[-1], scan) is not None):
        # mt.from_rest: eq. 5 read the window at rest and the null fit took it off rest only because rest there left
        # more than NULL_FIT_MISMATCH of the residual unexplained; eq. 5 is then no evidence of motion, whatever the
        # 1-sigma of the velocity the fit and autofocus then reached, and the fit at that velocity must rule rest out
        # (mover campaign scene 007's clutter band-limited, 33.1 dB: eq. 5 at v_r -0.29 m/s leaving 0.34, tabled at
        # -8.42 m/s, 5.9 sigma, which leaves 0.2645 where rest leaves 0.2533; docs/multichannel.md section 11)
        at_estimate = null_fit.mismatch(mt.radial_velocity, mt.along_track_velocity)
        at_rest = null_fit.mismatch(0.0, 0.0)
        log.debug(
            "reconstruct: mover at range cell %d, %.3f s (SNR %.1f dB) within %g sigma of detection_velocity: the "
            "null fit's mismatch %.4f at its estimate, %.4f at rest",
            det.cell,
            det.time,
            det.snr_db,
            STATIC_SIGMAS,
            at_estimate,
            at_rest,
        )
        if not _rest_ruled_out(at_estimate, at_rest):
            # a candidate for _drop_under_threshold: keep what its refocus changed, to undo it
            tally.undo[len(tally.movers) - 1] = change
            tally.at_rest[len(tally.movers) - 1] = (at_estimate, at_rest)


def _rest_ruled_out(at_estimate: float, at_rest: float) -> bool:
    """Whether the null fit rules out rest (v_r = v_a = 0) for a mover, from its mismatches at its estimate and at
    rest: rest must leave more of the residual unexplained than the estimate and more than NULL_FIT_MISMATCH, the
    fraction over which the fit calls a velocity wrong (xu_traffic V9: 1.0000 at rest, 0.2151 at its estimate).
    Under it both explain the residual and the fit cannot tell them: with a sinc or gaussian beam a slow target's
    residual is its skirt's leakage, which the fit predicts at any slow velocity (mover campaign scene 014: its
    clutter read at v_r -1.34 m/s 0.177 at rest, 0.144 at it; its true M2 0.076 and 0.078)."""
    return at_rest > max(at_estimate, NULL_FIT_MISMATCH)


def _static_within(mt: MovingTarget, scan: _Scan) -> float | None:
    """How many 1-sigma ``mt``'s line-of-sight speed stands over detection_velocity, when under STATIC_SIGMAS (the
    1-sigma of the tabled v_los = v_r cos + v_a sin: _uncertainties' sigma_vr x cos); None when it is above them.

    Where a neighbour range-tapered the final eq. 5 search, the 1-sigma is taken with the larger of the looks' spreads,
    tapered (the one tabled) and untapered: rest is ruled out only if both rule it out. A clutter response is many
    scatterers whose mixing the taper partly hides: mover campaign scene 014's clutter (static, SNR 30.6 dB under
    the CFAR threshold) read v_r -1.69 m/s with tapered looks agreeing to 0.14 (3.9 sigma over detection_velocity)
    and untapered to 0.38 (1.7 sigma: taken back); docs/multichannel.md section 8."""
    g, params = scan.g, scan.params
    wider = dataclasses.replace(mt, leakage_spread=max(mt.leakage_spread, mt.untapered_spread))
    s_r = _uncertainties(wider, g, params.clutter_band if params.clutter_suppression else None)[0]
    v_los = mt.line_of_sight_velocity(g.squint)
    z = (abs(v_los) - params.detection_velocity) / (s_r * math.cos(g.squint))
    return z if z < STATIC_SIGMAS else None


def _drop_under_threshold(scan: _Scan, tally: _Tally) -> dict[int, int]:
    """Take back the movers whose detection is under the CFAR threshold the measured background sets, whose
    line-of-sight speed is not STATIC_SIGMAS over detection_velocity and for which the null fit does not rule out rest
    (_rest_ruled_out; _refocus keeps those candidates): nothing tells them from the background. Returns the movers
    kept, old index to new.

    The first pass examines everything over detection_snr; only the second pass knows the threshold a false-alarm
    rate sets (_second_pass). A detection under it is as strong as the background's own peaks (mover campaign scene
    012: 15.99 dB against 17.1, 4 of the measured background's 466 540 peaks stronger; v_los 1.21 m/s, 0.8 sigma over
    1 m/s; null-fit mismatch 0.0818 at rest, 0.0950 at its estimate: a clutter-plus-noise peak). Neither the threshold
    nor the velocity alone decides: xu_traffic's true V9 is at 19.85 dB under 42.7 and 0.66 sigma over 1 m/s, and the
    null fit prefers its estimate (docs/multichannel.md section 8). Without the clutter null (no null fit) every mover
    eq. 5 estimated within STATIC_SIGMAS of detection_velocity is taken back whatever its SNR: the detection image
    holds the static scene at full strength, so the threshold says nothing of motion (mover campaign scenes 013, 015,
    016: static points at 16.8-28.6 dB read at v_los 1.6-5.0 m/s, 0.9-1.7 sigma over 1 m/s; docs/multichannel.md
    section 10), and so is one whose eq. 5 falls from rest to its estimate no further than the window's noise alone
    does (MovingTarget.noise_dip, _noise_dip: scene 017's static at 2.4 sigma; section 11). With the clutter null, a
    mover eq. 5 read at rest and the null fit took off it (MovingTarget.from_rest) is a candidate whatever its sigma
    (scene 007's clutter response at 5.9 sigma; section 11). Its refocus is undone, it is recorded as a detection
    taken for static ("weak"), and the detections merged with it with it."""
    drop = [
        k
        for k in sorted(tally.undo)
        if k not in tally.at_rest  # eq. 5's, without the clutter null (_refocus): the threshold does not apply
        or (tally.peaks[k].snr_db < scan.found.cfar_db and scan.found.cfar_db > scan.params.detection_snr)
    ]
    index = {k: i for i, k in enumerate(k for k in range(len(tally.movers)) if k not in drop)}
    if not drop:
        return index
    for k in drop:
        mt, det = tally.movers[k], tally.peaks[k]
        scan.y_tr[:, mt.first_cell : mt.last_cell] -= tally.undo[k]
        v_los = mt.line_of_sight_velocity(scan.g.squint)
        z = _static_within(mt, scan)
        if k in tally.at_rest and z is None:  # mt.from_rest (_refocus)
            log.info(
                "reconstruct: detection at range cell %d, %.3f s (SNR %.1f dB) is under the CFAR threshold %.1f dB, "
                "eq. 5 reads it at rest and the null fit does not rule rest out (its mismatch %.4f at its v_los %.3f "
                "m/s and %.4f at rest): taken for static",
                det.cell,
                det.time,
                det.snr_db,
                scan.found.cfar_db,
                tally.at_rest[k][0],
                v_los,
                tally.at_rest[k][1],
            )
        elif k in tally.at_rest:
            log.info(
                "reconstruct: detection at range cell %d, %.3f s (SNR %.1f dB) is under the CFAR threshold %.1f dB "
                "and its v_los %.3f m/s only %.2f sigma over detection_velocity %g m/s, the null fit's mismatch %.4f "
                "at its estimate and %.4f at rest: taken for static",
                det.cell,
                det.time,
                det.snr_db,
                scan.found.cfar_db,
                v_los,
                z,
                scan.params.detection_velocity,
                *tally.at_rest[k],
            )
        elif mt.noise_dip <= 0:
            log.info(
                "reconstruct: detection at range cell %d, %.3f s (SNR %.1f dB): eq. 5 falls from rest to its v_los "
                "%.3f m/s no further than the window's noise alone does there (by %.4f more) and no clutter null "
                "tells a mover from the static scene: taken for static",
                det.cell,
                det.time,
                det.snr_db,
                v_los,
                mt.noise_dip,
            )
        else:
            log.info(
                "reconstruct: detection at range cell %d, %.3f s (SNR %.1f dB): its v_los %.3f m/s is only %.2f sigma "
                "over detection_velocity %g m/s and no clutter null tells a mover from the static scene: taken for "
                "static",
                det.cell,
                det.time,
                det.snr_db,
                v_los,
                z,
                scan.params.detection_velocity,
            )
        tally.rejected.append(
            {
                "cell": det.cell,
                "index": det.index,
                "snr_db": det.snr_db,
                "kind": "weak",
                "v_los": v_los,
                "sigmas": z,
                "under_cfar": k in tally.at_rest,
                "noise_dip": mt.noise_dip,
            }
        )
    for d in tally.rejected:
        if d["kind"] == "merged":
            if d["mover"] in index:
                d["mover"] = index[d["mover"]]
            else:
                m = tally.movers[d["mover"]]
                v = m.line_of_sight_velocity(scan.g.squint)
                d.update(
                    kind="weak",
                    v_los=v,
                    sigmas=_static_within(m, scan),
                    under_cfar=d["mover"] in tally.at_rest,
                    noise_dip=m.noise_dip,
                )
                del d["mover"]
    dropped = [tally.peaks[k] for k in drop]
    tally.removed = [dataclasses.replace(r, kind="static") if r.det in dropped else r for r in tally.removed]
    tally.movers = [m for k, m in enumerate(tally.movers) if k not in drop]
    tally.peaks = [p for k, p in enumerate(tally.peaks) if k not in drop]
    tally.counts["weak"] = len(drop)
    return index


def _warn_within_noise(tally: _Tally) -> None:
    """Warn of each mover kept (numbered as _drop_under_threshold kept them) whose only evidence of motion, eq. 5's
    fall from rest without the clutter null, is beyond the window's noise's own (MovingTarget.noise_dip > 0) but within
    what the noise's draw gives a static point at POINT_TARGET_ALPHA (noise_dip_bound): its motion is not
    significant. Not taken back: a weak true mover stands there too (mover campaign scene 016's M1, 19.5 dB,
    0.40 of the draw's sigma) with noise-pulled statics (scene 015's S2 over noise seeds, 0.55 and 0.68 of it);
    docs/multichannel.md section 13."""
    for i, (mt, det) in enumerate(zip(tally.movers, tally.peaks, strict=True)):
        if 0 < mt.noise_dip <= mt.noise_dip_bound:
            log.warning(
                "reconstruct: mover %d (range cell %d, %.3f s, SNR %.1f dB): without a clutter null its motion rests "
                "on eq. 5 falling from rest %.4f further than the window's noise alone does, within the %.4f the "
                "noise's draw gives a static point at %g: it may be a static point pulled off rest by the noise",
                i,
                det.cell,
                det.time,
                det.snr_db,
                mt.noise_dip,
                mt.noise_dip_bound,
                POINT_TARGET_ALPHA,
            )


def _warn_merged(tally: _Tally, kept: dict[int, int]) -> None:
    """Warn of the responses merged with a mover that could not be separated from it (_merge), numbered as the movers
    _drop_under_threshold kept; of one merged with a detection it took back only at info level: it names no mover
    (mover campaign scene 014: three merged with its clutter read at -1.34 m/s, once warned of as another mover's)."""
    for m in tally.merged:
        if m.mover in kept:
            log.warning(
                "reconstruct: %s, could not be separated from it: %s", m.said(f"mover {kept[m.mover]}"), m.cause
            )
        else:
            log.info(
                "reconstruct: %s: merged with it, taken for static with it", m.said("a detection taken for static")
            )


def _warn_unseparated(scan: _Scan, tally: _Tally) -> None:
    """Warn of movers found whose detections the windows could not separate."""
    peaks = tally.peaks
    for i in range(len(peaks)):
        for j in range(i + 1, len(peaks)):
            if _shares_window(peaks[i], j, scan, tally) or _shares_window(peaks[j], i, scan, tally):
                log.warning(
                    "reconstruct: movers %d and %d in range cells %d-%d (%d cells and %.1f ms apart in "
                    "apparent time) could not be separated; their velocity estimates mix both",
                    i,
                    j,
                    min(peaks[i].cell, peaks[j].cell),
                    max(peaks[i].cell, peaks[j].cell),
                    abs(peaks[i].cell - peaks[j].cell),
                    1e3 * abs(peaks[i].time - peaks[j].time),
                )


def _warn_unexamined(tally: _Tally, params: ReconstructParams, cfar_db: float) -> None:
    """Warn of detections with no velocity dip and of those max_detections left unexamined. ``cfar_db``: the final
    CFAR threshold; a detection found before the measured background raised it can lie under it (session 42
    new-user trial, row 7b: "above the CFAR threshold (SNR 50.4 dB)" where ``-v`` gave the threshold as 60.9 dB)."""
    if tally.flat:
        snr = [d.snr_db for d in tally.flat]
        places = "; ".join(f"range cell {d.cell} at {d.time:.3f} s, SNR {d.snr_db:.1f} dB" for d in tally.flat[:3])
        if len(tally.flat) > 3:
            places += f"; {len(tally.flat) - 3} more"
        under = sum(x < cfar_db for x in snr)
        if under == 0:
            level = f"over the final CFAR threshold {cfar_db:.1f} dB"
        else:
            which = "all" if under == len(snr) else f"{under} of them"
            level = (
                f"{which} under the final CFAR threshold {cfar_db:.1f} dB, which the measured background set after "
                "they were detected"
            )
        log.warning(
            "reconstruct: %d detection(s) (%s; %s) have no slant-range velocity that explains them (too weak for "
            "the velocity search under about %.0f dB; no point target: side lobes, clutter residue; or a point "
            "target whose velocity criterion has no dip); they are not in moving_targets",
            len(snr),
            places,
            level,
            WEAK_SEARCH_DB,
        )
    for where in tally.ambiguity_residues:
        log.warning(
            "reconstruct: a detection with no velocity that explains it sits at %s, outside its separation mask: "
            "that mover's ambiguity residue, not a target",
            where,
        )
    if tally.dropped:
        log.warning(
            "reconstruct: %d further detections above the CFAR threshold were not examined "
            "(reconstruct.max_detections = %d): movers among them are missed",
            tally.dropped,
            params.max_detections,
        )


def _truth_cell_index(raw: Product, g: _Geometry, lead: int, k: int, centres: np.ndarray) -> tuple[float, float]:
    """(walk-corrected range cell, output azimuth sample) where truth target k appears in the detection image.

    The inverse of the detection's apparent position (_moving_target_rows): its static equivalent S is at
    beam centre at t_app, at slant range R_app, and sits in walk-corrected range R_app + v sin(theta) t_app.
    """
    t = raw.targets
    xyz = np.array([t["x"][k], t["y"][k], t["z"][k]], float)
    vel = np.array([t["vx"][k], t["vy"][k], t["vz"][k]], float)
    s, _ = moving.apparent_position(raw.radar, g.times, xyz, vel, centres)
    t_app = _beam_centre_time(raw, g, s, centres)
    p = np.array([np.interp(t_app, g.times, centres[:, c]) for c in range(3)])
    wc_range = float(np.linalg.norm(s - p)) + g.velocity * math.sin(g.squint) * t_app
    rt0 = float(raw.coords["range_time"][0])
    return (2 * wc_range / C - rt0) * g.fs + lead, (t_app - g.out_times[0]) * g.n * g.prf


def _beam_centre_time(raw: Product, g: _Geometry, s: np.ndarray, centres: np.ndarray) -> float:
    """Beam-centre time of the static point ``s``: the middle of its illumination on the track extended (linearly) by
    the data's length either side, so that an illumination the data window cuts is not centred on the cut. A fast
    mover's S lies up to v_los R / (v cos(theta))^2 from it in apparent time, near or past the data's end (mover
    campaign scene 010's M2, v_los -20.04 m/s: S's illumination cut at +0.600 s put it at 0.2577 s, 26 ms before
    the 0.2836 s where the mover appears at SNR 51.5 dB; its miss reason then read "undetectable at any speed" from
    the background there)."""
    t = g.times
    span = float(t[-1] - t[0])
    rate = (centres[-1] - centres[0]) / span
    step = span / max(len(t) - 1, 1)
    before = t[0] - step * np.arange(len(t), 0, -1)
    after = t[-1] + step * np.arange(1, len(t) + 1)
    t_ext = np.concatenate([before, t, after])
    c_ext = np.concatenate(
        [centres[0] + np.outer(before - t[0], rate), centres, centres[-1] + np.outer(after - t[-1], rate)]
    )
    return moving.illumination_centre_time(raw.radar, t_ext, s, np.zeros(3), c_ext)


@dataclasses.dataclass
class _TruthProbe:
    """A moving truth target where it appears in the detection image(s) (_probe_truth), for its miss reason."""

    cell: float  # walk-corrected range cell where it appears (_truth_cell_index)
    index: float  # output azimuth sample where it appears
    snr_db: float  # strongest of its ambiguities over the background in the searched image
    peak_index: int  # that peak's azimuth sample
    peak_cell: int  # and range cell
    v_los: float  # its true line-of-sight velocity (m/s)
    null: _NullProbe | None = None  # the clutter null's effect on it (None: the searched image is conventional)
    residual_snr_db: float | None = None  # over the measured background (_second_pass; None: no second pass)
    background_peaks_above: int = 0  # the measured background's peaks stronger than that (_second_pass)


@dataclasses.dataclass(frozen=True)
class _NullProbe:
    """What the clutter null did to a truth mover (_probe_truth's, when the searched image is the null's residual)."""

    conventional_snr_db: float  # its SNR in the conventional detection image
    null_depth_db: float  # background where its residual peaks over that where it appears
    null_gain_db: float  # detection.clutter_null_peak_gain of its true v_los
    # the null's minimum detectable velocity (m/s) for its conventional SNR against a CFAR threshold (dB): the one in
    # force is known only after the second pass, which can raise it far above detection_snr (xu_traffic: 42.7 dB)
    mdv_at: Callable[[float], float]


def _probe_truth(
    raw: Product,
    params: ReconstructParams,
    g: _Geometry,
    lead: int,
    power: np.ndarray,
    bg: np.ndarray,
    conv: np.ndarray | None,
    bg_conv: np.ndarray | None,
) -> dict[int, _TruthProbe]:
    """Per moving truth target (its row): its SNR in the detection image(s) where it appears, and the clutter null's
    MDV.

    ``power``, ``bg``: the detection image searched and its background; ``conv``, ``bg_conv`` the conventional
    detection image and its background when ``power`` is the clutter-null residual (None: it is conventional); the
    :class:`_TruthProbe` then has the :class:`_NullProbe`. Its snr_db is the strongest of the target's ambiguities
    k PRF / K_a apart in the searched image (:func:`_snr_near`).
    """
    truth = raw.targets
    if not len(truth):
        return {}
    moving_rows = np.nonzero(moving.is_moving(truth))[0]
    if not len(moving_rows):
        return {}
    centres = moving.phase_centres(raw)
    r_mid = _swath_centre_range(raw)
    spacing = g.prf / float(detection.fm_rate(g.velocity, g.squint, r_mid, g.fc, 0.0)) * g.n * g.prf
    out = {}
    for k in moving_rows:
        cell, index = _truth_cell_index(raw, g, lead, int(k), centres)
        snr_db, i_res, c_res = _snr_near(power, bg, index, cell, range(-g.n + 1, g.n), spacing)
        xyz = np.array([truth["x"][k], truth["y"][k], truth["z"][k]], float)
        vel = np.array([truth["vx"][k], truth["vy"][k], truth["vz"][k]], float)
        v_a, v_r = moving.slant_velocity(xyz, vel, raw.radar.altitude)
        probe = _TruthProbe(cell, index, snr_db, i_res, c_res, channels.line_of_sight_velocity(v_r, v_a, g.squint))
        if conv is not None and bg_conv is not None:
            probe.null = _null_probe(probe, params, g, bg, conv, bg_conv, spacing)
        out[int(k)] = probe
    return out


def _snr_near(
    pw: np.ndarray, bgr: np.ndarray, index: float, cell: float, shifts: Iterable[int], spacing: float
) -> tuple[float, int, int]:
    """(SNR dB, azimuth sample, range cell) of the strongest peak of ``pw`` over its background ``bgr`` within
    +-PROBE_SAMPLES samples and +-3 cells of each position ``index + k spacing`` (k in ``shifts``), ``cell``.

    The prediction lands within about 10 samples (7 m) of the focused peak: its illumination centre and the
    compressed image's time origin differ slightly; the window allows for that.
    """
    n_out, n_cells = pw.shape
    best, where = 0.0, (round(index) % n_out, min(max(round(cell), 0), n_cells - 1))
    c0, c1 = max(0, round(cell) - 3), min(n_cells, round(cell) + 4)
    for k in shifts:
        i = round(index + k * spacing)
        if not 0 <= i < n_out or c0 >= c1:
            continue
        rows = np.arange(i - PROBE_SAMPLES, i + PROBE_SAMPLES + 1) % n_out
        sub = pw[rows, c0:c1] / np.maximum(bgr[rows, c0:c1], 1e-30)
        j, c = np.unravel_index(int(np.argmax(sub)), sub.shape)
        if float(sub[j, c]) > best:
            best, where = float(sub[j, c]), (int(rows[j]), c0 + int(c))
    return (10 * math.log10(best) if best > 0 else -math.inf), where[0], where[1]


def _null_probe(
    probe: _TruthProbe,
    params: ReconstructParams,
    g: _Geometry,
    bg: np.ndarray,
    conv: np.ndarray,
    bg_conv: np.ndarray,
    spacing: float,
) -> _NullProbe:
    """The clutter null's effect on a truth mover found by ``probe`` in its residual (background ``bg``): its SNR
    in the conventional detection image ``conv`` (background ``bg_conv``), the null's depth and peak gain there,
    and the minimum detectable velocity for that SNR against a CFAR threshold (``mdv_at``)."""
    lam = C / g.fc
    conventional_snr_db, i, c = _snr_near(conv, bg_conv, probe.index, probe.cell, [0], spacing)
    gains = detection.clutter_null_peak_gains(g.tau0, g.prf, g.half_band, params.clutter_band, lam, probe.v_los)
    gain = float(gains.max())
    depth = _ambiguity_depths(bg, float(bg_conv[i, c]), probe.index, c, g.n, spacing)
    margins = np.array(depth) - conventional_snr_db
    margins = np.minimum(margins, margins[::-1])  # either sign of k

    def mdv_at(threshold_db: float) -> float:
        return detection.minimum_detectable_velocity(
            g.tau0, g.prf, g.half_band, params.clutter_band, lam, threshold_db + margins
        )

    return _NullProbe(
        conventional_snr_db=conventional_snr_db,
        # the background where its residual peaks (one of its ambiguities) over that where it appears
        null_depth_db=10 * math.log10(float(bg[probe.peak_index, probe.peak_cell]) / float(bg_conv[i, c])),
        null_gain_db=10 * math.log10(gain) if gain > 0 else -math.inf,
        mdv_at=mdv_at,
    )


def _ambiguity_depths(bg: np.ndarray, level: float, index: float, cell: int, n: int, spacing: float) -> list[float]:
    """Per response k = -(n - 1) .. n - 1 of a mover at azimuth sample ``index``, range cell ``cell``: the residual's
    background ``bg`` there over the conventional one ``level`` where it appears, dB (inf beyond the image).

    Response k lies k PRF / K_a away (which way depends on the sign convention: the responses are nearly
    symmetric in k, so each |k| takes the lower background of the two places)."""
    depth = []
    for shift in range(-n + 1, n):
        levels = []
        for sign in (1, -1):
            j = round(index + sign * shift * spacing)
            if 0 <= j < bg.shape[0]:
                levels.append(float(bg[j, cell]))
        depth.append(10 * math.log10(min(levels) / level) if levels else math.inf)
    return depth


def _miss_reason(
    name: str, probe: _TruthProbe | None, rejected: list[dict], spacing: float, params: ReconstructParams, cfar: dict
) -> str:
    """Why truth mover ``name`` is not in moving_targets, from what the detection image held where it appears."""
    if probe is None:
        return f"{name}: not found"

    def off(index: float) -> float:  # samples from the mover's strongest peak, modulo its ambiguity spacing
        k = (index - probe.peak_index) / spacing
        return abs(k - round(k)) * spacing

    near = [d for d in rejected if abs(d["cell"] - probe.peak_cell) <= 4 and off(d["index"]) <= 8]
    if near:
        d = max(near, key=lambda d: d["snr_db"])
        if d["kind"] == "merged":
            return (
                f"{name}: detected (SNR {d['snr_db']:.1f} dB) but merged with mover {d['mover']} as its own response "
                "(same range cells, at its apparent time or one of its ambiguities k PRF / K_a)"
            )
        if d["kind"] == "explained":
            by: _Removed | None = d["by"]
            # the threshold it fell under is the one in force when it was examined: the first pass's detection_snr,
            # under the measured one a detection can be (mover campaign scene 017's M3: 15.2 dB, 15 then 17.9 dB)
            then, final = d["threshold_db"], cfar["threshold_db"]
            under = (
                f" (its SNR is under the measured CFAR threshold {final:.1f} dB as well)"
                if d["snr_db"] < final and then < final
                else ""
            )
            if by is None:
                return (
                    f"{name}: detected (SNR {d['snr_db']:.1f} dB) but taken out with the responses of the targets "
                    f"already examined (it fell under the CFAR threshold {then:.1f} dB once they were removed){under}"
                )
            what = {"mover": "a mover", "static": "a static target", "incoherent": "a detection no velocity explains"}
            return (
                f"{name}: detected (SNR {d['snr_db']:.1f} dB) but taken out with the response of "
                f"{what[by.kind]} examined at {by.det.time:.4f} s, range cell {by.det.cell} (SNR "
                f"{by.det.snr_db:.1f} dB, {by.det.snr_db - d['snr_db']:.1f} dB brighter, {d['cell'] - by.det.cell:+d} "
                f"cells from it), removed over range cells {by.lo}-{by.hi - 1}: it fell under the CFAR threshold "
                f"{then:.1f} dB then in force once that response was removed{under}"
            )
        if d["kind"] == "weak":
            under = (
                f"under the CFAR threshold {cfar['threshold_db']:.1f} dB that a false-alarm rate "
                f"{params.false_alarm_rate:g} per peak sets, and "
                if d.get("under_cfar", True)
                else "without a clutter null, "
            )
            if d["sigmas"] is None and d.get("under_cfar", True):  # MovingTarget.from_rest (_refocus)
                return (
                    f"{name}: detected (SNR {d['snr_db']:.1f} dB) {under}taken for static: eq. 5 reads it at rest "
                    f"and the null fit does not rule rest out at its estimated line-of-sight velocity "
                    f"{d['v_los']:.3f} m/s (its true one {probe.v_los:.3f} m/s)"
                )
            if d.get("noise_dip", math.nan) <= 0:
                return (
                    f"{name}: detected (SNR {d['snr_db']:.1f} dB) {under}taken for static: eq. 5 falls from rest to "
                    f"its estimated line-of-sight velocity {d['v_los']:.3f} m/s no further than the window's noise "
                    f"alone does there (by {d['noise_dip']:.4f} more; its true one {probe.v_los:.3f} m/s)"
                )
            return (
                f"{name}: detected (SNR {d['snr_db']:.1f} dB) {under}taken for static: its "
                f"estimated line-of-sight velocity {d['v_los']:.3f} m/s is only {d['sigmas']:.1f} sigma over "
                f"detection_velocity {params.detection_velocity:g} m/s (its true one {probe.v_los:.3f} m/s)"
            )
        if d["kind"] == "static":
            err, thr = d["v_los"] - probe.v_los, params.detection_velocity
            # within the margin the mover campaign allows the search at the threshold (20 % of it), the estimate is
            # right and the mover is slow, not hidden by the clutter (campaign scene 009 M2: -0.97 for -1.01 m/s)
            why = (
                f"its true line-of-sight velocity {probe.v_los:.3f} m/s is itself under it"
                if abs(probe.v_los) < thr
                else f"its true line-of-sight velocity is {probe.v_los:.3f} m/s, {abs(err):.3f} m/s from the estimate: "
                "the estimate is right and the mover sits at the static threshold"
                if abs(err) <= 0.2 * thr
                else f"the true one is {probe.v_los:.3f} m/s: the search runs on its window's channels before the "
                "null, where the static clutter in those cells outweighs it"
                if params.clutter_suppression
                # no null, no clutter said to be there: mover campaign scenes 029's M4 (v_los -1.43 read -0.69 m/s at
                # 22.4 dB in noise, the same with its same-cell neighbour M3 taken out) and 036's M4 were told "the
                # static clutter outweighs it" in scenes without clutter (docs/multichannel.md section 17)
                else f"the true one is {probe.v_los:.3f} m/s, {abs(err):.3f} m/s from the estimate: without a clutter "
                "null the search reads its window's channels as they are, so the noise there or another target in "
                "its cells pulled it"
            )
            return (
                f"{name}: detected (SNR {d['snr_db']:.1f} dB) but taken for static: its velocity search estimated a "
                f"line-of-sight velocity of {d['v_los']:.3f} m/s, under detection_velocity {thr:g} m/s; {why}"
            )
        return f"{name}: detected (SNR {d['snr_db']:.1f} dB) but no slant-range velocity explains its response " + (
            "(too weak for the velocity search)"
            if d["snr_db"] < WEAK_SEARCH_DB
            else "(not for weakness at this SNR: the velocity search's criterion has no dip, or its estimate "
            "leaves the clutter-null residual unexplained)"
        )
    level = probe.snr_db if probe.residual_snr_db is None else probe.residual_snr_db
    if probe.residual_snr_db is not None:
        # the second pass's CFAR against the measured background (_second_pass)
        under = (
            f"; with the examined responses taken out it stands {level:.1f} dB over the measured background, "
            f"{probe.background_peaks_above} of whose {cfar.get('background_peaks', 0)} peaks are stronger: under "
            f"the CFAR threshold {cfar['threshold_db']:.1f} dB that a false-alarm rate {params.false_alarm_rate:g} "
            "per peak sets there"
        )
    else:
        under = f", under the CFAR threshold {cfar['threshold_db']:.1f} dB"
    null = probe.null
    if null is not None and level < cfar["threshold_db"]:
        # against the threshold in force, not the first pass's floor (xu_traffic V1, v_los 0.35 m/s: 0.30 m/s against
        # 15 dB, "within 20 %" of it; against the 42.7 dB the measured background sets it is far below)
        v, mdv = abs(probe.v_los), null.mdv_at(cfar["threshold_db"])
        # the gain model is good to about 1.5 dB (docs/multichannel.md), 20 % in v_los (gain ~ v_los^2)
        where = (
            # no speed's peak gain lifts that SNR over the threshold (campaign scene 010's M2: 5.7 dB against 52.2)
            "undetectable at any speed with this null"
            if not math.isfinite(mdv)
            else f"below this null's minimum detectable velocity {mdv:.2f} m/s"
            if v < mdv
            else f"within the model's 20 % of this null's minimum detectable velocity {mdv:.2f} m/s"
            if v < 1.2 * mdv
            else f"above this null's minimum detectable velocity {mdv:.2f} m/s"
        )
        return (
            f"{name}: the clutter null keeps {null.null_gain_db:.1f} dB of its peak (line-of-sight speed "
            f"{v:.2f} m/s, {where} for its conventional SNR {null.conventional_snr_db:.1f} dB and the CFAR threshold "
            f"{cfar['threshold_db']:.1f} dB): its residual peaks "
            f"{probe.snr_db:.1f} dB over the background{under}"
        )
    if level < cfar["threshold_db"]:
        return f"{name}: its peak is {probe.snr_db:.1f} dB over the background where it appears{under}"
    return (
        f"{name}: its peak is {probe.snr_db:.1f} dB over the background where it appears, but no detection "
        "was made there (a side lobe of a stronger detection, or beyond max_detections)"
    )


def reconstruct(
    raw: Product, params: ReconstructParams = ReconstructParams(), progress: ProgressFactory | None = None
) -> Product:
    """Reconstruct a raw_multichannel product into a single-channel raw product at N PRF (module docstring).

    Steps: the filter bank (:func:`_filter_bank`), the channels deramped (:func:`_to_deramped`), with
    clutter_suppression the null's residual (:func:`_clutter_residual`), the reconstruction (:func:`_reconstruct`),
    the movers detected and focused (:func:`_detect_and_focus`, detection auto) or the whole swath as one
    (:func:`_whole_swath_mover`, detection whole), then back to raw echoes (:func:`_raw_echoes`).
    """
    _check_input(raw)
    g = _geometry(raw, params)
    n_ch, n_az, n_rg = raw.data.shape
    bank = _filter_bank(g, n_az, params)
    mode = None if params.range_compression == "auto" else params.range_compression
    spec, f_r, lead, expand, compression = _to_deramped(raw, g, mode)  # (N, n_az, n_fft) in (t, f_r)
    info = {
        "n_channels": int(n_ch),
        "prf_in": float(g.prf),
        "prf_out": g.n * g.prf,
        "doppler_bandwidth": 2 * g.half_band,
        "condition_number": bank.max_condition,
        "noise_gain_db": 10 * math.log10(bank.noise_gain),
        "uniform_prf": 2 * g.velocity / (n_ch * float(np.mean(np.diff(g.dx)))) if n_ch > 1 else g.prf,
        "method": params.method,
        "range_compression": compression,
        # the receivers along track from the transmitter (m): with prf_in, the channels evaluate's first-order
        # ghost level of a velocity error needs (sarproc.quality.moving), the image having one channel left
        "channel_offsets": [float(x) for x in g.dx],
    }
    # With the clutter null, detection and estimation see only the chirp's range band: the bins outside it hold
    # the chirp's spectral tails aliased by the range sampling (true frequency f_r -+ f_s), whose azimuth history
    # the deramp (built for f_r) does not make static. The null cannot cancel them, and compression puts their
    # residue about T_p in range from every bright static point (docs/multichannel.md section 8: false alarms of
    # bright static points). The reconstruction keeps every bin (a mover's tails keep their conventional one).
    in_band = np.abs(f_r) <= raw.radar.bandwidth / 2
    spec_est = spec * in_band if params.clutter_suppression and not np.all(in_band) else spec
    residual = _clutter_residual(spec, in_band, g, params, info) if params.clutter_suppression else None
    y = _reconstruct(spec, bank)  # (N n_az, n_fft) in (f_a, f_r)
    movers: list[MovingTarget] = []
    if params.method == "modified" and params.detection == "auto":
        src = y if residual is None else channels.apply_filter_bank(residual, bank)
        movers = _detect_and_focus(
            raw, params, g, spec_est, src, y, f_r, lead, info, progress, bank, residual is not None
        )
        movers = _compression_corrected(raw, g, movers)
        del src
    del spec_est
    residual = None
    y = sfft.ifft(y, axis=0, workers=-1)  # (t', f_r)
    if params.method == "modified" and params.detection == "whole":
        mt, y = _whole_swath_mover(raw, params, g, spec, y, f_r, lead)
        movers.append(mt)
    del spec
    out = _raw_echoes(y, g, f_r, expand, lead, n_rg)
    return _output_product(raw, params, g, out, info, movers)


def _filter_bank(g: _Geometry, n_az: int, params: ReconstructParams) -> channels.FilterBank:
    """The reconstruction filter bank, with a warning where N PRF is below the Doppler band (the output stays
    aliased) or the bank's condition number exceeds max_condition."""
    if g.n * g.prf < 2 * g.half_band:
        log.warning(
            "reconstruct: N PRF = %.4g Hz is below the Doppler bandwidth %.4g Hz: the output stays aliased",
            g.n * g.prf,
            2 * g.half_band,
            extra=IMAGE_DEFECT,
        )
    bank = channels.filter_bank(g.tau0, g.prf, n_az, regularization=params.regularization)
    if bank.max_condition > params.max_condition:
        log.warning(
            "reconstruct: filter bank condition number %.3g exceeds %.3g (noise gain %.1f dB)%s",
            bank.max_condition,
            params.max_condition,
            10 * math.log10(bank.noise_gain),
            "" if params.regularization > 0 else "; set reconstruct.regularization",
        )
    return bank


def _clutter_residual(
    spec: np.ndarray, in_band: np.ndarray, g: _Geometry, params: ReconstructParams, info: dict
) -> np.ndarray | None:
    """The clutter null's residual of the deramped channels ``spec`` in (f_a, f_r), the chirp's range band only
    (``in_band``), for detection (method modified, detection auto; else None); its redundant channels and
    suppression go into ``info``, with a warning where no channel is redundant."""
    spec_fa = sfft.fft(spec, axis=1, workers=-1)
    res, dof = clutter_null(spec_fa, g, params.clutter_band)
    before, after = float(np.sum(np.abs(spec_fa) ** 2)), float(np.sum(np.abs(res) ** 2))
    info["clutter_redundant_channels"] = dof
    info["clutter_suppression_db"] = 10 * math.log10(after / before) if before > 0 and after > 0 else None
    if dof <= 0:
        log.warning("reconstruct: no redundant channel (N PRF barely covers the Doppler band): no clutter null")
    if params.method == "modified" and params.detection == "auto":
        return res * in_band
    return None


def _whole_swath_mover(
    raw: Product,
    params: ReconstructParams,
    g: _Geometry,
    spec: np.ndarray,
    y: np.ndarray,
    f_r: np.ndarray,
    lead: int,
) -> tuple[MovingTarget, np.ndarray]:
    """detection whole: the whole swath estimated as one mover, and the reconstruction ``y`` (t', f_r) replaced
    by its modified one (focused along track)."""
    win = _Window(spec, f_r, g, params)
    centre_range = C / 2 * (raw.coords["range_time"][0] + ((len(f_r) - 1) / 2 - lead) / g.fs)
    mt, notes = _estimate(win, params, g, centre_range, (len(f_r) - 1) / 2)
    for note in notes:
        log.warning("reconstruct: the whole swath as one mover: %s", note)
    assert mt is not None  # only a static_below threshold (not given here) drops a mover
    mt = dataclasses.replace(mt, first_cell=0, last_cell=len(f_r))
    y = win.output(
        mt.radial_velocity, mt.along_track_velocity, mt.beam_centre_time, mt.slant_range, focus_along_track=True
    )
    return mt, y


def _raw_echoes(y: np.ndarray, g: _Geometry, f_r: np.ndarray, expand: np.ndarray, lead: int, n_rg: int) -> np.ndarray:
    """The reconstruction ``y`` (t', f_r) back to raw echoes on the input's range samples: the deramp restored and
    the chirp re-expanded by ``expand`` (range_compression_filters), complex64 (t', range time). ``y`` is changed in
    place."""
    y *= deramp.deramp_phasor(g.out_times, f_r, g.velocity, g.squint, g.fc, sign=+1)
    y *= expand[None, :]
    return sfft.ifft(y, axis=1, workers=-1)[:, lead : lead + n_rg].astype(np.complex64)


# dB: detection SNR under which a detection no velocity explains is said to be too weak for the velocity search
# (docs/multichannel.md section 8, "Where it breaks, the product says so"); above it that is no explanation (mover
# campaign scene 010's M2, 51.5 dB, whose eq. 5 has no dip; a static point 26 dB brighter shares its range cell)
WEAK_SEARCH_DB = 20.0
PROBE_SAMPLES = 16  # azimuth samples either side of a truth mover's predicted peak searched for it (_probe_truth)
# m/s: each estimator's error that no SNR predicts, measured (docs/multichannel.md section 8, make movers-003-sigma,
# xu_traffic): eq. 5's v_los over 24 movers (9 noise-free, rms 0.019; 15 in clutter with the null, rms 0.033: the
# clutter left in the window pulls it); the null fit's v_los over the 6 clutter movers it estimated (rms 0.072, up to
# 0.113); the autofocus's v_a over the 9 noise-free movers (rms 0.023; 0.05 before, measured with the 0.08 m/s bias
# of the detection's range cell in it) and, with the clutter null, over the 15 clutter movers in whose cells
# _autofocus_snr found nothing above the mover's own residue (rms 0.040: clutter too weak to measure still pulls it)
LOS_FLOOR = 0.03
NULL_FIT_FLOOR = 0.08
ALONG_TRACK_FLOOR = 0.025
ALONG_TRACK_CLUTTER_FLOOR = 0.04
# the autofocus's data of a noise-free mover alone: 24.6-26.1 dB over its ring bins (_autofocus_snr; the focus's residue
# beyond the quadratic and cubic phase), measured on tests/focus/test_movers.py's two_movers M1 and M2
AUTOFOCUS_SELF = 10 ** (-24.0 / 10)


def _compression_corrected(raw: Product, g: _Geometry, movers: list[MovingTarget]) -> list[MovingTarget]:
    """``movers``, each with the detection image's compression offset taken out of its apparent time (and range)
    (:func:`_compression_corrected_one`; the track and the compression shared by all computed once)."""
    centres = moving.phase_centres(raw)
    positions = np.stack([np.interp(g.out_times, g.times, centres[:, c]) for c in range(3)], axis=-1)
    ka = float(detection.fm_rate(g.velocity, g.squint, _swath_centre_range(raw), g.fc, 0.0))
    return [_compression_corrected_one(raw, g, mt, centres, positions, ka) for mt in movers]


def _compression_corrected_one(
    raw: Product, g: _Geometry, mt: MovingTarget, centres: np.ndarray, positions: np.ndarray, ka: float
) -> MovingTarget:
    """``mt`` with the detection image's compression offset taken out of its apparent time (and range);
    ``centres``: the phase centres at ``g.times``, ``positions`` at ``g.out_times``; ``ka``: the compression's
    FM rate.

    The detection image's peak (_refine_peak) is not at the static equivalent's beam-centre time: the quadratic
    compression leaves the squint's cubic term, whose offset over the mover's illumination is -0.13 to -0.18 ms
    (0.9-1.2 m in azimuth) on xu_scene (detection.compressed_peak_offset). It is modelled at the uncorrected
    apparent position, with the mover's illumination from its relocated position and estimated velocity, and
    subtracted; the walk-corrected range R_app + v sin(theta) t_app the peak measured stays.
    """
    if not (mt.first_cell < mt.last_cell) or not np.isfinite(mt.apparent_time):
        return mt
    p = np.array([np.interp(mt.apparent_time, g.times, centres[:, c]) for c in range(3)])
    app = _beam_centre_point(p, mt.apparent_range, g.squint)
    try:
        vel = moving.scene_velocity(app, mt.along_track_velocity, mt.radial_velocity, raw.radar.altitude)
        interval = moving.illumination_interval(
            raw.radar, g.times, moving.relocate(raw.radar, g.times, app, vel, centres), vel, centres
        )
    except InputError:
        return mt  # not relocatable: _moving_target_rows says so
    dt = detection.compressed_peak_offset(
        g.out_times, positions, app, interval, mt.apparent_time, g.squint, g.velocity, raw.radar.wavelength, ka
    )
    walk = g.velocity * math.sin(g.squint)
    t_app = mt.apparent_time - dt
    return dataclasses.replace(mt, apparent_time=t_app, apparent_range=mt.apparent_range + walk * dt)


def _beam_centre_point(platform_xyz: np.ndarray, slant_range: float, squint: float) -> np.ndarray:
    """Static point at beam centre (squint theta) at ``slant_range`` from the phase centre (ground z = 0)."""
    p = np.asarray(platform_xyz, float)
    uz = -p[2] / slant_range
    ux = math.sin(squint)
    return p + slant_range * np.array([ux, math.sqrt(max(0.0, 1.0 - ux**2 - uz**2)), uz])


def _illumination_cut(t_c: float, t_ill: float, g: _Geometry) -> float:
    """s: how much of a mover's illumination ``t_ill`` lies outside the data, from its energy's centroid ``t_c`` in
    the output time (_centre): a cut c leaves t_ill - c lit, against the data's edge, centred c / 2 inside its
    beam-centre time. 0 for a mover whose illumination the data hold whole."""
    if not math.isfinite(t_c):
        return 0.0
    t0, t1 = float(g.out_times[0]), float(g.out_times[-1]) + 1.0 / (g.n * g.prf)
    return max(0.0, t_ill - 2 * (t1 - t_c), t_ill - 2 * (t_c - t0))


def _uncertainties(mt: MovingTarget, g: _Geometry, clutter_band: float | None) -> tuple[float, float, float]:
    """1-sigma v_r, v_a (m/s) and along-track relocation (m), each from what its estimator sees (docs/multichannel.md).

    Both estimators work on the mover's whole echo, before the clutter null. Without the null its SNR is the
    detection SNR; with it (``clutter_band``: the null's) the detection SNR is the residual's, which keeps only the
    null's peak gain G(v_los) of the mover (detection.clutter_null_peak_gain: -10 to -36 dB on xu_traffic), so the
    mover's own SNR is snr = detection SNR / G. Taking the residual's SNR for it over-stated both CRB terms by
    1 / sqrt(G) (v_r's 1-sigma about 2x, its line-of-sight part 3.5x on the clutter Monte-Carlo).
    v_los (the leakage search, or the null fit): the criterion measures the channel phase 4 pi v_los tau_n / lambda;
    with per-channel coherent SNR snr / N its phase noise is 1 / sqrt(2 snr / N), a straight-line fit over tau_n gives
    sigma_los = lambda / (4 pi sqrt(sum (tau_n - mean)^2)) / sqrt(2 snr / N) (for a slow mover, G ~ v_los^2, the same
    as the residual's amplitude measuring v_los to |v_los| / sqrt(2 x detection SNR)). Each path's model error, which
    no SNR predicts, is added in quadrature: LOS_FLOOR for eq. 5, NULL_FIT_FLOOR for the null fit.
    v_a (autofocus): the quadratic phase coefficient over T has variance 90 / (snr_af T^4), so
    sigma_K = sqrt(90 / snr_af) / (pi T^2) and dK/dv_a = 2 K / v; snr_af is the autofocus's own integrated signal to
    clutter-plus-noise ratio (_autofocus_snr: the clutter in the mover's cells, which the null hid from the
    detection, counts), never above the mover's snr (which it is where no autofocus ran or it saw nothing). The
    clutter in the mover's cells illuminated before and after it pulls the autofocus (a bias, not noise: no SNR
    predicts it); the autofocus run again on the mover's illumination alone measures that pull (illumination_pull),
    added in quadrature, as is the autofocus's error on noise-free movers (ALONG_TRACK_FLOOR; with the null, on
    clutter movers whose _autofocus_snr saw no clutter: ALONG_TRACK_CLUTTER_FLOOR).
    v_r = (v_los - v_a sin(theta)) / cos(theta) (the refined search keeps v_los with v_a fixed), so
    sigma_vr^2 = (sigma_los^2 + sin(theta)^2 sigma_va^2) / cos(theta)^2.
    Relocation: the apparent shift is about R v_los / v, so sigma_x = R sqrt(sigma_los^2 + (sin sigma_a)^2) / v.
    sigma_los is never under the null fit's minimum's half-width (MovingTarget.null_fit_width) nor, where the null
    fit overruled a mover's eq. 5 estimate, their difference (MovingTarget.overruled): biases of the criterion that
    no SNR predicts (scene 011 before the null fit modelled the beam's skirt: v_r 11 m/s off, stated 0.13).
    """
    lam = C / g.fc
    cos, sin = math.cos(g.squint), math.sin(g.squint)
    snr = 10 ** (mt.snr_db / 10) if np.isfinite(mt.snr_db) else float("inf")
    if clutter_band is not None and math.isfinite(snr):
        # the detection SNR is the clutter-null residual's, which keeps G of the mover's peak; both estimators work
        # on its whole echo before the null
        v_los = mt.line_of_sight_velocity(g.squint)
        gain = min(1.0, detection.clutter_null_peak_gain(g.tau0, g.prf, g.half_band, clutter_band, lam, v_los))
        snr = snr / gain if gain > 0 else float("inf")
    # the autofocus's data holds at least the mover's background; inf: nothing above a clean mover's residue
    snr_af = snr if math.isnan(mt.autofocus_snr) else min(snr, mt.autofocus_snr)
    spread = float(np.sqrt(np.sum((g.tau0 - g.tau0.mean()) ** 2)))
    s_los = lam / (4 * math.pi * spread) / math.sqrt(2 * snr / g.n) if spread > 0 else float("inf")
    s_los = math.hypot(s_los, NULL_FIT_FLOOR if mt.null_fit_index is not None else LOS_FLOOR)
    # what the criterion's own curve says, which no SNR predicts: a flat minimum, or an overruled eq. 5 estimate
    s_los = max(s_los, mt.null_fit_width, abs(mt.overruled), mt.leakage_spread)
    ka = 2 * (g.velocity * cos) ** 2 / (lam * mt.apparent_range)
    t_ill = 2 * g.half_band / ka
    s_k = math.sqrt(90 / snr_af) / (math.pi * t_ill**2)
    if mt.lit_cut > 0:
        # eq. 5 searched the span symmetric about the beam-centre time its lit edge gives (_lit_span): an error dt of
        # that time moves the span's band K_a dt off centre; the edge is located to about one output sample
        s_los = math.hypot(s_los, lam / 2 * ka / (g.n * g.prf))
    else:
        # a mover lit past the data's start or end, not corrected (no rect beam's edge to tell its beam-centre time,
        # or eq. 5 not the criterion): its Doppler band is cut on that side and eq. 5, flat across the cut, settles
        # about half of it off the truth (_illumination_cut; docs/multichannel.md sections 18 and 21)
        s_los = max(s_los, lam / 2 * ka * _illumination_cut(mt.beam_centre_time, t_ill, g))
    # the clutter's pull, which the CRB misses: measured by the autofocus itself (illumination_pull)
    pull = abs(mt.autofocus_pull) if np.isfinite(mt.autofocus_pull) else 0.0
    floor_a = ALONG_TRACK_FLOOR if clutter_band is None else ALONG_TRACK_CLUTTER_FLOOR
    s_a = math.hypot(math.hypot(s_k * g.velocity / (2 * ka), floor_a), pull)
    s_r = math.hypot(s_los, sin * s_a) / cos
    s_x = mt.apparent_range * math.hypot(s_los, sin * s_a) / g.velocity
    return s_r, s_a, s_x


TRUTH_MATCH_M = 20.0  # m: a detection within this of a truth point's apparent position is matched to it


def _static_matches(truth: np.ndarray, rows: np.ndarray, names: list[str], static: list[int]) -> dict:
    """The table's detections against the static truth points (whose apparent position is their own):
    ``static_points``, per static point the detections within TRUTH_MATCH_M (a static point taken for a mover),
    and ``unmatched``, per row matched to no truth mover (table order) its nearest static point and distance
    (None without static points) and whether it lies within TRUTH_MATCH_M of it (``at_static``: not a false
    alarm on the open scene)."""
    col = {name: k for k, (name, _, _) in enumerate(MOVING_TARGET_COLUMNS)}
    app = rows[:, [col["apparent_x"], col["apparent_y"], col["apparent_z"]]] if len(rows) else np.zeros((0, 3))
    xyz = {k: np.array([truth[c][k] for c in "xyz"], float) for k in static}
    dist = {k: np.linalg.norm(app - xyz[k], axis=1) for k in static}
    points = [{"name": names[k], "detections_within": int(np.sum(dist[k] <= TRUTH_MATCH_M))} for k in static]
    unmatched = []
    for i in range(len(rows)):
        if rows[i, col["truth_index"]] >= 0:
            continue
        k = min(static, key=lambda j: dist[j][i]) if static else None
        d = None if k is None else float(dist[k][i])
        unmatched.append(
            {
                "row": i,
                "nearest_static": None if k is None else names[k],
                "distance": d,
                "at_static": d is not None and d <= TRUTH_MATCH_M,
            }
        )
    return {"static_points": points, "unmatched": unmatched}


def _relocation_checks(
    raw: Product, g: _Geometry, rows: np.ndarray, truth_apparent: dict, names: list[str], centres: np.ndarray
) -> list[dict]:
    """Per table row matched to a truth mover, in table order: its name, row and relocation against the truth
    (sarproc.quality.moving.relocation_check: the relocation error, the bound its apparent-position and velocity
    errors allow, the verdict)."""
    from sarproc.quality.moving import relocation_check

    col = {name: k for k, (name, _, _) in enumerate(MOVING_TARGET_COLUMNS)}
    out = []
    for i, row in enumerate(rows):
        k = int(row[col["truth_index"]])
        relocated = row[[col["relocated_x"], col["relocated_y"], col["relocated_z"]]]
        if k < 0 or not np.all(np.isfinite(relocated)):
            continue
        truth = np.array([raw.targets[c][k] for c in "xyz"], float)
        start = row[[col["apparent_x"], col["apparent_y"], col["apparent_z"]]]
        check = relocation_check(
            raw.radar, g.times, centres, truth, truth_apparent[k], start, relocated, row[col["v_a"]], row[col["v_r"]]
        )
        out.append({"name": names[k], "row": i, **check})
    return out


def _moving_target_rows(
    raw: Product, g: _Geometry, movers: list[MovingTarget], info: dict, params: ReconstructParams
) -> np.ndarray:
    """The aux ``moving_targets`` table (model.MOVING_TARGET_COLUMNS), matched to moving truth targets if any."""
    centres = moving.phase_centres(raw)
    rows = np.zeros((0, len(MOVING_TARGET_COLUMNS)))
    truth = raw.targets
    speeds = np.stack([truth["vx"], truth["vy"], truth["vz"]], axis=1) if len(truth) else np.zeros((0, 3))
    moving_rows = [k for k in range(len(truth)) if np.any(speeds[k] != 0)]
    truth_apparent = {
        k: moving.apparent_position(
            raw.radar, g.times, [truth["x"][k], truth["y"][k], truth["z"][k]], speeds[k], centres
        )[0]
        for k in moving_rows
    }
    out = []
    for i, mt in enumerate(movers):
        if not (mt.first_cell < mt.last_cell) or not np.isfinite(mt.apparent_time):
            continue
        p = np.array([np.interp(mt.apparent_time, g.times, centres[:, c]) for c in range(3)])
        app = _beam_centre_point(p, mt.apparent_range, g.squint)
        vel = moving.scene_velocity(app, mt.along_track_velocity, mt.radial_velocity, raw.radar.altitude)
        try:
            true_xyz = moving.relocate(raw.radar, g.times, app, vel, centres)
        except InputError as exc:
            log.warning("reconstruct: mover %d not relocated: %s", i, exc)
            true_xyz = np.full(3, np.nan)
        s_r, s_a, s_x = _uncertainties(mt, g, params.clutter_band if params.clutter_suppression else None)
        out.append(
            [
                i,
                mt.snr_db,
                mt.radial_velocity,
                s_r,
                mt.along_track_velocity,
                s_a,
                *app,
                *true_xyz,
                s_x,
                mt.apparent_time,
                mt.first_cell,
                mt.last_cell,
                mt.leakage,
                -1,
            ]
        )
    if out:
        rows = np.array(out, float)
    # Match each truth mover to the nearest unclaimed detection within TRUTH_MATCH_M of its apparent position.
    if moving_rows and len(rows):
        free = set(range(len(rows)))
        pairs = sorted(
            (float(np.linalg.norm(rows[i, 6:9] - truth_apparent[k])), i, k)
            for i in range(len(rows))
            for k in moving_rows
        )
        taken = set()
        for dist, i, k in pairs:
            if dist <= TRUTH_MATCH_M and i in free and k not in taken:
                rows[i, -1] = k
                free.discard(i)
                taken.add(k)
    if moving_rows:
        names = target_names(truth)
        found = {int(k) for k in rows[:, -1] if k >= 0} if len(rows) else set()
        probes, rejected, spacing = info.pop("_probes", ({}, [], 1.0))
        cfar = info.get("detection_cfar", {"threshold_db": params.detection_snr})
        missed = [k for k in moving_rows if k not in found]
        reasons = [_miss_reason(names[k], probes.get(int(k)), rejected, spacing, params, cfar) for k in missed]
        for reason in reasons:
            log.warning("reconstruct: truth mover %s", reason)
        info["truth"] = {
            "movers": len(moving_rows),
            "found": len(found),
            "missed": [names[k] for k in missed],
            "missed_reasons": reasons,
            "false_alarms": int(np.sum(rows[:, -1] < 0)) if len(rows) else 0,
            "relocation": _relocation_checks(raw, g, rows, truth_apparent, names, centres),
            **_static_matches(truth, rows, names, [k for k in range(len(truth)) if k not in moving_rows]),
        }
    return rows


def _output_product(
    raw: Product, params: ReconstructParams, g: _Geometry, out: np.ndarray, info: dict, movers: list[MovingTarget]
) -> Product:
    from sarproc.product.io import history_entry

    pos = raw.aux["platform_position"]
    out_pos = np.stack([np.interp(g.out_times, g.times, pos[:, k]) for k in range(3)], axis=1)
    # Beyond the last input pulse the track is extrapolated linearly (straight-line flight).
    if len(g.times) > 1:
        late = g.out_times > g.times[-1]
        vel = (pos[-1] - pos[-2]) / (g.times[-1] - g.times[-2])
        out_pos[late] = pos[-1] + (g.out_times[late] - g.times[-1])[:, None] * vel
    tx = np.asarray(raw.aux.get("tx_offset", np.zeros(3)), float).reshape(3)
    aux = {k: v for k, v in raw.aux.items() if k not in ("platform_position", "rx_offset", "tx_offset")}
    aux.update(platform_position=out_pos, tx_offset=tx, rx_offset=tx.reshape(1, 3))
    info["moving_targets"] = []
    for k, mt in enumerate(movers):
        info["moving_targets"].append(
            {
                "first_cell": int(mt.first_cell),
                "last_cell": int(mt.last_cell),
                "slant_range": float(mt.slant_range),
                "radial_velocity": mt.radial_velocity,
                "along_track_velocity": mt.along_track_velocity,
                "beam_centre_time": float(mt.beam_centre_time),
                "leakage": float(mt.leakage),
                "at_bound": bool(mt.at_bound),
                "search_evaluations": int(len(mt.search)),
                "snr_db": float(mt.snr_db) if np.isfinite(mt.snr_db) else None,
                # the autofocus's own signal to clutter-plus-noise ratio (v_a_sigma's; None: no autofocus or none)
                "autofocus_snr_db": 10 * math.log10(mt.autofocus_snr) if 0 < mt.autofocus_snr < math.inf else None,
                # v_a's offset (m/s) on its illumination alone: the clutter's pull in v_a_sigma (None: no autofocus)
                "autofocus_pull": float(mt.autofocus_pull) if np.isfinite(mt.autofocus_pull) else None,
                # v_los from the clutter-null residual's fit (_NullFit) rather than eq. 5 (NULL_FIT_FLOOR in v_r_sigma)
                "null_fit": mt.null_fit_index is not None,
                "apparent_time": float(mt.apparent_time) if np.isfinite(mt.apparent_time) else None,
            }
        )
        aux[f"velocity_search_{k}"] = mt.search
        if len(mt.autofocus):
            aux[f"autofocus_{k}"] = mt.autofocus
    if movers:
        aux["estimated_velocity"] = np.array([[m.radial_velocity, m.along_track_velocity] for m in movers])
    if params.method == "modified" and params.detection == "auto":
        aux["moving_targets"] = _moving_target_rows(raw, g, movers, info, params)
    else:  # no detection ran: an empty table, and no claim about the truth movers
        aux["moving_targets"] = np.zeros((0, len(MOVING_TARGET_COLUMNS)))
    radar = raw.radar.replace(prf=g.n * g.prf, n_channels=1)
    # the reconstructed channel's Doppler power spectrum (squint centroid removed): where its band lies in the
    # N PRF and its ghosts' bands (paper 003 Fig. 10; docs/product.md); left out where the output is not finite
    freq, power = channels.azimuth_power_spectrum(out, g.out_times, radar)
    if np.all(np.isfinite(power)):
        aux["doppler_frequency"], aux["doppler_power"] = freq, power
    info.pop("_probes", None)  # _detect_and_focus's hand-over to _moving_target_rows, not product metadata
    # NaN or Inf samples written (0 but where the filter bank breaks down): every later stage refuses to read them
    # (read_product's check_finite); recorded so that the product says so itself
    info["non_finite_samples"] = int(out.size - np.count_nonzero(np.isfinite(out)))
    attrs = dict(raw.attrs.items())
    attrs["reconstruct"] = info
    prod = raw.derive(
        "raw",
        out,
        ("azimuth_time", "range_time"),
        {"azimuth_time": g.out_times, "range_time": raw.coords["range_time"]},
        radar=radar,
        attrs=attrs,
        aux=aux,
    )
    prod.history.append(history_entry("reconstruct", as_dict(params)))
    return prod
