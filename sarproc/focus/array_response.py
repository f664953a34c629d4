"""What a cross-track array's focused responses look like, recorded beside its images for evaluate's
neighbour models: the azimuth chirp of a beam-limited aperture, the array factor's period in elevation and
the range response of the range filter. Shared by array3d's cubes and backproject's 3D (elevation-frame)
images, whose responses are the same (paper 004)."""

from __future__ import annotations

import numpy as np

from sarproc.dsp.rangecomp import replica_fft_size, replica_spectrum
from sarproc.product import fft as sfft
from sarproc.product.metadata import C, RadarMetadata
from sarproc.product.sorted_values import median

APERTURE_CHIRP_NOTE = (
    "a target seen over a finite (beam-limited) aperture focuses to its aperture's sinc times "
    "exp(j pi K_a (x - x0)^2) about its own peak, K_a = 2 / (lambda r): azimuth_chirp_times_range = 2 / lambda "
    "(1/m), K_a = value / r (the magnitude is the sinc's; the phase matters to a neighbour's side lobes)"
)


def chirp_attrs(radar: RadarMetadata, note: str = APERTURE_CHIRP_NOTE) -> dict:
    """The azimuth chirp every response carries, K_a = 2 / (lambda r)."""
    return {"azimuth_chirp_times_range": 2.0 / radar.wavelength, "azimuth_chirp_note": note}


def period_attrs(radar: RadarMetadata, rx_offset: np.ndarray) -> dict:
    """A uniform array's elevation response is its array factor, periodic in sin(theta) with period lambda / d:
    recorded so that evaluate's neighbour models follow it (a sinc departs from it by 20 % nine nulls out
    with 28 receivers). Empty for a non-uniform (or single-receiver) layout."""
    v = np.sort(np.asarray(rx_offset, float).reshape(-1, 3)[:, 1])
    s = np.diff(v)
    if len(s) == 0 or np.any(s <= 0):
        return {}
    d = median(s)
    if not np.allclose(s, d, rtol=1e-6, atol=1e-12):
        return {}
    return {
        "elevation_period": radar.wavelength / d,
        "elevation_period_note": (
            "uniform receivers: the elevation response is the array factor sin(pi q) / (N sin(pi q / N)), q in "
            "nulls lambda / (N d), periodic in sin(theta) with period lambda / d (rad near nadir)"
        ),
    }


RANGE_TABLE_OVERSAMPLING = 32  # table points per range sample (linear interpolation: 2e-4 of the peak)
RANGE_TABLE_SAMPLES = 40  # half-width of the table, range samples (a chip reaches 10 + 2 nulls, 15 samples)


def range_response(radar: RadarMetadata, n_range: int, kind: str) -> tuple[np.ndarray, float]:
    """The range response of a point target after range compression (filter ``kind``), tabulated: (values, step
    in m), real, centred on the peak (1 there), RANGE_TABLE_OVERSAMPLING points per sample over
    +-RANGE_TABLE_SAMPLES samples. Matched: the chirp's autocorrelation, whose far side lobes are not a sinc's
    (the 1 us, 375 MHz chirp of paper 004: -31...-35 dB of the peak 10-18 samples out, where the sinc has nulls);
    flat: the rect's sinc."""
    n_fft = replica_fft_size(radar, n_range)
    spec_h = replica_spectrum(radar, n_fft)
    if kind == "matched":
        weight = np.abs(spec_h) ** 2
    else:
        weight = (np.abs(sfft.fftfreq(n_fft, 1.0 / radar.range_sampling_rate)) <= radar.bandwidth / 2).astype(float)
    k = sfft.fftfreq(n_fft)  # cycles per range sample
    m = np.arange(-RANGE_TABLE_SAMPLES * RANGE_TABLE_OVERSAMPLING, RANGE_TABLE_SAMPLES * RANGE_TABLE_OVERSAMPLING + 1)
    x = m / RANGE_TABLE_OVERSAMPLING  # range samples
    r = np.cos(2 * np.pi * np.outer(x, k)) @ weight  # the spectrum's even part (its odd part is 1e-5 of the peak)
    step = C / (2 * radar.range_sampling_rate) / RANGE_TABLE_OVERSAMPLING
    return r / r[len(x) // 2], step


def range_response_attrs(radar: RadarMetadata, n_range: int, kind: str) -> dict:
    """The range response (:func:`range_response`) as image attributes, for evaluate's neighbour models."""
    values, step = range_response(radar, n_range, kind)
    return {
        "range_response": [float(v) for v in values],
        "range_response_step": step,
        "range_response_note": (
            f"a point target's range response after range compression ({kind} filter), real, "
            "centred on its peak (1 there), every range_response_step m"
        ),
    }
