"""Compiled accumulation of point-target echoes into a block of pulses.

A target's echo on window sample n (fast time n/f_s from the window start) is

    g exp(j 2 pi [K/2 (n/f_s - rel)^2 - f_c tau]),   |n/f_s - rel| <= T_p / 2,

with rel its delay inside the window. The square splits into a chirp common to every target
and pulse, c_n = exp(j pi K n^2 / f_s^2), times a phasor linear in n,

    g exp(j 2 pi [K rel^2 / 2 - f_c tau]) w^n,   w = exp(-j 2 pi K rel / f_s),

so each target costs one complex multiply-add per sample (a geometric recurrence) instead of
a float64 phase and a cos/sin. Every phase is reduced to cycles in float64 before its cos/sin,
so the large terms (f_c tau ~ 1e6 cycles, K n^2 / 2 f_s^2 ~ 1e4) lose nothing; the recurrence
drifts by about one float64 ulp per sample (1e-12 over 4k samples), far below complex64.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from sarproc.dsp.kernel_cache import CACHE, lean_cache_loads


@numba.njit(inline="always")
def _cis(cycles: float) -> complex:
    """exp(j 2 pi cycles) for any float64 cycles, reduced to [0, 1) first."""
    frac = cycles - math.floor(cycles)
    return complex(math.cos(2 * math.pi * frac), math.sin(2 * math.pi * frac))


@numba.njit(cache=CACHE, error_model="numpy")
def window_chirp(n_range: int, fs: float, chirp_rate: float) -> np.ndarray:
    """c_n = exp(j pi K (n / f_s)^2) for the window's samples, complex128."""
    out = np.empty(n_range, np.complex128)
    for n in range(n_range):
        t = n / fs
        out[n] = _cis(0.5 * chirp_rate * t * t)
    return out


@numba.njit(inline="always")
def _support(rel: float, fs: float, half_pulse: float, n_range: int) -> tuple[int, int]:
    """First and last window sample with |n/f_s - rel| <= T_p/2 (the simulator's envelope test,
    evaluated the same way), clipped to the window; last < first when none is inside."""
    first = max(0, int(math.ceil((rel - half_pulse) * fs)) - 1)
    last = min(n_range - 1, int(math.floor((rel + half_pulse) * fs)) + 1)
    while first <= last and abs(first / fs - rel) > half_pulse:
        first += 1
    while last >= first and abs(last / fs - rel) > half_pulse:
        last -= 1
    return first, last


@numba.njit(parallel=True, nogil=True, cache=CACHE, error_model="numpy")
def accumulate_echoes(
    out: np.ndarray,
    delays: np.ndarray,
    gains: np.ndarray,
    gate: np.ndarray,
    t0: float,
    fs: float,
    pulse_duration: float,
    chirp_rate: float,
    carrier: float,
    chirp: np.ndarray,
) -> None:
    """Add every target's echo to ``out`` (n_t, n_range) complex128 or complex64, in place.

    Targets are summed in complex128 either way; a complex64 ``out`` receives each sample rounded once,
    the value a complex128 ``out`` would give after a cast. nogil: a writer thread stores the previous
    block meanwhile.

    delays (n_t, n_tg) two-way delays, s; gains (n_t, n_tg) complex (0 skips the pair); gate
    (n_t,) receive-window offsets, s; t0 the window's first range time, s; chirp from
    :func:`window_chirp` for the same window. Pulses run in parallel, targets in order.
    """
    n_t, n_tg = delays.shape
    n_range = out.shape[1]
    half = 0.5 * pulse_duration
    for i in numba.prange(n_t):
        row = out[i]
        acc = np.zeros(n_range, np.complex128)
        for j in range(n_tg):
            g = gains[i, j]
            if g == 0:
                continue
            tau = delays[i, j]
            rel = tau - gate[i] - t0
            first, last = _support(rel, fs, half, n_range)
            if last < first:
                continue
            step_cycles = -chirp_rate * rel / fs
            w = _cis(step_cycles)
            w4 = _cis(4 * step_cycles)
            base = 0.5 * chirp_rate * rel * rel - carrier * tau
            # four interleaved recurrences (samples n, n+1, n+2, n+3) keep the multiplier busy; unsigned
            # indices spare every load numba's negative-index wrap-around (-20 % of the kernel's time)
            p0 = g * _cis(base + first * step_cycles)
            p1 = g * _cis(base + (first + 1) * step_cycles)
            p2 = g * _cis(base + (first + 2) * step_cycles)
            p3 = g * _cis(base + (first + 3) * step_cycles)
            n = numba.uint64(first)
            end = numba.uint64(last + 1)
            while n + numba.uint64(4) <= end:
                acc[n] += p0
                acc[n + numba.uint64(1)] += p1
                acc[n + numba.uint64(2)] += p2
                acc[n + numba.uint64(3)] += p3
                p0 *= w4
                p1 *= w4
                p2 *= w4
                p3 *= w4
                n += numba.uint64(4)
            while n < end:
                acc[n] += p0
                p0 *= w
                n += numba.uint64(1)
        for n in range(n_range):
            row[n] += acc[n] * chirp[n]


