"""The echo kernels (:mod:`sarproc.simulation.echo_kernel`) compiled ahead of time, for small simulations.

A small scene's echoes (the demo: ~1e8 target-samples) take a few hundredths of a second serially, less than
numba's start-up (~0.3 s a process); such a simulation runs the kernels compiled ahead of time
(:mod:`sarproc.product.aot`, serial: prange as range) without importing numba, once the module is built (in
the background, on the first small run). Pulses are independent rows and each sums its targets in order, so the
echoes equal numba's bit for bit (tested in tests/product/test_aot_kernels.py). They did not while the builder
wrote its own compiles of the kernels' callees into numba's cache (1 ulp, 2.9e-15 relative in complex128); it
now builds with a private cache (:func:`sarproc.product.aot.private_numba_cache`). Importing this module imports
no numba.
"""

from __future__ import annotations

import math
from types import ModuleType

import numpy as np

from sarproc.product.aot import Kernels

_ACCUMULATE = (
    "(c8[:, ::1], f8[:, ::1], c16[:, ::1], f8[::1], f8, f8, f8, f8, f8, c16[::1])",
    "(c16[:, ::1], f8[:, ::1], c16[:, ::1], f8[::1], f8, f8, f8, f8, f8, c16[::1])",
)
ECHO = Kernels(
    name="echo",
    module="sarproc.simulation.echo_kernel",
    sources=("simulation/echo_kernel.py", "simulation/echo_aot.py"),
    exports={
        "window_chirp": "c16[::1](i8, f8, f8)",
        "_accumulate_echoes": "void" + _ACCUMULATE[0],
        "accumulate_echoes_c16": ("_accumulate_echoes", "void" + _ACCUMULATE[1]),
    },
    owner="sarproc.simulation.echo_aot:ECHO",
    slp=True,
)
# Serial target-samples (one pulse, one target, one window sample) per second of the echo kernel: an estimate,
# not a measurement (docs/performance.md, fifth round).
SERIAL_RATE = 4e8


def kernels(target_samples: float) -> ModuleType:
    """The module to run a simulation of ``target_samples`` (pulses x targets x samples per pulse, all channels)
    with: the compiled one where that pays and it is built, else numba's (:meth:`Kernels.pick`)."""
    return ECHO.pick(target_samples / SERIAL_RATE)


def window_chirp(k: ModuleType, n_range: int, fs: float, chirp_rate: float) -> np.ndarray:
    """:func:`sarproc.simulation.echo_kernel.window_chirp` from module ``k`` (from :func:`kernels`)."""
    return k.window_chirp(int(n_range), float(fs), float(chirp_rate))


def accumulate_echoes(k: ModuleType, out: np.ndarray, *args: object) -> None:
    """:func:`sarproc.simulation.echo_kernel.accumulate_echoes` from module ``k`` (same arguments; ``out``
    C-contiguous complex64 or complex128, the others as echo_block passes them)."""
    if not ECHO.is_compiled(k):
        k.accumulate_echoes(out, *args)
    elif out.dtype == np.complex64:
        k._accumulate_echoes(out, *args)
    else:
        k.accumulate_echoes_c16(out, *args)


# Band-limited echoes (simulation.waveform: band_limited). The transmitted pulse is the sampled chirp
# (the processor's replica h_m) reconstructed by a DAC filter P that passes |f| <= B/2 flat and rejects
# |f| >= f_s - B/2, so an echo delayed by tau samples as e_n = sum_m h_m p(n - m - tau f_s): the echoes
# of a pulse are the replica convolved with each target's fractional-delay kernel p(j - delta). p is a
# Kaiser-windowed sinc (cutoff f_s/2, so p(j) = [j == 0]: an echo on a sample is the replica itself),
# designed for BAND_LIMITED_REJECTION_DB of stopband and passband ripple over that transition band.
BAND_LIMITED_REJECTION_DB = 120.0
# Points a sample of the tabulated Kaiser window: linear interpolation between them is within 2.3e-9 of the
# window (at 1.2 B sampling; 9e-9 at 512, 3.6e-8 at 256), some 40 dB under the filter's 120 dB.
KAISER_PER_SAMPLE = 1024


def kaiser_design(fs: float, bandwidth: float, rejection_db: float = BAND_LIMITED_REJECTION_DB) -> tuple[int, float]:
    """(half_taps J, Kaiser beta) of the fractional-delay kernel: the transition band runs from B/2 to
    f_s - B/2 (fraction (f_s - B) / f_s of the sampling rate); Kaiser's formulas for ``rejection_db``."""
    transition = (fs - bandwidth) / fs
    if transition <= 0:
        raise ValueError("a band-limited echo needs a sampling rate above the bandwidth")
    beta = 0.1102 * (rejection_db - 8.7)
    length = (rejection_db - 7.95) / (2.285 * 2 * math.pi * transition)
    return int(math.ceil(length / 2)) + 1, beta


def kaiser_table(half_taps: int, beta: float, per_sample: int = KAISER_PER_SAMPLE) -> np.ndarray:
    """The Kaiser window I0(beta sqrt(1 - (t/J)^2)) / I0(beta) at t = -J + i / per_sample, i = 0 .. 2 J per_sample
    (float64, both edges included)."""
    t = np.arange(-half_taps * per_sample, half_taps * per_sample + 1) / per_sample
    r2 = np.minimum((t / half_taps) ** 2, 1.0)
    return np.i0(beta * np.sqrt(1.0 - r2)) / np.i0(beta)


# The band-limited kernel's own module: built by the background builder's command, apart from ECHO (whose
# complex128 export equals numba's bit for bit only as built today: tests/product/test_aot_kernels.py).
IMPULSES = Kernels(
    name="impulses",
    module="sarproc.simulation.echo_kernel",
    sources=("simulation/echo_kernel.py", "simulation/echo_aot.py"),
    exports={
        "accumulate_impulses": "void(c16[:, ::1], f8[:, ::1], c16[:, ::1], f8[::1], f8, f8, f8, i8, f8[::1], f8, f8)"
    },
    owner="sarproc.simulation.echo_aot:IMPULSES",
)
# Serial kernel taps (one pulse, one target, one tap) per second: an estimate, as SERIAL_RATE.
SERIAL_TAP_RATE = 1e8


def impulse_kernels(taps: float) -> ModuleType:
    """The module to run ``taps`` (pulses x targets x kernel taps) of :func:`accumulate_impulses` with: the compiled
    one where that pays and it is built, else numba's (:meth:`Kernels.pick`)."""
    return IMPULSES.pick(taps / SERIAL_TAP_RATE)


def accumulate_impulses(k: ModuleType, out: np.ndarray, *args: object) -> None:
    """:func:`sarproc.simulation.echo_kernel.accumulate_impulses` from module ``k`` (from :func:`impulse_kernels`;
    same arguments, ``out`` C-contiguous complex128)."""
    k.accumulate_impulses(out, *args)
