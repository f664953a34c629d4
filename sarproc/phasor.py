"""Fast unit phasors from float64 phase kept in cycles."""

from __future__ import annotations

import numpy as np


def unit_phasor(cycles: np.ndarray) -> np.ndarray:
    """exp(j 2 pi cycles) as complex64 for cycles already reduced to [0, 1).

    float32 cos/sin of the reduced phase are accurate to ~1e-7 rad and several times faster
    than numpy's complex exponential.
    """
    ph = (2 * np.pi * cycles).astype(np.float32)
    out = np.empty(ph.shape, np.complex64)
    out.real = np.cos(ph)
    out.imag = np.sin(ph)
    return out
