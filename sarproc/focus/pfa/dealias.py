"""Sliding-spotlight azimuth de-aliasing by sub-apertures (Nie 2016, sec. 3.2, Fig. 2).

After motion compensation to the scene centre O (an azimuth deramp, eq. 3) a point x sweeps
K (u(t) - u(t-1)) . x radians from pulse to pulse; over the scene these phase steps span

    w = K_max (max |du_a| W_a + max |du_r| W_r)   rad per pulse,

and the PRF is enough only if w < 2 pi (PFA's own, lowest, PRF requirement). In sliding
spotlight the beam sweeps a scene wider than its footprint, so the PRF is usually chosen for
the footprint only and the full-aperture deramped signal folds. Fig. 2's cure, done here:

1. cut the pulses into sub-apertures, short enough that the footprint barely moves, and deramp
   each to the centre q_b of its footprint, exp{-j K [r_0(t) - r_q(t)]} (exact ranges), which
   leaves it unaliased at the PRF;
2. upsample each by zero padding its azimuth spectrum (transform domain), U times;
3. re-ramp with the same function at the upsampled pulse times (antenna positions by cubic
   interpolation) and stitch: sub-apertures overlap by half and only their central halves are
   kept (the FFT's circular edges are dropped).

The result is the full-aperture signal at U x PRF, ready for one PFA. Whether the image would
fold is checked from the geometry either way, and a warning says so only when it would.
"""

from __future__ import annotations

import logging
import math
from typing import TYPE_CHECKING

import numpy as np

from sarproc.dsp.phasor import unit_phasor
from sarproc.focus.pfa.phase_history import PhaseHistory, reference_ranges
from sarproc.focus.pfa.polar import los_components, wavenumbers
from sarproc.product import beam, fft as sfft
from sarproc.product.errors import IMAGE_DEFECT, InputError
from sarproc.product.sorted_values import median
from sarproc.product.uniform_spline import UniformCubicSpline

if TYPE_CHECKING:
    import numpy.typing as npt

    from sarproc.focus.pfa.polar import Grid
    from sarproc.product.metadata import RadarMetadata

log = logging.getLogger(__name__)

MODES = ("auto", "on", "off")


def footprint_centres(radar: RadarMetadata, positions: np.ndarray) -> np.ndarray:
    """Ground (z = 0) point of the boresight per pulse (n, 3); the scene centre without a beam."""
    if radar.azimuth_beamwidth <= 0 or radar.mode not in ("sliding_spotlight", "stripmap"):
        return np.broadcast_to(np.asarray(radar.scene_center, float), positions.shape).copy()
    b = beam.boresight(radar, positions)
    lam = -positions[:, 2] / b[:, 2]
    return positions + lam[:, None] * b


def phase_steps(ph: PhaseHistory, e_a: np.ndarray, e_r: np.ndarray, extent_a: float, extent_r: float) -> float:
    """Largest per-pulse phase-step spread over a content of extent (W_a, W_r), rad."""
    ua, ur = los_components(ph.positions, ph.reference, e_a, e_r)
    if len(ua) < 2:
        return 0.0
    k_max = float(wavenumbers(ph.carrier_frequency, ph.freqs[-1]))
    return k_max * float(np.max(np.abs(np.diff(ua)) * extent_a + np.abs(np.diff(ur)) * extent_r))


def content_extent(radar: RadarMetadata, ph: PhaseHistory, e_a: np.ndarray, grid: Grid) -> tuple[float, float, float]:
    """(swept azimuth extent, footprint width, slide per pulse), m, of what the beam lights.

    Without a sliding beam the content is taken as the image grid.
    """
    grid_a = grid.n_a * grid.da
    if radar.mode != "sliding_spotlight" or radar.azimuth_beamwidth <= 0:
        return grid_a, grid_a, 0.0
    q = footprint_centres(radar, ph.positions)
    qa = (q - ph.reference) @ np.asarray(e_a)
    rng = median(reference_ranges(ph.positions, ph.reference))
    width = 2 * rng * math.tan(radar.azimuth_beamwidth / 2)  # -3 dB footprint (the pattern's skirts fold too)
    slide = float(np.max(np.abs(np.diff(qa)))) if len(qa) > 1 else 0.0
    return float(np.ptp(qa)) + width, width, slide


