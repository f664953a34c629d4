"""Range compression by matched filtering in the range-frequency domain."""

from __future__ import annotations

import math

import numpy as np

from sarproc.product import fft as sfft
from sarproc.product.errors import InputError
from sarproc.product.metadata import RadarMetadata
from sarproc.product.theory import WINDOWS, window_taper

FILTERS = ("flat", "matched")


def chirp_replica(radar: RadarMetadata) -> tuple[np.ndarray, int]:
    """Centred chirp replica sampled at f_s: (samples complex128, index of tau = 0)."""
    fs, tp = radar.range_sampling_rate, radar.pulse_duration
    half = int(math.floor(tp * fs / 2))
    tau = np.arange(-half, half + 1) / fs
    h = np.where(np.abs(tau) <= tp / 2, np.exp(1j * np.pi * radar.chirp_rate * tau**2), 0)
    return h, half


def replica_fft_size(radar: RadarMetadata, n_range: int) -> int:
    """FFT length of range compression: n_range + the replica, so the circular convolution does not wrap."""
    h, _ = chirp_replica(radar)
    return sfft.next_fast_len(n_range + len(h), real=False)


def replica_spectrum(radar: RadarMetadata, n_fft: int) -> np.ndarray:
    """FFT (n_fft bins, unshifted) of the chirp replica circularly centred on sample 0 (tau = 0), complex128."""
    h, half = chirp_replica(radar)
    circ = np.zeros(n_fft, complex)
    circ[: half + 1] = h[half:]
    circ[n_fft - half :] = h[:half]
    return sfft.fft(circ)


def replica_alias_power(radar: RadarMetadata, n_fft: int, oversample: int = 8) -> np.ndarray:
    """|H_s|^2 with the aliases summed in power: sum_k |C(f - k f_s)|^2 on replica_spectrum's grid (n_fft bins,
    unshifted), C the continuous chirp's spectrum (the chirp sampled ``oversample`` times finer, the same rect).

    replica_spectrum is the coherent sum sum_k C(f - k f_s); beyond B/2 its terms are the Fresnel tails of the
    pulse's end and of its start, and their beat (period 1 / T_p) is a ripple in |H_s| that this sum has not."""
    fs, tp, m = radar.range_sampling_rate, radar.pulse_duration, oversample
    half = int(math.floor(tp * fs / 2)) * m + (m - 1)
    tau = np.arange(-half, half + 1) / (m * fs)
    h = np.where(np.abs(tau) <= tp / 2, np.exp(1j * np.pi * radar.chirp_rate * tau**2), 0)
    circ = np.zeros(n_fft * m, complex)
    circ[: half + 1] = h[half:]
    circ[n_fft * m - half :] = h[:half]
    fine = np.abs(sfft.fft(circ)) ** 2 / m**2
    # the replica is the fine chirp's every m-th sample: its bin q holds the fine bins q + k n_fft
    return fine.reshape(m, n_fft).sum(axis=0)


def spectral_window(name: str, freqs: np.ndarray, bandwidth: float) -> np.ndarray:
    """Amplitude taper over the band |f| <= B/2 (zero outside); the windows and their theory are
    sarproc.product.theory's."""
    if name not in WINDOWS:
        raise InputError(f"range window {name!r} is not one of {list(WINDOWS)}")
    x = freqs / bandwidth
    return window_taper(name, np.where(np.abs(x) <= 0.5, x, 1.0))


def range_compress(
    signal: np.ndarray, radar: RadarMetadata, window: str = "none", workers: int = -1, filter: str = "flat"
) -> np.ndarray:
    """Range-compress the last axis of ``signal``; a target's peak lands at its delay's sample.

    ``filter='matched'`` is the classic matched filter conj(H(f)): its output spectrum is
    |H(f)|^2, whose Fresnel ripples (finite time-bandwidth product) raise the far side lobes.
    ``filter='flat'`` (default) divides by H(f) inside |f| <= B/2 instead, so the compressed
    spectrum is exactly rect(f/B) (times ``window``): the ideal sinc the theory refers to.
    ``signal`` (..., n_range) complex; returns complex64 of the same shape, normalised so a
    unit-amplitude echo compresses to a peak of about 1.
    """
    if filter not in FILTERS:
        raise InputError(f"range filter {filter!r} is not one of {list(FILTERS)}")
    n_rg = signal.shape[-1]
    h, _ = chirp_replica(radar)
    n_fft = replica_fft_size(radar, n_rg)
    spec_h = replica_spectrum(radar, n_fft)
    f = sfft.fftfreq(n_fft, 1.0 / radar.range_sampling_rate)
    if filter == "matched":
        filt = np.conj(spec_h) / np.count_nonzero(h)
        if window != "none":
            filt = filt * spectral_window(window, f, radar.bandwidth)
    else:
        band = spectral_window(window, f, radar.bandwidth)
        # Unit-amplitude echo -> rect spectrum of height n_fft / n_band -> unit peak.
        filt = np.where(band > 0, band / np.where(band > 0, spec_h, 1), 0) * (n_fft / np.count_nonzero(band))
    spec = sfft.fft(signal, n=n_fft, axis=-1, workers=workers)
    spec *= filt.astype(np.complex64 if signal.dtype == np.complex64 else complex)
    out = sfft.ifft(spec, axis=-1, workers=workers)[..., :n_rg]
    return out.astype(np.complex64)
