"""Azimuth deramp of the squint Doppler history, and range (de)compression by the chirp's phase.

A stripmap target seen at squint theta has its Doppler band centred on
f_dc(f_r) = 2 v sin(theta) (f_c + f_r) / c at range frequency f_r: many PRFs away from zero
(the first spectral fold) and tilted across the range band by 2 v sin(theta) B / c (the second
fold: no single band centre fits every range frequency). Paper 003 removes this Doppler history
before the multichannel reconstruction; we do it exactly in the (range frequency, azimuth time)
domain, channel by channel, on the channel's equivalent monostatic time t + tau_n:

    D_n(f_r, t) = exp(-j 2 pi f_dc(f_r) (t + tau_n))                         (deramp)
    D^-1(f_r, t') = exp(+j 2 pi f_dc(f_r) t')                                 (inverse, output grid)

Being linear in f_r, D is also the linear range-walk correction (a shift of every echo by
2 v sin(theta) t / c): after it each target stays in a few range cells, which lets the
processor cut a moving target out by range. Static targets then have Doppler bands centred on
zero at every range frequency. Range compression uses the chirp's stationary-phase spectrum,
exp(+j pi f_r^2 / K): unit modulus, so decompression exp(-j pi f_r^2 / K) restores the raw
echoes exactly and ``backproject`` compresses the output as it would any raw product.
"""

from __future__ import annotations

import math

import numpy as np

from sarproc.dsp.numpy_phasor import unit_phasor
from sarproc.product.metadata import C


def _phasor(cycles: np.ndarray) -> np.ndarray:
    cycles = np.asarray(cycles, float)
    return unit_phasor(cycles - np.floor(cycles))


def squint_doppler(range_frequency: np.ndarray, velocity: float, squint: float, carrier_frequency: float) -> np.ndarray:
    """f_dc(f_r) = 2 v sin(theta) (f_c + f_r) / c, Hz."""
    return 2.0 * velocity * math.sin(squint) * (carrier_frequency + np.asarray(range_frequency, float)) / C


def deramp_phasor(
    times: np.ndarray,
    range_frequency: np.ndarray,
    velocity: float,
    squint: float,
    carrier_frequency: float,
    sign: int = -1,
) -> np.ndarray:
    """(n_t, n_f) complex64 exp(sign j 2 pi f_dc(f_r) t): sign -1 deramps, +1 restores."""
    fdc = squint_doppler(range_frequency, velocity, squint, carrier_frequency)
    return _phasor(sign * np.asarray(times, float)[:, None] * fdc[None, :])


def doppler_shift_phasor(
    times: np.ndarray, range_frequency: np.ndarray, los_velocity: float, carrier_frequency: float, sign: int = -1
) -> np.ndarray:
    """(n_t, n_f) exp(sign j 2 pi f_v(f_r) t), f_v = -2 v_los (f_c + f_r) / c: a moving target's Doppler offset."""
    fv = -2.0 * los_velocity * (carrier_frequency + np.asarray(range_frequency, float)) / C
    return _phasor(sign * np.asarray(times, float)[:, None] * fv[None, :])


def path_phasor(range_frequency: np.ndarray, path: np.ndarray | float, carrier_frequency: float) -> np.ndarray:
    """(n_f,) exp(+j 2 pi (f_c + f_r) path / c): removes an extra one-way-equivalent path ``path`` (m)."""
    return _phasor((carrier_frequency + np.asarray(range_frequency, float)) * path / C)


def compression_phasor(range_frequency: np.ndarray, chirp_rate: float, sign: int = +1) -> np.ndarray:
    """exp(sign j pi f_r^2 / K): +1 compresses a chirp exp(j pi K tau^2), -1 re-expands it."""
    f = np.asarray(range_frequency, float)
    return _phasor(sign * 0.5 * f**2 / chirp_rate)


def quadratic_phasor(
    times: np.ndarray, range_frequency: np.ndarray, acceleration: float, t_center: float, carrier_frequency: float
) -> np.ndarray:
    """(n_t, n_f) exp(+j 2 pi (f_c + f_r) a (t - t_c)^2 / c): removes a range history 0.5 a (t - t_c)^2 (two-way)."""
    dt2 = (np.asarray(times, float) - t_center) ** 2
    return _phasor(
        dt2[:, None] * (acceleration * (carrier_frequency + np.asarray(range_frequency, float)) / C)[None, :]
    )
