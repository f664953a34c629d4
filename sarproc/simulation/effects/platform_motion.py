"""Deterministic platform motion: deviations of the antenna phase centre from the straight track.

Added to the nominal position (v t, 0, H) at every pulse time t:

    dx(t) = dv t                                          (constant along-track velocity error)
    dy(t) = A_y sin(2 pi t / T_y + phi_y)                 (cross-track sinusoid)
    dz(t) = A_z sin(2 pi t / T_z + phi_z)                 (vertical sinusoid)

The echoes use the actual positions, and the simulator stores them in aux
``platform_position``: a processor that reads them (backprojection) focuses exactly, one that
assumes the nominal straight line sees the residual phase 4 pi (dR) / lambda and defocuses.
The radar metadata (velocity, altitude) stay nominal.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from sarproc.product.config import param
from sarproc.product.errors import InputError
from sarproc.simulation.effects.base import Effect, register_effect


@dataclasses.dataclass(frozen=True)
class PlatformMotionParams:
    cross_track_amplitude: float = param("length", default=0.0, ge=0, doc="A_y, m")
    cross_track_period: float | None = param("time", default=None, gt=0, doc="T_y; required with A_y > 0")
    cross_track_phase: float = param("angle", default=0.0, doc="phi_y at t = 0 (aperture centre)")
    vertical_amplitude: float = param("length", default=0.0, ge=0, doc="A_z, m")
    vertical_period: float | None = param("time", default=None, gt=0, doc="T_z; required with A_z > 0")
    vertical_phase: float = param("angle", default=0.0, doc="phi_z at t = 0")
    along_track_velocity_error: float = param("velocity", default=0.0, doc="dv added to the nominal speed along +x")

    def validate(self) -> None:
        for axis in ("cross_track", "vertical"):
            if getattr(self, f"{axis}_amplitude") > 0 and getattr(self, f"{axis}_period") is None:
                raise InputError(f"{axis}_period: required with a non-zero {axis}_amplitude")


def displacement(params: PlatformMotionParams, t: np.ndarray) -> np.ndarray:
    """(n_t, 3) deviation from the nominal track at times ``t``, m."""
    t = np.asarray(t, float)
    d = np.zeros(t.shape + (3,))
    d[:, 0] = params.along_track_velocity_error * t
    if params.cross_track_amplitude > 0:
        assert params.cross_track_period is not None  # validate() requires it
        d[:, 1] = params.cross_track_amplitude * np.sin(
            2 * math.pi * t / params.cross_track_period + params.cross_track_phase
        )
    if params.vertical_amplitude > 0:
        assert params.vertical_period is not None  # validate() requires it
        d[:, 2] = params.vertical_amplitude * np.sin(2 * math.pi * t / params.vertical_period + params.vertical_phase)
    return d


@register_effect("platform_motion")
class PlatformMotion(Effect):
    order = 15
    Params = PlatformMotionParams

    def platform_positions(self, t: np.ndarray, positions: np.ndarray) -> np.ndarray:
        return positions + displacement(self.params, t)
