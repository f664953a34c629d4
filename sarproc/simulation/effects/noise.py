"""Receiver noise: circular complex white Gaussian noise at a given SNR.

SNR is per raw sample: the echo power of the strongest target (|amplitude|^2, peak two-way
gain 1) over the noise power per complex sample. Seeded by ``simulation.seed`` so runs repeat.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from sarproc.product.config import param
from sarproc.simulation.effects.base import Effect, register_effect


@dataclasses.dataclass(frozen=True)
class NoiseParams:
    snr: float = param("decibel", doc="strongest target's raw-sample power over noise power per sample")


@register_effect("noise")
class Noise(Effect):
    order = 90
    Params = NoiseParams

    def finalize(self, block: np.ndarray, rng: np.random.Generator, signal_power: float) -> np.ndarray:
        sigma2 = signal_power / 10.0 ** (self.params.snr / 10.0)
        if sigma2 <= 0:  # a zero-amplitude scene: noise relative to unit amplitude
            sigma2 = 1.0 / 10.0 ** (self.params.snr / 10.0)
        scale = np.sqrt(sigma2 / 2.0)
        noise = rng.standard_normal(block.shape) + 1j * rng.standard_normal(block.shape)
        return block + scale * noise
