"""Antenna pattern and beam steering (stripmap, spotlight, sliding spotlight).

The two-way amplitude gain is the square of the one-way amplitude pattern evaluated at the
target's angles off boresight: azimuth (towards the velocity) and elevation. Patterns are
defined by their one-way -3 dB beamwidth beta:
  sinc:     one-way amplitude sinc(0.886 sin(phi) / beta)      (uniform aperture)
  gaussian: one-way power exp(-4 ln2 phi^2 / beta^2)
  rect:     one-way amplitude 1 for |phi| <= beta/2, else 0  (an ideal beam: flat spectrum)
Steering: stripmap keeps the boresight fixed (pointing at the scene centre at t = 0);
spotlight points it at the scene centre for every pulse; sliding spotlight points it at a
rotation point on the central line of sight at ``rotation_range`` from the aperture centre.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ..config import param
from ..errors import InputError
from .base import Effect, register_effect


@dataclasses.dataclass(frozen=True)
class AntennaParams:
    azimuth_beamwidth: float = param("angle", gt=0, lt=math.pi, doc="one-way -3 dB azimuth beamwidth")
    elevation_beamwidth: float = param("angle", default=0.0, ge=0, lt=math.pi,
                                       doc="one-way -3 dB elevation beamwidth (0: no elevation pattern)")
    pattern: str = param(default="sinc", choices=("sinc", "gaussian", "rect"), doc="pattern shape")
    rotation_range: float | None = param("length", default=None, gt=0,
                                         doc="sliding spotlight: slant range of the beam rotation point")


def one_way_amplitude(angle: np.ndarray, beamwidth: float, pattern: str) -> np.ndarray:
    if pattern == "sinc":
        return np.sinc(0.886 * np.sin(angle) / beamwidth)
    if pattern == "gaussian":
        return np.exp(-2.0 * math.log(2.0) * (angle / beamwidth) ** 2)
    return (np.abs(angle) <= beamwidth / 2).astype(float)


@register_effect("antenna")
class Antenna(Effect):
    order = 50
    Params = AntennaParams

    def __init__(self, params, scene_params, radar):
        super().__init__(params, scene_params, radar)
        mode = radar.mode
        if mode == "sliding_spotlight" and params.rotation_range is None:
            raise InputError("effects.antenna.rotation_range: required for acquisition.mode sliding_spotlight")
        if mode != "sliding_spotlight" and params.rotation_range is not None:
            raise InputError("effects.antenna.rotation_range: only used with acquisition.mode sliding_spotlight")
        self.mode = mode
        self.centre = np.asarray(radar.scene_center, float)
        self.ap_centre = np.array([0.0, 0.0, radar.altitude])
        los = self.centre - self.ap_centre
        self.fixed_boresight = los / np.linalg.norm(los)
        if mode == "sliding_spotlight":
            self.pivot = self.ap_centre + self.fixed_boresight * params.rotation_range

    def update_radar(self, radar):
        return radar.replace(azimuth_beamwidth=self.params.azimuth_beamwidth,
                             elevation_beamwidth=self.params.elevation_beamwidth)

    def boresight(self, platform_pos: np.ndarray) -> np.ndarray:
        """(n_t, 3) unit boresight vectors."""
        if self.mode == "stripmap":
            return np.broadcast_to(self.fixed_boresight, platform_pos.shape)
        aim = self.centre if self.mode == "spotlight" else self.pivot
        d = aim - platform_pos
        return d / np.linalg.norm(d, axis=-1, keepdims=True)

    def gains(self, t, platform_pos, target_pos, channel, gains):
        b = self.boresight(platform_pos)                                    # (n_t, 3)
        x = np.array([1.0, 0.0, 0.0])
        e_az = x - (b @ x)[:, None] * b
        e_az /= np.linalg.norm(e_az, axis=-1, keepdims=True)
        e_el = np.cross(b, e_az)
        u = target_pos - platform_pos[:, None, :]
        u /= np.linalg.norm(u, axis=-1, keepdims=True)                      # (n_t, n_tg, 3)
        az = np.arcsin(np.clip(np.einsum("tgk,tk->tg", u, e_az), -1, 1))
        g = one_way_amplitude(az, self.params.azimuth_beamwidth, self.params.pattern)
        if self.params.elevation_beamwidth > 0:
            el = np.arcsin(np.clip(np.einsum("tgk,tk->tg", u, e_el), -1, 1))
            g = g * one_way_amplitude(el, self.params.elevation_beamwidth, self.params.pattern)
        return gains * g**2  # two-way
