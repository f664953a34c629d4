"""Along-track channel model and the multichannel reconstruction filter bank (paper 003; Krieger 2004).

Channel model (derived in docs/multichannel.md, checked against the exact bistatic simulator
by tests/focus/test_multichannel.py). One transmitter at the platform, receiver n at
along-track offset dx_n; platform speed v along +x, a point target moving with along-track
velocity v_a (+x) and slant-range velocity v_r (away from the track, slant plane). In the frame
of the target the platform moves at v - v_a, so the receiver's bistatic path at pulse time t is
the monostatic path of a phase centre half-way between transmitter and receiver, which the
monostatic radar would occupy at time t + tau_n:

    tau_n = dx_n / (2 (v - v_a))                                           (1)

up to two terms. (a) The part of the target's motion the time shift does not absorb (its
slant-range motion during tau_n) lengthens the monostatic path by -2 v_r cos(theta) tau_n, a
channel phase  exp(+j 4 pi v_r cos(theta) tau_n / lambda)  (the channel phase imbalance of
paper 003, its eq. (8), second term). (b) The bistatic path exceeds twice the monostatic one
by the geometric constant

    e_n = dx_n^2 cos^2(theta) / (4 R)                                      (2)

(paper 003 eq. (8), first term: the same for static and moving targets). With the squint
Doppler history removed (deramp.py) and the target's Doppler offset
f_v = -2 v_los / lambda, v_los = v_r cos(theta) + v_a sin(theta), taken out, channel n of a
moving target is the monostatic baseband signal g delayed by tau_n, exactly as for a static
target: s_n(t) = g(t + tau_n). Its spectrum, sampled at PRF, aliases N bands:

    S_n(f) = sum_j H_nj(f) G(f + j PRF),   H_nj(f) = exp(j 2 pi (f + j PRF) tau_n)        (3)

for f in the base band and the N aliases j whose frequencies f + j PRF lie in the processed band
[f_0 - N PRF / 2, f_0 + N PRF / 2). The reconstruction filter bank (Krieger, Gebert, Moreira
2004) inverts H per frequency, G = P S with P = H^-1, and places the N bands side by side in a
spectrum sampled at N PRF (scaled by N, the DFT length ratio). When H is ill-conditioned
(non-uniform phase centres, e.g. PRF far from 2 v / (N d)) the Tikhonov solution

    P = (H^H H + mu s_max^2 I)^-1 H^H                                      (4)

trades residual ambiguities for noise. The noise gain reported is mean_f sum_jn |P_jn|^2, 1
(0 dB) for uniform sampling (H / sqrt(N) unitary), the SNR scaling factor of Krieger 2004.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from collections.abc import Mapping, Sequence

    import numpy.typing as npt

    from sarproc.product.metadata import RadarMetadata
    from sarproc.product.model import Product
    from sarproc.quality.metrics import QualityReport


def channel_delays(
    along_track_offsets: npt.ArrayLike, velocity: float, along_track_velocity: float = 0.0
) -> np.ndarray:
    """tau_n = dx_n / (2 (v - v_a)), s (eq. 1)."""
    rel = velocity - along_track_velocity
    if not rel > 0:
        raise ValueError(f"relative along-track velocity v - v_a = {rel:g} m/s must be > 0")
    return np.asarray(along_track_offsets, float) / (2.0 * rel)


def bistatic_excess(along_track_offsets: npt.ArrayLike, squint: float, slant_range: float) -> np.ndarray:
    """e_n = dx_n^2 cos^2(theta) / (4 R), m: bistatic path minus twice the phase-centre path (eq. 2)."""
    dx = np.asarray(along_track_offsets, float)
    return dx**2 * math.cos(squint) ** 2 / (4.0 * slant_range)


def line_of_sight_velocity(radial_velocity: float, along_track_velocity: float, squint: float) -> float:
    """v_los = v_r cos(theta) + v_a sin(theta): range rate due to the target's motion at beam centre."""
    return radial_velocity * math.cos(squint) + along_track_velocity * math.sin(squint)


