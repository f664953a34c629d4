"""Static clutter: many random point scatterers around the scene centre (paper 003's clutter case).

``n_scatterers`` points are drawn uniformly in a box of ``azimuth_extent`` x ``range_extent``
centred on the scene centre, in the coordinates of ``targets.frame``, with circular complex
Gaussian amplitudes of rms ``amplitude`` (a speckle-like distributed background), seeded by
``seed`` so runs repeat. They are static (target_motion does not move them) and take every
other effect (antenna pattern, channels) like targets do, but are not listed in the targets
table; aux ``clutter_position`` (n, 3) and ``clutter_amplitude`` (n,) hold them.

Cost: the simulator spends about n_pulses x n_channels x n_scatterers x ceil(T_p f_s) phasor
evaluations on clutter; the estimate is logged and a scene above ``max_evaluations`` is
refused (InputError) before any work is done.
"""

from __future__ import annotations

import dataclasses
import logging
import math
from typing import TYPE_CHECKING

import numpy as np

from sarproc.product.config import param
from sarproc.product.errors import InputError
from sarproc.product.frames import make_frame
from sarproc.simulation.effects.base import Effect, register_effect

if TYPE_CHECKING:
    from sarproc.product.metadata import RadarMetadata
    from sarproc.simulation.scene import SceneParams

log = logging.getLogger(__name__)


@dataclasses.dataclass(frozen=True)
class ClutterParams:
    n_scatterers: int = param(ge=1, le=1_000_000, doc="number of random static scatterers")
    azimuth_extent: float = param("length", gt=0, doc="box size along the frame's azimuth axis")
    range_extent: float = param("length", gt=0, doc="box size along the frame's range axis")
    amplitude: float = param(default=1.0, ge=0, doc="rms amplitude of each scatterer")
    seed: int = param(default=1, ge=0, doc="random seed of positions and amplitudes")
    max_evaluations: float = param(default=2e10, gt=0, doc="refuse scenes whose clutter costs more phasors")


def clutter_cost(n_pulses: int, n_channels: int, n_scatterers: int, pulse_samples: int) -> float:
    """Phasor evaluations the simulator spends on clutter."""
    return float(n_pulses) * n_channels * n_scatterers * pulse_samples


@register_effect("clutter")
class Clutter(Effect):
    order = 60
    Params = ClutterParams

    def __init__(self, params: ClutterParams, scene_params: SceneParams, radar: RadarMetadata) -> None:
        super().__init__(params, scene_params, radar)
        rng = np.random.default_rng(params.seed)
        frame = make_frame(scene_params.targets.frame, radar)
        az0, rg0 = (float(c) for c in frame.from_xyz(np.asarray(radar.scene_center, float)))
        n = params.n_scatterers
        az = az0 + (rng.random(n) - 0.5) * params.azimuth_extent
        rg = rg0 + (rng.random(n) - 0.5) * params.range_extent
        try:
            self.xyz = frame.to_xyz(az, rg)
        except InputError as exc:
            raise InputError(f"effects.clutter: {exc}") from None
        self.amp = params.amplitude * (rng.standard_normal(n) + 1j * rng.standard_normal(n)) / math.sqrt(2)

    def update_radar(self, radar: RadarMetadata) -> RadarMetadata:
        n_pulses = int(round(radar.aperture_time * radar.prf)) or 1
        samples = int(math.ceil(radar.pulse_duration * radar.range_sampling_rate)) + 2
        cost = clutter_cost(n_pulses, radar.n_channels, self.params.n_scatterers, samples)
        if cost > self.params.max_evaluations:
            raise InputError(
                f"effects.clutter: {cost:.3g} phasor evaluations exceed max_evaluations "
                f"{self.params.max_evaluations:.3g}; use fewer scatterers or pulses"
            )
        log.info("clutter: %d scatterers, about %.3g phasor evaluations", self.params.n_scatterers, cost)
        self.cost = cost
        return radar

    def scatterers(self) -> tuple[np.ndarray, np.ndarray]:
        return self.xyz, self.amp

    def aux(self) -> dict:
        return {"clutter_position": self.xyz, "clutter_amplitude": self.amp}