def dealias(
    ph: PhaseHistory,
    radar: RadarMetadata,
    e_a: np.ndarray,
    e_r: np.ndarray,
    grid: Grid,
    mode: str = "auto",
    subaperture_pulses: int | None = None,
    upsample: int | None = None,
    guard: float = 1.25,
) -> tuple[PhaseHistory, dict]:
    """Apply (or not) the sub-aperture de-aliasing; returns (phase history, report dict)."""
    if mode not in MODES:
        raise InputError(f"dealias: {mode!r} is not one of {list(MODES)}")
    grid_r = grid.n_r * grid.dr
    swept, width, slide = content_extent(radar, ph, e_a, grid)
    need = phase_steps(ph, e_a, e_r, max(swept, grid.n_a * grid.da), grid_r)
    report = {
        "content_extent": swept,
        "footprint": width,
        "phase_step_spread": need,
        "applied": False,
        "upsample": 1,
        "subaperture_pulses": 0,
    }
    fold = need >= 2 * math.pi
    if mode == "on" or (mode == "auto" and fold and radar.mode == "sliding_spotlight"):
        inst = phase_steps(ph, e_a, e_r, width, grid_r)
        per_m = phase_steps(ph, e_a, e_r, 1.0, 0.0)
        room = (2 * math.pi / guard - inst) / max(per_m, 1e-30)  # metres of slide a sub-aperture may take
        n_sub = subaperture_pulses or (int(room / slide) if slide > 0 else len(ph.times))
        n_sub = int(min(max(n_sub, 0), len(ph.times)))
        if n_sub < 8:
            raise InputError(
                f"dealias: the footprint's own band ({inst:.3g} rad/pulse) leaves no room for a "
                f"sub-aperture at this PRF; raise the PRF above the instantaneous Doppler band"
            )
        u = upsample or max(1, int(math.ceil(need * guard / (2 * math.pi))))
        ph = upsample_subapertures(ph, radar, n_sub, u)
        report.update(applied=True, upsample=u, subaperture_pulses=n_sub)
        need /= u
        fold = need >= 2 * math.pi
    if fold:
        log.warning(
            "pfa2: the deramped scene band (%.3g rad per pulse over %.0f m) exceeds the PRF: "
            "targets fold into azimuth ghosts%s",
            need,
            swept,
            "" if report["applied"] else "; enable dealias",
            extra=IMAGE_DEFECT,
        )
    report["azimuth_oversampling"] = 2 * math.pi / need if need > 0 else 8.0
    report["folds"] = bool(fold)
    return ph, report


def upsample_subapertures(ph: PhaseHistory, radar: RadarMetadata, n_sub: int, factor: int) -> PhaseHistory:
    """Fig. 2: deramp sub-apertures to their footprint centres, zero-pad their spectra, stitch."""
    n, n_f = ph.data.shape
    if factor == 1:
        return ph
    idx = np.arange(n, dtype=float)
    spline = UniformCubicSpline(0.0, 1.0, ph.positions)  # platform positions at fractional pulse indices
    k = wavenumbers(ph.carrier_frequency, ph.freqs)
    hop = max(1, n_sub // 2)
    starts = list(range(0, max(1, n - n_sub + 1), hop))
    if starts[-1] + n_sub < n:
        starts.append(n - n_sub)
    n_out = n * factor
    out = np.zeros((n_out, n_f), np.complex64)
    q_all = footprint_centres(radar, ph.positions)
    # block b keeps pulses [keep[b], keep[b + 1]): its central half, the data's edges at the ends
    keep = [0] + [st + n_sub // 4 for st in starts[1:]] + [n]
    for b, s in enumerate(starts):
        e = min(s + n_sub, n)
        length = e - s
        q = q_all[(s + e - 1) // 2]
        rows = np.arange(keep[b] * factor, keep[b + 1] * factor)
        if len(rows) == 0:
            continue
        ramp = _ramp(ph.positions[s:e], ph.reference, q, k)
        spec = sfft.fft(ph.data[s:e] * np.conj(ramp), axis=0)
        up = np.zeros((length * factor, n_f), spec.dtype)
        half = (length + 1) // 2
        up[:half] = spec[:half]
        up[length * factor - (length - half) :] = spec[half:]
        sig = sfft.ifft(up, axis=0)
        sig *= factor
        t_up = s + np.arange(length * factor) / factor
        pick = rows - s * factor
        pos_up = spline(t_up[pick])
        out[rows] = (sig[pick] * _ramp(pos_up, ph.reference, q, k)).astype(np.complex64)
    t_new = np.interp(np.arange(n_out) / factor, idx, ph.times)
    pos_new = spline(np.arange(n_out) / factor)
    return ph.replace(
        data=out,
        positions=pos_new,
        times=t_new,
        delay_center=np.interp(np.arange(n_out) / factor, idx, ph.delay_center),
        delay_span=np.interp(np.arange(n_out) / factor, idx, ph.delay_span),
    )


def _ramp(positions: np.ndarray, reference: npt.ArrayLike, point: npt.ArrayLike, k: np.ndarray) -> np.ndarray:
    """exp{j K [r_0(t) - r_q(t)]} (n, n_f) complex64: the deramp to ``point`` relative to ``reference``."""
    d = reference_ranges(positions, reference) - reference_ranges(positions, point)
    cyc = np.outer(d, k / (2 * math.pi))
    cyc -= np.floor(cyc)
    return unit_phasor(cyc)