@dataclasses.dataclass(frozen=True)
class FilterBank:
    """Reconstruction filters for one channel geometry and PRF.

    matrix: (n_az, N, N) complex, P[a, j, n] maps channel n to band j at base bin a;
    out_index: (n_az, N) int, bin of band j in the N n_az output spectrum;
    condition: (n_az,) condition number of H per base bin; noise_gain: mean sum |P|^2.
    """

    matrix: np.ndarray
    out_index: np.ndarray
    condition: np.ndarray
    noise_gain: float
    regularization: float

    @property
    def max_condition(self) -> float:
        return float(np.max(self.condition))

    @functools.cached_property
    def matrix64(self) -> np.ndarray:
        """``matrix`` as complex64 (what apply_filter_bank multiplies by), computed once per bank."""
        return self.matrix.astype(np.complex64)

    @functools.cached_property
    def synthesis64(self) -> np.ndarray:
        """(n_az, N, N) H = P^-1 as complex64 (synthesise_channels), computed once per bank: the null fit maps
        its trial mover back to channels 3-4 times per trial velocity through the same bank."""
        return np.linalg.inv(self.matrix).astype(np.complex64)


def band_frequencies(n_az: int, prf: float, n_bands: int, band_center: float = 0.0) -> np.ndarray:
    """(n_az, n_bands) frequencies f + j PRF of each base bin's aliases inside the processed band, Hz."""
    f = np.fft.fftfreq(n_az, 1.0 / prf)
    lo = band_center - n_bands * prf / 2.0
    # First alias at or above the band's lower edge; a small tolerance keeps exact edges in.
    j0 = np.ceil((lo - f) / prf - 1e-9)
    return f[:, None] + (j0[:, None] + np.arange(n_bands)[None, :]) * prf


def filter_bank(
    tau: np.ndarray, prf: float, n_az: int, band_center: float = 0.0, regularization: float = 0.0
) -> FilterBank:
    """Filters P(f) = H(f)^-1 (eq. 3) or the Tikhonov solution (eq. 4) for ``n_az`` azimuth bins."""
    tau = np.asarray(tau, float)
    n = len(tau)
    fo = band_frequencies(n_az, prf, n, band_center)  # (n_az, N)
    h = np.exp(2j * np.pi * tau[None, :, None] * fo[:, None, :])  # (n_az, N_ch, N_band), eq. (3)
    s = np.linalg.svd(h, compute_uv=False)
    cond = s[:, 0] / np.maximum(s[:, -1], 1e-300)
    if regularization > 0:
        hh = np.conj(np.swapaxes(h, 1, 2))
        mu = regularization * s[:, :1, None] ** 2
        p = np.linalg.solve(hh @ h + mu * np.eye(n)[None], hh)  # eq. (4)
    else:
        p = np.linalg.inv(h)
    out_index = np.rint(fo * n_az / prf).astype(np.int64) % (n * n_az)
    gain = float(np.mean(np.sum(np.abs(p) ** 2, axis=(1, 2))))
    return FilterBank(matrix=p, out_index=out_index, condition=cond, noise_gain=gain, regularization=regularization)


def apply_filter_bank(spectra: np.ndarray, bank: FilterBank) -> np.ndarray:
    """Channel azimuth spectra (N, n_az, ...) -> reconstructed spectrum (N n_az, ...) at N PRF.

    Bins follow numpy's FFT order for a length-N n_az transform; complex64 in, complex64 out.
    """
    n, n_az = spectra.shape[:2]
    rest = spectra.shape[2:]
    s = np.moveaxis(spectra, 0, 1).reshape(n_az, n, -1)  # (n_az, N, m)
    z = bank.matrix64 @ s  # (n_az, N_band, m)
    out = np.empty((n * n_az,) + (s.shape[-1],), np.complex64)
    out[bank.out_index.reshape(-1)] = z.reshape(n_az * n, -1)
    out *= np.float32(n)
    return out.reshape((n * n_az,) + rest)


def synthesise_channels(spectrum: np.ndarray, bank: FilterBank) -> np.ndarray:
    """Inverse of :func:`apply_filter_bank`: reconstructed spectrum (N n_az, ...) -> channel spectra (N, n_az, ...).

    Each base bin's N band values are mapped back through H = P^-1 (eq. 3: the channels a target with that
    reconstructed spectrum and the bank's channel delays gives); exact for an unregularised bank.
    """
    n, n_az = bank.out_index.shape[1], bank.out_index.shape[0]
    rest = spectrum.shape[1:]
    z = spectrum.reshape(n * n_az, -1)[bank.out_index.reshape(-1)].reshape(n_az, n, -1) / n
    s = bank.synthesis64 @ z.astype(np.complex64)  # (n_az, N ch, m)
    return np.moveaxis(s, 1, 0).reshape((n, n_az) + rest)


