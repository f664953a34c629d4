"""Doppler-centroid correction before the azimuth deramp (An et al. 2012, sec. 3.1).

Slant-plane model of paper 000 (fig. 1): the platform flies along x at speed v, theta is the
squint of the line of sight to the scene centre at the aperture centre, and a target at
(x_n, r_0) of the squint frame has range r(t) of eq. (1). Squint puts a Doppler centroid
2 (f_c + f_r) v sin(theta) / c into the echo (eq. 6, 2nd and 3rd terms); with PRF below the
total bandwidth this centroid line folds, and the folded parts are what break the coarse
focusing (sec. 2.2). Three corrections, multiplied in the (range-frequency, azimuth-time)
domain:

  nonlinear  eq. (7): exp(-j 4 pi (f_c + f_r) v sin(theta) t / c); removes the centroid and its
             range-frequency dependence (a linear range-walk correction to the aperture centre).
  linear     method 1 (Lanari 2001): exp(-j 4 pi f_c v sin(theta) t / c) only.
  none       the original two-step approach (no correction).

Input and output are (azimuth_time, range_time) signals; output complex64, phases float64.
"""

from __future__ import annotations

import dataclasses
import math
from typing import TYPE_CHECKING

import numpy as np

from sarproc.product import fft as sfft
from sarproc.product.config import as_dict, param
from sarproc.product.errors import InputError
from sarproc.product.metadata import C, RadarMetadata
from sarproc.product.model import Product

if TYPE_CHECKING:
    from sarproc.product.steps import ProgressFactory

METHODS = ("nonlinear", "linear", "none")
PRECISIONS = ("float32", "float64")


@dataclasses.dataclass(frozen=True)
class PreprocessParams:
    """``preprocess:`` section."""

    method: str = param(
        default="nonlinear", choices=METHODS, doc="nonlinear (eq. 7), linear (method 1) or none (original two-step)"
    )
    precision: str = param(
        default="float32", choices=PRECISIONS, doc="intermediate complex precision (phases are always float64)"
    )
    block_pulses: int = param(default=512, ge=1, doc="pulses per FFT block (memory bound)")


def complex_dtype(precision: str) -> type[np.complexfloating]:
    return np.complex64 if precision == "float32" else np.complex128


def correction_frequency(radar: RadarMetadata, f_r: np.ndarray, method: str) -> np.ndarray:
    """beta(f_r), Hz: the correction multiplies the echo by exp(j 2 pi beta t)."""
    v_s = radar.velocity * math.sin(radar.squint)
    if method == "nonlinear":
        return -2.0 * (radar.carrier_frequency + np.asarray(f_r, float)) * v_s / C  # eq. (7)
    if method == "linear":
        return np.full(np.shape(f_r), -2.0 * radar.carrier_frequency * v_s / C)
    if method == "none":
        return np.zeros(np.shape(f_r))
    raise InputError(f"preprocess.method: {method!r} is not one of {list(METHODS)}")


def doppler_correction(
    signal: np.ndarray,
    azimuth_time: np.ndarray,
    radar: RadarMetadata,
    method: str = "nonlinear",
    precision: str = "float64",
    block_pulses: int = 512,
    progress: ProgressFactory | None = None,
) -> np.ndarray:
    """Apply the Doppler-centroid correction to ``signal`` (n_az, n_rg); returns a new complex64 array."""
    if signal.ndim != 2 or signal.shape[0] != len(azimuth_time):
        raise InputError(f"preprocess: signal shape {signal.shape} does not match {len(azimuth_time)} pulses")
    cdt = complex_dtype(precision)
    out = np.empty(signal.shape, np.complex64)
    n_rg = signal.shape[1]
    t = np.asarray(azimuth_time, float)
    if method == "none":
        out[...] = signal
        return out
    if method == "linear":
        beta = correction_frequency(radar, np.zeros(1), method)[0]
        out[...] = signal * np.exp(2j * np.pi * beta * t)[:, None].astype(cdt)
        return out
    # numba (~0.2 s to import) only where the correction runs: coarse-focus imports this module's constants
    from sarproc.dsp.phasor import multiply_separable_phase

    # FFT length from next_fast_len (6483 = 3 x 2161 samples took 3.4x longer than 6561); the correction is a
    # range shift, so the padding also keeps a little of what walks past the window's end from wrapping around
    n_fft = sfft.next_fast_len(n_rg)
    f_r = sfft.fftfreq(n_fft, 1.0 / radar.range_sampling_rate)
    beta = correction_frequency(radar, f_r, method)
    starts = range(0, len(t), block_pulses)
    for s in progress(starts) if progress is not None else starts:
        e = min(s + block_pulses, len(t))
        spec = sfft.fft(signal[s:e].astype(cdt), n=n_fft, axis=1, workers=-1)
        # float64 cycles beta t (they reach 2e5), summed and turned into phasors inside one compiled loop
        multiply_separable_phase(spec, [t[s:e]], [beta], cycles=True)
        out[s:e] = sfft.ifft(spec, axis=1, workers=-1, overwrite_x=True)[:, :n_rg]
    return out


def check_fixed_gate(raw: Product) -> None:
    """Refuse a raw product whose receive gate moves (aux ``range_gate_offset``, paper 002's varied gate, the
    Gotcha import): the chain's range axis is one fixed gate, and a moving one defocused silently."""
    gate = np.asarray(raw.aux.get("range_gate_offset", np.zeros(1)), float)
    if np.ptp(gate) > 0:
        span = np.ptp(gate) * C / 2
        raise InputError(
            f"preprocess: aux/range_gate_offset: the receive gate moves over {span:.3g} m of slant range during "
            "the acquisition; the paper 000 chain assumes a fixed gate (sarproc pfa2 or sarproc backproject focus it)"
        )


def preprocess(
    raw: Product, params: PreprocessParams = PreprocessParams(), progress: ProgressFactory | None = None
) -> Product:
    """Raw product -> ``preprocessed`` product (same axes), with the correction recorded in attrs."""
    from sarproc.product.io import history_entry

    if raw.kind != "raw":
        raise InputError(f"preprocess needs a single-channel 'raw' product, got {raw.kind!r}")
    if tuple(raw.dims) != ("azimuth_time", "range_time"):
        raise InputError(f"preprocess: raw dims {raw.dims} must be ('azimuth_time', 'range_time')")
    check_fixed_gate(raw)
    data = doppler_correction(
        raw.data, raw.coords["azimuth_time"], raw.radar, params.method, params.precision, params.block_pulses, progress
    )
    attrs = dict(raw.attrs)
    attrs["doppler_correction"] = params.method
    out = raw.derive("preprocessed", data, raw.dims, raw.coords, attrs=attrs)
    out.history.append(history_entry("preprocess", as_dict(params)))
    return out