# Band-limited echoes (simulation.waveform: band_limited). The transmitted pulse is the sampled chirp
# (the processor's replica h_m) reconstructed by a DAC filter P that passes |f| <= B/2 flat and rejects
# |f| >= f_s - B/2, so an echo delayed by tau samples as e_n = sum_m h_m p(n - m - tau f_s): the echoes
# of a pulse are the replica convolved with each target's fractional-delay kernel p(j - delta). p is a
# Kaiser-windowed sinc (cutoff f_s/2, so p(j) = [j == 0]: an echo on a sample is the replica itself),
# designed for BAND_LIMITED_REJECTION_DB of stopband and passband ripple over that transition band.
BAND_LIMITED_REJECTION_DB = 120.0


def kaiser_design(fs: float, bandwidth: float, rejection_db: float = BAND_LIMITED_REJECTION_DB) -> tuple[int, float]:
    """(half_taps J, Kaiser beta) of the fractional-delay kernel: the transition band runs from B/2 to
    f_s - B/2 (fraction (f_s - B) / f_s of the sampling rate); Kaiser's formulas for ``rejection_db``."""
    transition = (fs - bandwidth) / fs
    if transition <= 0:
        raise ValueError("a band-limited echo needs a sampling rate above the bandwidth")
    beta = 0.1102 * (rejection_db - 8.7)
    length = (rejection_db - 7.95) / (2.285 * 2 * math.pi * transition)
    return int(math.ceil(length / 2)) + 1, beta


@numba.njit(inline="always")
def _bessel_i0(x: float) -> float:
    """Modified Bessel function I_0(x) by its power series (x <= 30: terms fall below 1e-17 of the sum)."""
    term, total, k = 1.0, 1.0, 1
    q = 0.25 * x * x
    while term > 1e-17 * total:
        term *= q / (k * k)
        total += term
        k += 1
    return total


@numba.njit(parallel=True, cache=CACHE, error_model="numpy")
def accumulate_impulses(
    out: np.ndarray,
    delays: np.ndarray,
    gains: np.ndarray,
    gate: np.ndarray,
    t0: float,
    fs: float,
    carrier: float,
    half_taps: int,
    beta: float,
    offset: float,
) -> None:
    """Add every target's fractional-delay kernel g exp(-j 2 pi f_c tau) p(i - offset - rel f_s) to ``out``
    (n_t, n_ext) complex128, in place; ``out`` sample i is window sample i - ``offset`` (the window extended by
    the replica's half length and the kernel's), rel = tau - gate - t0. Arguments as accumulate_echoes."""
    n_t, n_tg = delays.shape
    n_ext = out.shape[1]
    norm = _bessel_i0(beta)
    for i in numba.prange(n_t):
        row = out[i]
        for j in range(n_tg):
            g = gains[i, j]
            if g == 0:
                continue
            tau = delays[i, j]
            x = (tau - gate[i] - t0) * fs + offset  # kernel centre, out samples
            base = math.floor(x)
            delta = x - base
            a = g * _cis(-carrier * tau)
            s = math.sin(math.pi * delta)
            for k in range(-half_taps + 1, half_taps + 1):
                n = base + k
                if n < 0 or n >= n_ext:
                    continue
                t = k - delta  # p(t): t in (-J, J]
                r = t / half_taps
                if r * r >= 1.0:
                    continue
                w = _bessel_i0(beta * math.sqrt(1.0 - r * r)) / norm
                # sinc(t) = sin(pi (k - delta)) / (pi t) = (-1)^(k+1) sin(pi delta) / (pi t)
                p = w if abs(t) < 1e-12 else (s if k % 2 else -s) / (math.pi * t) * w
                row[int(n)] += a * p


lean_cache_loads(globals())  # cached kernels load without numba's context refresh (kernel_cache)