def ghost_level_db(tau: np.ndarray, prf: float, error_phase: np.ndarray, half_band: float, n_az: int = 256) -> float:
    """First-order false-target level (dB) left by a channel phase error phi_n (eq. 6, docs/multichannel.md).

    A complex phi_n also carries an amplitude error: the channel gain is exp(j phi_n).

    The reconstruction sees diag(e^{j phi}) H instead of H (eq. 3), so band j' leaks into band j through
    E = P diag(e^{j phi}) H (E = I without error). A target whose spectrum is flat over |f| <= half_band
    fills band j at base bin a where |f_a + j PRF| <= half_band (occupancy o_aj); the pieces moved by k
    bands form a ghost k PRF away whose peak, relative to the target's, is

        |sum_a sum_j E[a, j + k, j] o_aj| / sum_a sum_j o_aj                                  (6)

    The largest over k = +-1 .. +-(N - 1) is returned (-inf without error).
    """
    tau = np.asarray(tau, float)
    n = len(tau)
    bank = filter_bank(tau, prf, n_az)
    fo = band_frequencies(n_az, prf, n)
    h = np.exp(2j * np.pi * tau[None, :, None] * fo[:, None, :])
    e = bank.matrix @ (np.exp(1j * np.asarray(error_phase, complex))[None, :, None] * h)
    occ = (np.abs(fo) <= half_band).astype(float)
    best = 0.0
    for k in range(1, n):
        for sign in (1, -1):
            s = sum(np.sum(e[:, j + sign * k, j] * occ[:, j]) for j in range(n) if 0 <= j + sign * k < n)
            best = max(best, abs(s) / occ.sum())
    return float(20 * np.log10(best)) if best > 0 else float("-inf")


def beam_half_band(radar: RadarMetadata) -> float:
    """Doppler half-band of the beam, Hz: v cos(theta) beamwidth / lambda (the target's flat spectrum in eq. 6)."""
    return radar.velocity * math.cos(radar.squint) * radar.azimuth_beamwidth / radar.wavelength


def velocity_error_phase(tau: npt.ArrayLike, dv_r: float, squint: float, wavelength: float) -> np.ndarray:
    """Residual channel phase (rad per channel) of a slant-range velocity error dv_r, m/s: 4 pi dv_r cos(theta)
    tau_n / lambda (eq. 8, second term, with the error in place of v_r)."""
    return 4 * np.pi * dv_r * math.cos(squint) * np.asarray(tau, float) / wavelength


def channel_ghost_level_db(
    offsets: npt.ArrayLike, radar: RadarMetadata, channel_prf: float, error_phase: npt.ArrayLike
) -> float:
    """:func:`ghost_level_db` (eq. 6) of a channel error ``error_phase`` (rad per channel; complex: with a gain
    error) for receivers at along-track ``offsets`` (m, from the transmitter) sampled at ``channel_prf``, with the
    Doppler half-band of ``radar``'s beam."""
    tau = channel_delays(offsets, radar.velocity)
    return ghost_level_db(tau, channel_prf, np.asarray(error_phase), beam_half_band(radar))


def product_ghost_level_db(raw: Product, error_phase: np.ndarray) -> float:
    """:func:`channel_ghost_level_db` of a multichannel raw product: its receivers, PRF and beam."""
    return channel_ghost_level_db(receiver_offsets(raw.aux), raw.radar, raw.radar.prf, error_phase)


def velocity_ghost(
    radar: RadarMetadata, channel_offsets: Sequence[float], channel_prf: float, dv_r: float
) -> tuple[float, float]:
    """(largest residual channel phase, rad; first-order false-target level, dB) of a slant-range velocity error
    ``dv_r`` (m/s) in a reconstruction of receivers at ``channel_offsets`` (m along track from the transmitter)
    sampled at ``channel_prf``: eq. 8's second term with the error for v_r, then eq. 6. No error: (0, -inf)."""
    if dv_r == 0:
        return 0.0, -math.inf
    phase = velocity_error_phase(channel_delays(channel_offsets, radar.velocity), dv_r, radar.squint, radar.wavelength)
    return float(np.abs(phase).max()), channel_ghost_level_db(channel_offsets, radar, channel_prf, phase)


