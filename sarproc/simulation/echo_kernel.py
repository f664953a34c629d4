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

from sarproc.dsp.kernel_cache import CACHE, lean_cache_loads, slp_vectorized


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


@numba.njit(inline="always")
def _echo_start(
    tau: float, rel: float, fs: float, chirp_rate: float, carrier: float, first: int
) -> tuple[complex, complex, complex]:
    """A target's echo over the window as a geometric series (module docstring): its phasor at sample ``first``
    without the gain, the step w between samples and w^8."""
    step_cycles = -chirp_rate * rel / fs
    base = 0.5 * chirp_rate * rel * rel - carrier * tau
    return _cis(base + first * step_cycles), _cis(step_cycles), _cis(8 * step_cycles)


@numba.njit(inline="always")
def _add_series(
    acc_re: np.ndarray, acc_im: np.ndarray, p: complex, w: complex, w8: complex, first: int, last: int
) -> None:
    """Add p w^(n - first) to acc at samples first .. last (float64 real and imaginary sums apart)."""
    wr, wi = w8.real, w8.imag
    # eight recurrences (samples n .. n + 7, each stepped by w^8), written out as scalars so that the
    # SLP vectoriser packs them; unsigned indices spare numba's negative-index wrap-around
    r0, i0 = p.real, p.imag
    p *= w
    r1, i1 = p.real, p.imag
    p *= w
    r2, i2 = p.real, p.imag
    p *= w
    r3, i3 = p.real, p.imag
    p *= w
    r4, i4 = p.real, p.imag
    p *= w
    r5, i5 = p.real, p.imag
    p *= w
    r6, i6 = p.real, p.imag
    p *= w
    r7, i7 = p.real, p.imag
    n = numba.uint64(first)
    end = numba.uint64(last + 1)
    while n + numba.uint64(8) <= end:
        acc_re[n] += r0
        acc_re[n + numba.uint64(1)] += r1
        acc_re[n + numba.uint64(2)] += r2
        acc_re[n + numba.uint64(3)] += r3
        acc_re[n + numba.uint64(4)] += r4
        acc_re[n + numba.uint64(5)] += r5
        acc_re[n + numba.uint64(6)] += r6
        acc_re[n + numba.uint64(7)] += r7
        acc_im[n] += i0
        acc_im[n + numba.uint64(1)] += i1
        acc_im[n + numba.uint64(2)] += i2
        acc_im[n + numba.uint64(3)] += i3
        acc_im[n + numba.uint64(4)] += i4
        acc_im[n + numba.uint64(5)] += i5
        acc_im[n + numba.uint64(6)] += i6
        acc_im[n + numba.uint64(7)] += i7
        r0, i0 = r0 * wr - i0 * wi, r0 * wi + i0 * wr
        r1, i1 = r1 * wr - i1 * wi, r1 * wi + i1 * wr
        r2, i2 = r2 * wr - i2 * wi, r2 * wi + i2 * wr
        r3, i3 = r3 * wr - i3 * wi, r3 * wi + i3 * wr
        r4, i4 = r4 * wr - i4 * wi, r4 * wi + i4 * wr
        r5, i5 = r5 * wr - i5 * wi, r5 * wi + i5 * wr
        r6, i6 = r6 * wr - i6 * wi, r6 * wi + i6 * wr
        r7, i7 = r7 * wr - i7 * wi, r7 * wi + i7 * wr
        n += numba.uint64(8)
    rest = end - n  # 0 .. 7 samples left: lane k holds sample n + k
    if rest > 0:
        acc_re[n] += r0
        acc_im[n] += i0
    if rest > 1:
        acc_re[n + numba.uint64(1)] += r1
        acc_im[n + numba.uint64(1)] += i1
    if rest > 2:
        acc_re[n + numba.uint64(2)] += r2
        acc_im[n + numba.uint64(2)] += i2
    if rest > 3:
        acc_re[n + numba.uint64(3)] += r3
        acc_im[n + numba.uint64(3)] += i3
    if rest > 4:
        acc_re[n + numba.uint64(4)] += r4
        acc_im[n + numba.uint64(4)] += i4
    if rest > 5:
        acc_re[n + numba.uint64(5)] += r5
        acc_im[n + numba.uint64(5)] += i5
    if rest > 6:
        acc_re[n + numba.uint64(6)] += r6
        acc_im[n + numba.uint64(6)] += i6


