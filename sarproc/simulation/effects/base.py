"""The effect plugin interface of the simulator.

The simulator computes the ideal case (one channel at the platform, straight track, static
targets, fixed receive gate, unit gains, no noise) and lets each declared effect change one
or more of these through hooks. Every hook receives the current value and returns the new
one, so effects compose in ``order``. Hooks an effect does not override cost nothing.

Shapes: ``t`` (n_t,) azimuth times, s; positions in m; ``target_pos`` (n_t, n_tg, 3);
gains complex (n_t, n_tg); gate offsets (n_t,) s; signal blocks (n_ch, n_t, n_range) complex.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, TypeVar

import numpy as np

if TYPE_CHECKING:
    from typing import Any

    from sarproc.product.metadata import RadarMetadata
    from sarproc.simulation.scene import SceneParams

EFFECTS: dict[str, type[Effect]] = {}


def register_effect(key: str) -> Callable[[type[E]], type[E]]:
    """Class decorator: make an effect available under ``effects.<key>`` in scene YAML."""

    def deco(cls: type[E]) -> type[E]:
        cls.key = key
        EFFECTS[key] = cls
        return cls

    return deco


E = TypeVar("E", bound="Effect")


class _NoParams:
    pass


class Effect:
    key = "base"
    order = 50  # application order: geometry (10s), gains (50s), noise last (90s)
    product_kind: str | None = None  # e.g. "raw_array": the raw product type this effect implies
    Params: type = _NoParams  # replaced by a frozen dataclass in each effect

    def __init__(self, params: Any, scene_params: SceneParams, radar: RadarMetadata) -> None:
        self.params = params
        self.scene_params = scene_params
        self.radar = radar

    def update_radar(self, radar: RadarMetadata) -> RadarMetadata:
        """Record what the effect adds to the radar metadata (e.g. beamwidths, channels)."""
        return radar

    def channels(self, tx_offset: np.ndarray, rx_offsets: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Transmit offset (3,) and receive offsets (n_ch, 3) relative to the platform position."""
        return tx_offset, rx_offsets

    def platform_positions(self, t: np.ndarray, positions: np.ndarray) -> np.ndarray:
        return positions

    def target_positions(self, t: np.ndarray, target_pos: np.ndarray, velocity: np.ndarray) -> np.ndarray:
        return target_pos

    def gate_offsets(self, t: np.ndarray, offsets: np.ndarray, reference_delay: float) -> np.ndarray:
        return offsets

    def gains(
        self, t: np.ndarray, platform_pos: np.ndarray, target_pos: np.ndarray, channel: int, gains: np.ndarray
    ) -> np.ndarray:
        return gains

    def scatterers(self) -> tuple[np.ndarray, np.ndarray] | None:
        """Extra static point scatterers (clutter): None, or (xyz (n, 3) m, complex amplitudes (n,))."""
        return None

    def finalize(self, block: np.ndarray, rng: np.random.Generator, signal_power: float) -> np.ndarray:
        """Last touch on a finished block of pulses (noise)."""
        return block

    def aux(self) -> dict:
        """Extra arrays to store with the raw product."""
        return {}

    def product_attrs(self, radar: RadarMetadata, aux: dict) -> dict:
        """Extra attributes (truth the effect knows) for the raw product, given its final radar and aux arrays."""
        return {}


def offsets_along(values: np.ndarray, axis: int) -> np.ndarray:
    """(n, 3) receiver offsets, m: ``values`` along coordinate ``axis`` (0 along track, 1 cross track), 0 elsewhere."""
    offsets = np.zeros((len(values), 3))
    offsets[:, axis] = values
    return offsets


class ReceiverArray(Effect):
    """An effect that replaces the one monostatic channel by receivers at fixed offsets from the
    transmitter (which stays at the platform position). Subclasses set ``receiver_offsets`` (n_ch, 3), m."""

    receiver_offsets: np.ndarray

    def update_radar(self, radar: RadarMetadata) -> RadarMetadata:
        return radar.replace(n_channels=len(self.receiver_offsets))

    def channels(self, tx_offset: np.ndarray, rx_offsets: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return np.zeros(3), self.receiver_offsets
