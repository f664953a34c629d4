"""Varied receive range gate (paper 002, Nie 2016, section 2, eq. (2)).

In a highly squinted acquisition the echo of the scene walks through the receive window by
about v sin(theta) T_a. The radar instead moves the start of its receive gate with the linear
part of the range history of the scene centre, in whole gates of ``range_step`` p_r (slant
range per gate; default one range sample c / (2 f_s)) and only every ``pulses_per_step`` K
pulses, so the recorded window only has to cover the scene, the pulse and the residual walk.

Linear range history (scene centre C, nominal straight track P(t) = (v t, 0, H)):

    r_0(t) ~= R_c + rdot t,   rdot = d|P(t) - C|/dt at t = 0 = (P(0) - C) . V / R_c = -v sin(theta)

Pulse k (0-based, from the first pulse) belongs to step m = floor(k / K); the step's gate is
set from the range at the step's middle pulse time t_m:

    n_m = round(rdot t_m / p_r),     gate offset (s) = 2 n_m p_r / c

so the offsets are integer multiples of 2 p_r / c (of 1/f_s by default), constant over each
step, and zero around the aperture centre (the raw ``range_time`` axis is then the absolute
fast time of the pulses near t = 0). A sample at ``range_time`` tau of pulse t was taken at
absolute fast time tau + offset(t): in eq. (2) the echo of a point at r_p sits at
2 (r_p - n(t) p_r) / c. The gate is designed from the nominal track, as a radar would; a
platform_motion effect does not change it. The simulator stores the schedule in aux
``range_gate_offset`` (read by backprojection) and sizes the automatic window with it.
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING

import numpy as np

from sarproc.product.config import param
from sarproc.product.metadata import C
from sarproc.simulation.effects.base import Effect, register_effect

if TYPE_CHECKING:
    from sarproc.product.metadata import RadarMetadata
    from sarproc.simulation.scene import SceneParams


@dataclasses.dataclass(frozen=True)
class RangeGateParams:
    range_step: float | None = param(
        "length", default=None, gt=0, doc=("slant range p_r of one gate step; default one range sample c / (2 f_s)")
    )
    pulses_per_step: int = param(default=1, ge=1, doc="K: the gate moves at most once every K pulses")


def linear_range_rate(radar: RadarMetadata) -> float:
    """d|P(t) - C|/dt at t = 0 for the nominal straight track (m/s); -v sin(theta) by geometry."""
    p0 = np.array([0.0, 0.0, radar.altitude])
    d = p0 - np.asarray(radar.scene_center, float)
    return float(d @ np.array([radar.velocity, 0.0, 0.0]) / np.linalg.norm(d))


@register_effect("range_gate")
class RangeGate(Effect):
    order = 30
    Params = RangeGateParams

    def __init__(self, params: RangeGateParams, scene_params: SceneParams, radar: RadarMetadata) -> None:
        super().__init__(params, scene_params, radar)
        self.range_step = params.range_step or C / (2 * radar.range_sampling_rate)
        self.rate = linear_range_rate(radar)
        self.n_pulses = int(round(radar.aperture_time * radar.prf)) or 1

    def gate_steps(self, t: np.ndarray) -> np.ndarray:
        """n(t): whole gate steps of the receive window start at pulse times ``t`` (int64)."""
        prf, n, k_step = self.radar.prf, self.n_pulses, self.params.pulses_per_step
        k = np.rint(np.asarray(t, float) * prf + (n - 1) / 2.0).astype(np.int64)  # pulse index
        middle = (k // k_step) * k_step + (k_step - 1) / 2.0
        t_m = (middle - (n - 1) / 2.0) / prf
        return np.rint(self.rate * t_m / self.range_step).astype(np.int64)  # eq. (2): n(t) p_r ~ r_0(t) - R_c

    def gate_offsets(self, t: np.ndarray, offsets: np.ndarray, reference_delay: float) -> np.ndarray:
        n = self.gate_steps(t)
        if self.params.range_step is None:  # one sample per step: offsets exactly n / f_s
            return offsets + n / self.radar.range_sampling_rate
        return offsets + n * (2 * self.range_step / C)
