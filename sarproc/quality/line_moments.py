"""A 3D chip's trigonometric interpolant along a line close to one image axis, by moments of its spectrum.

On the line ``x0 + t v`` (``v[a] = 1``, the other components small: a cut along a response's principal axis)
the interpolant is sum_k c_k exp(2 pi i t (f_a,k + eps_k)), eps_k = sum_(b != a) f_b,k v_b. Across the cut
(|t - t_c| <= R) the off-axis part exp(2 pi i (t - t_c) eps_k) turns by at most w = 2 pi R max|eps - eps_c|
radians, a fraction of a turn for a nearly axis-aligned cut, so its Taylor series in (t - t_c) / R converges
in about twenty terms: the sum becomes P moments of the spectrum over the other axes (one matrix product) and
P sums of n_a terms along axis a. That costs chip size x P multiply-adds, against chip size x 17 kernel
evaluations (an exponential and a square root each) of the non-uniform FFT
(:func:`sarproc.quality.linesum.exponential_sums`); the truncation is bounded, and kept below 1e-16 of the
terms' sum (the NUFFT's own error is 1e-14).
"""

from __future__ import annotations

import functools
import math

import numpy as np

_TOL = 1e-16  # truncation bound relative to sum |c_k|
MAX_TURN = 6.0  # rad: w beyond this (a steep cut) is left to the NUFFT; the terms grow to exp(w) before they fall


def series_length(w: float) -> int:
    """Taylor terms P with w^P / P! exp(w) below _TOL (the tail of exp(i w s eta), |s|, |eta| <= 1)."""
    p, term = 0, math.exp(w)
    while term >= _TOL:
        p += 1
        term *= w / p
    return max(p, 1)


def line_sums(
    spec: np.ndarray, freqs: list, x0: np.ndarray, v: np.ndarray, first: float, step: float, count: int
) -> np.ndarray | None:
    """sum_k spec[k] exp(2 pi i f_k . (x0 + t_j v)), t_j = first + j step (j < count), f_k the outer grid of
    ``freqs`` (cycles per sample per axis): a chip's interpolant on the line times its size. None where the
    line is too far from every image axis for the series (the caller takes the NUFFT)."""
    ndim = spec.ndim
    a = int(np.argmax(np.abs(v)))
    half = 0.5 * (count - 1) * step  # R
    centre = first + half  # t_c
    eps: np.ndarray = np.zeros(())
    for b in range(ndim):
        eps = np.add.outer(eps, freqs[b] * v[b] if b != a else np.zeros(1))
    eps = eps.reshape(-1)  # over the other axes (axis a's slot has one entry)
    mid = 0.5 * (eps.max() + eps.min())
    spread = 0.5 * (eps.max() - eps.min())
    w = 2 * math.pi * half * spread
    if w > MAX_TURN:
        return None
    p_max = series_length(w)
    # c_k = spec_k exp(2 pi i f_k . (x0 + t_c v)) is spec_k times one factor per axis: the other axes' factors
    # go into the powers (others x P, small) and axis a's onto the moments, so the spectrum is read once, by the
    # one matrix product (three products over the whole spectrum and the real and imaginary copies were 2/3 of
    # the time; the same sums to rounding)
    factor = [np.exp(2j * np.pi * freqs[b] * (x0[b] + centre * v[b])) for b in range(ndim)]
    others = functools.reduce(np.multiply.outer, [factor[b] for b in range(ndim) if b != a]).reshape(-1)
    eta = (eps - mid) / spread if spread > 0 else np.zeros_like(eps)
    powers = np.vander(eta, p_max, increasing=True) * others[:, None]  # (others, P): eta^p times the phase
    moments = (np.moveaxis(spec, a, 0).reshape(spec.shape[a], -1) @ powers) * factor[a][:, None]  # (n_a, P)
    tau = step * (np.arange(count) - 0.5 * (count - 1))  # t_j - t_c, symmetric about 0
    along = _phases(tau, freqs[a]) @ moments  # (count, P)
    s = tau / half if half > 0 else np.zeros(count)
    # sum_p (i w)^p / p! s^p along[:, p], by Horner in s
    scale = [complex(1.0)]
    for p in range(1, p_max):
        scale.append(scale[-1] * 1j * w / p)
    acc = scale[-1] * along[:, -1]
    for p in range(p_max - 2, -1, -1):
        acc = acc * s + scale[p] * along[:, p]
    out: np.ndarray = acc * np.exp(2j * np.pi * mid * tau)
    return out


def _phases(tau: np.ndarray, freqs: np.ndarray) -> np.ndarray:
    """exp(2 pi i tau_j f_k) (count, n) for offsets ``tau`` symmetric about 0: the cosines and sines of the half
    tau >= 0, the other half their conjugates (a complex exponential of each pair took a third of a cut's time)."""
    count = tau.size
    arg = 2 * np.pi * np.outer(tau[count // 2 :], freqs)
    half = np.empty(arg.shape, dtype=np.complex128)
    np.cos(arg, out=half.real)
    np.sin(arg, out=half.imag)
    below = half[:0:-1] if count % 2 else half[::-1]  # tau < 0: the mirror of tau > 0
    return np.concatenate([below.conj(), half])