@numba.njit(parallel=True, nogil=True, cache=CACHE, error_model="numpy")
def _accumulate_echoes(
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
    """:func:`accumulate_echoes`'s kernel; compiled with LLVM's SLP vectoriser (see there)."""
    n_t, n_tg = delays.shape
    n_range = out.shape[1]
    half = 0.5 * pulse_duration
    for i in numba.prange(n_t):
        row = out[i]
        # real and imaginary sums apart: eight consecutive samples are one vector load, add and store each
        acc_re = np.zeros(n_range, np.float64)
        acc_im = np.zeros(n_range, np.float64)
        for j in range(n_tg):
            g = gains[i, j]
            if g == 0:
                continue
            tau = delays[i, j]
            rel = tau - gate[i] - t0
            first, last = _support(rel, fs, half, n_range)
            if last < first:
                continue
            p, w, w8 = _echo_start(tau, rel, fs, chirp_rate, carrier, first)
            _add_series(acc_re, acc_im, g * p, w, w8, first, last)
        for n in range(n_range):
            row[n] += complex(acc_re[n], acc_im[n]) * chirp[n]


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

    The kernel is compiled (or loaded from the cache, where it was compiled so) with LLVM's SLP vectoriser,
    which numba leaves off by default (``NUMBA_SLP_VECTORIZE``): it packs the eight recurrences into vector
    registers, 2-2.5x fewer CPU seconds than scalar code. It changes no arithmetic (no fast-math: the same
    IEEE operations, packed), so the echoes are those of the scalar kernel bit for bit.
    """
    with slp_vectorized():
        _accumulate_echoes(out, delays, gains, gate, t0, fs, pulse_duration, chirp_rate, carrier, chirp)


# Band-limited echoes (simulation.waveform: band_limited): the design of the fractional-delay kernel p and its
# tabulated Kaiser window are in the numba-free :mod:`sarproc.simulation.echo_aot`.


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
    window: np.ndarray,
    per_sample: float,
    offset: float,
) -> None:
    """Add every target's fractional-delay kernel g exp(-j 2 pi f_c tau) p(i - offset - rel f_s) to ``out``
    (n_t, n_ext) complex128, in place; ``out`` sample i is window sample i - ``offset`` (the window extended by
    the replica's half length and the kernel's), rel = tau - gate - t0. p(t) = sinc(t) w(t), the Kaiser window
    w tabulated at ``per_sample`` points a sample over [-J, J] (``window``, echo_aot.kaiser_table) and
    interpolated linearly: a Bessel series per tap cost 5x the continuous chirp's samples. Other arguments as
    accumulate_echoes."""
    n_t, n_tg = delays.shape
    n_ext = out.shape[1]
    last = window.shape[0] - 1
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
                u = (t + half_taps) * per_sample
                m = int(u)  # u > 0: t > -J
                if m >= last:  # t = J: p(J) = 0 (the window's edge, where the Bessel kernel stopped too)
                    continue
                w = window[m] + (u - m) * (window[m + 1] - window[m])
                # sinc(t) = sin(pi (k - delta)) / (pi t) = (-1)^(k+1) sin(pi delta) / (pi t)
                p = w if abs(t) < 1e-12 else (s if k % 2 else -s) / (math.pi * t) * w
                row[int(n)] += a * p


lean_cache_loads(globals())  # cached kernels load without numba's context refresh (kernel_cache)
