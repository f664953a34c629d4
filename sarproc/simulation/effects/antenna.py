"""Antenna pattern and beam steering (stripmap, spotlight, sliding spotlight).

The two-way amplitude gain is the square of the one-way amplitude pattern evaluated at the
target's angles off boresight: azimuth (towards the velocity) and elevation. Patterns are
defined by their one-way -3 dB beamwidth beta:
  sinc:     one-way amplitude sinc(0.886 sin(phi) / beta)      (uniform aperture)
  gaussian: one-way power exp(-4 ln2 phi^2 / beta^2)
  rect:     one-way amplitude 1 for |phi| <= beta/2, else 0  (an ideal beam: flat spectrum)
Steering per mode is sarproc.product.beam.boresight (shared with the processors).
"""

from __future__ import annotations

import dataclasses
import math
from typing import TYPE_CHECKING

from sarproc.product.beam import boresight, off_boresight_angles, one_way_amplitude
from sarproc.product.config import param
from sarproc.product.errors import InputError
from sarproc.simulation.effects.base import Effect, register_effect

if TYPE_CHECKING:
    import numpy as np

    from sarproc.product.metadata import RadarMetadata
    from sarproc.simulation.scene import SceneParams


@dataclasses.dataclass(frozen=True)
class AntennaParams:
    azimuth_beamwidth: float = param("angle", gt=0, lt=math.pi, doc="one-way -3 dB azimuth beamwidth")
    elevation_beamwidth: float = param(
        "angle", default=0.0, ge=0, lt=math.pi, doc="one-way -3 dB elevation beamwidth (0: no elevation pattern)"
    )
    pattern: str = param(default="sinc", choices=("sinc", "gaussian", "rect"), doc="pattern shape")
    rotation_range: float | None = param(
        "length", default=None, gt=0, doc="sliding spotlight: slant range of the beam rotation point"
    )


@register_effect("antenna")
class Antenna(Effect):
    order = 50
    Params = AntennaParams

    def __init__(self, params: AntennaParams, scene_params: SceneParams, radar: RadarMetadata) -> None:
        super().__init__(params, scene_params, radar)
        mode = radar.mode
        if mode == "sliding_spotlight" and params.rotation_range is None:
            raise InputError("effects.antenna.rotation_range: required for acquisition.mode sliding_spotlight")
        if mode != "sliding_spotlight" and params.rotation_range is not None:
            raise InputError("effects.antenna.rotation_range: only used with acquisition.mode sliding_spotlight")

    def update_radar(self, radar: RadarMetadata) -> RadarMetadata:
        self.radar = radar.replace(
            azimuth_beamwidth=self.params.azimuth_beamwidth,
            elevation_beamwidth=self.params.elevation_beamwidth,
            beam_rotation_range=self.params.rotation_range or 0.0,
            antenna_pattern=self.params.pattern,
        )
        return self.radar

    def gains(
        self, t: np.ndarray, platform_pos: np.ndarray, target_pos: np.ndarray, channel: int, gains: np.ndarray
    ) -> np.ndarray:
        az, el = off_boresight_angles(boresight(self.radar, platform_pos), platform_pos, target_pos)
        g = one_way_amplitude(az, self.params.azimuth_beamwidth, self.params.pattern)
        if self.params.elevation_beamwidth > 0:
            g = g * one_way_amplitude(el, self.params.elevation_beamwidth, self.params.pattern)
        return gains * g**2  # two-way
