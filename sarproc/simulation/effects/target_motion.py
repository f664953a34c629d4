"""Moving targets: each target moves at its constant (vx, vy, vz) from its position at t = 0."""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING

from sarproc.simulation.effects.base import Effect, register_effect

if TYPE_CHECKING:
    import numpy as np


@dataclasses.dataclass(frozen=True)
class TargetMotionParams:
    pass


@register_effect("target_motion")
class TargetMotion(Effect):
    order = 20
    Params = TargetMotionParams

    def target_positions(self, t: np.ndarray, target_pos: np.ndarray, velocity: np.ndarray) -> np.ndarray:
        return target_pos + t[:, None, None] * velocity[None, :, :]