def ghost_predictions(image: Product, report: QualityReport) -> QualityReport:
    """``report`` (evaluate's, of ``image``) with the first-order ghost levels its truth predicts, where ``image``
    records reconstruct's channels (attribute ``reconstruct``: ``channel_offsets``, ``prf_in``):

    * ``false_target_predicted``: of simulate's channel imbalance (attribute ``channel_errors``);
    * each mover's ``channel_phase_from_velocity`` and ``ghost_level_from_velocity_db``: of its slant-range
      velocity error (:func:`velocity_ghost`).
    """
    rec = image.attrs.get("reconstruct") or {}
    offsets = rec.get("channel_offsets") or []
    if len(offsets) < 2:
        return report
    prf = float(rec["prf_in"])
    radar = image.radar
    errors = image.attrs.get("channel_errors") or {}
    predicted = report.false_target_predicted
    if errors:
        gain = (1 + np.asarray(errors["amplitude_imbalance"], float)) * np.exp(
            1j * np.asarray(errors["phase_imbalance"], float)
        )
        predicted = {
            "level_db": channel_ghost_level_db(offsets, radar, prf, -1j * np.log(gain)),
            "source": "the simulated channel imbalance's ghosts, first order (channel_errors; eq. 6)",
        }
    movers = []
    for m in report.movers:
        if m.v_r_error is not None:
            phase, level = velocity_ghost(radar, offsets, prf, m.v_r_error)
            m = dataclasses.replace(m, channel_phase_from_velocity=phase, ghost_level_from_velocity_db=level)
        movers.append(m)
    return dataclasses.replace(report, false_target_predicted=predicted, movers=tuple(movers))


def receiver_offsets(aux: Mapping[str, np.ndarray]) -> np.ndarray:
    """Along-track offsets of the receivers from the transmitter, m (aux ``rx_offset`` x minus ``tx_offset`` x)."""
    tx = np.asarray(aux.get("tx_offset", np.zeros(3)), float).reshape(3)
    return np.asarray(aux["rx_offset"], float).reshape(-1, 3)[:, 0] - tx[0]


DOPPLER_SPECTRUM_BLOCK = 256  # range cells per block of doppler_power_spectrum (bounds its working memory)


def doppler_power_spectrum(product: Product) -> tuple[np.ndarray, np.ndarray]:
    """(Doppler frequencies, Hz, ascending; power summed over range) of a single-channel raw product's azimuth
    spectrum with the squint's Doppler centroid 2 v sin(theta) / lambda removed: where a reconstructed
    channel's band lies within the N PRF it carries, and its ghosts' bands (paper 003, Fig. 10).
    ``reconstruct`` stores it (aux ``doppler_frequency``, ``doppler_power``)."""
    if product.data.ndim != 2:
        raise ValueError(f"doppler_power_spectrum: a single-channel product, not one of {product.data.ndim} axes")
    return azimuth_power_spectrum(product.data, np.asarray(product.coords["azimuth_time"], dtype=float), product.radar)


def azimuth_power_spectrum(
    data: np.ndarray, azimuth_time: np.ndarray, radar: RadarMetadata
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`doppler_power_spectrum` of ``data`` (azimuth_time, range) sampled at ``radar.prf``, computed in blocks
    of DOPPLER_SPECTRUM_BLOCK range cells."""
    r = radar
    ramp = np.exp(-2j * np.pi * 2 * r.velocity * math.sin(r.squint) / r.wavelength * azimuth_time)[:, None]
    power = np.zeros(len(data))
    for c in range(0, data.shape[1], DOPPLER_SPECTRUM_BLOCK):
        block = data[:, c : c + DOPPLER_SPECTRUM_BLOCK] * ramp
        power += np.sum(np.abs(np.fft.fft(block, axis=0)) ** 2, axis=1)
    return np.fft.fftshift(np.fft.fftfreq(len(data), 1 / r.prf)), np.fft.fftshift(power)


def ghost_spacing(radar: RadarMetadata, prf: float | None = None) -> float:
    """Azimuth distance between a target and its first channel ghost, m: PRF v / K_a with the azimuth FM rate
    K_a = 2 (v cos theta)^2 / (lambda R_ref) at the reference range. ``prf``: the channels' PRF (default the
    radar's; a reconstructed product's radar carries N times it)."""
    ka = 2 * (radar.velocity * math.cos(radar.squint)) ** 2 / (radar.wavelength * radar.reference_range)
    return (radar.prf if prf is None else prf) / ka * radar.velocity
