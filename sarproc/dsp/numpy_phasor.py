"""Unit phasors in plain numpy: for stages that run no compiled kernel (their process then never imports
numba, ~0.2 s; docs/performance.md, "Per-process overhead"). :mod:`sarproc.dsp.phasor` re-exports it."""

from __future__ import annotations

import numpy as np

_TWO_PI32 = np.float32(2 * np.pi)


def unit_phasor(cycles: np.ndarray) -> np.ndarray:
    """exp(j 2 pi cycles) as complex64 for cycles already reduced to [0, 1) (or any unit interval).

    The float64 phase is reduced to cycles by the caller (that is where float64 matters: 4 pi R / lambda
    reaches 1e8 rad); the reduced value is then carried in float32 and float32 cos/sin write straight
    into the output: error below 1e-6 rad, several times faster than numpy's complex exponential.
    """
    ph = np.array(cycles, dtype=np.float32)
    ph *= _TWO_PI32
    out = np.empty(ph.shape, np.complex64)
    np.cos(ph, out=out.real)
    np.sin(ph, out=out.imag)
    return out
