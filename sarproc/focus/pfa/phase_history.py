"""Range compression and motion compensation to a reference point, varied gate included (Nie 2016, eq. 3).

The raw pulse ``n`` was recorded from absolute fast time ``range_time[0] + gate(n)`` on (the
``range_gate`` effect stores ``gate(n) = 2 n(t) p_r / c`` in aux ``range_gate_offset``). After
range compression its spectrum, taken with respect to the pulse's own time axis, is

    X(t, f_r) = exp(-j 2 pi f_r (2 r_p / c - gate - tau_0)) exp(-j 4 pi f_c r_p / c)

and the compensation of eq. (3) multiplies by

    phi(t, f_r) = exp(+j 2 pi f_r (2 r_0(t) / c - gate(t) - tau_0)) exp(+j 4 pi f_c r_0(t) / c),

so the gate, a per-pulse delay, is removed inside the same phase ramp that moves the reference
point to zero delay: nothing is padded back to a fixed gate. The result is eq. (4),

    S(t, f_r) = exp{j 4 pi (f_c + f_r) [r_0(t) - r_p(t)] / c},  |f_r| <= B / 2,

kept only over the band (complex64, float64 phases). The recorded window's delays relative to
the reference after compensation are kept per pulse (``delay_center``, ``delay_span``): the
range interpolation of the polar format centres on them (the spectrum as a signal in f_r is
then a baseband one).
"""

from __future__ import annotations

import dataclasses
import math
from typing import TYPE_CHECKING

import numpy as np

from sarproc.dsp.phasor import unit_phasor
from sarproc.dsp.rangecomp import range_compress
from sarproc.product import fft as sfft
from sarproc.product.metadata import C, RadarMetadata

if TYPE_CHECKING:
    from typing import Any

    import numpy.typing as npt


@dataclasses.dataclass(frozen=True)
class PhaseHistory:
    """Motion-compensated signal S(t, f_r) of eq. (4) on a polar raster.

    data: (n_pulses, n_freq) complex64; freqs: (n_freq,) baseband f_r, uniform ascending, Hz;
    positions: (n_pulses, 3) antenna phase centres, m; reference: (3,) point at zero phase, m;
    times: (n_pulses,) s; delay_center / delay_span: (n_pulses,) s, centre and width of the
    recorded window's delays relative to the reference (the signal's support in time).
    """

    data: np.ndarray
    freqs: np.ndarray
    carrier_frequency: float
    positions: np.ndarray
    reference: np.ndarray
    times: np.ndarray
    delay_center: np.ndarray
    delay_span: np.ndarray

    @property
    def freq_step(self) -> float:
        return float(self.freqs[1] - self.freqs[0]) if len(self.freqs) > 1 else 1.0

    def replace(self, **changes: Any) -> PhaseHistory:
        return dataclasses.replace(self, **changes)


def reference_ranges(positions: np.ndarray, point: npt.ArrayLike) -> np.ndarray:
    """|P(t) - point| (n_pulses,), m, float64."""
    return np.linalg.norm(np.asarray(positions, float) - np.asarray(point, float).reshape(1, 3), axis=1)


def compensate(
    signal: np.ndarray,
    range_time: np.ndarray,
    positions: np.ndarray,
    radar: RadarMetadata,
    reference: npt.ArrayLike,
    gate_offset: np.ndarray | None = None,
    times: np.ndarray | None = None,
    *,
    range_window: str = "none",
    range_oversampling: float = 2.0,
    block_pulses: int = 256,
    workers: int = -1,
) -> PhaseHistory:
    """Range-compress raw pulses and compensate them to ``reference`` (eqs. 3-4).

    signal: (n_pulses, n_range) complex raw echoes; range_time: (n_range,) s, uniform;
    positions: (n_pulses, 3) antenna phase centres, m; gate_offset: (n_pulses,) s or None (fixed
    gate); ``range_oversampling``: FFT length over recorded window length, so the band is
    sampled finer than its time support needs (>= 1.5 for accurate polar interpolation).
    Processes ``block_pulses`` pulses at a time; returns a :class:`PhaseHistory`.
    """
    signal = np.asarray(signal)
    n_az, n_rg = signal.shape
    fs, fc = radar.range_sampling_rate, radar.carrier_frequency
    n_fft = sfft.next_fast_len(int(math.ceil(n_rg * range_oversampling)))
    f = sfft.fftfreq(n_fft, 1.0 / fs)
    keep = np.flatnonzero(np.abs(f) <= radar.bandwidth / 2)
    keep = keep[np.argsort(f[keep])]
    freqs = f[keep]
    gate = np.zeros(n_az) if gate_offset is None else np.asarray(gate_offset, float)
    r0 = reference_ranges(positions, reference)
    tau0 = float(range_time[0])
    shift = 2 * r0 / C - gate - tau0  # delay of the reference inside each pulse's window, s
    scale = np.float32(len(keep) / n_fft)  # unit echo -> unit spectrum
    out = np.empty((n_az, len(keep)), np.complex64)
    for s in range(0, n_az, block_pulses):
        e = min(s + block_pulses, n_az)
        rc = range_compress(signal[s:e], radar, range_window, workers=workers)
        spec = sfft.fft(rc, n=n_fft, axis=-1, workers=workers)[:, keep]
        # eq. (3), Nie 2016: range reference with the recorded gate n(t) p_r, and the carrier term
        cycles = freqs[None, :] * shift[s:e, None] + (2 * fc / C) * r0[s:e, None]
        cycles -= np.floor(cycles)
        spec *= unit_phasor(cycles)
        spec *= scale
        out[s:e] = spec
    window = n_rg / fs
    # recorded delays relative to the reference: [-shift, window - shift]
    centre = window / 2 - shift
    t = np.zeros(n_az) if times is None else np.asarray(times, float)
    return PhaseHistory(
        data=out,
        freqs=freqs,
        carrier_frequency=fc,
        positions=np.asarray(positions, float),
        reference=np.asarray(reference, float).reshape(3),
        times=t,
        delay_center=centre,
        delay_span=np.full(n_az, window),
    )
