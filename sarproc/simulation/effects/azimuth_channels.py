"""Azimuth (along-track) multichannel receiver (paper 003, Xu et al., Fig. 1): one transmitter, N receivers.

The transmitter is at the platform position; receiver n sits at along-track offset dx_n from it,
so channel n records the exact bistatic path |P_tx(t) - T(t)| + |P_rx,n(t) - T(t)| (no
equivalent-phase-centre approximation: that is the processor's model, see
sarproc.focus.multichannel.channels). Layout: dx_n = (n - (N - 1)/2) d, n = 0..N-1, centred on
the transmitter; d is the receiver spacing (the sub-aperture length of a split antenna).

Optional channel errors for robustness tests: ``phase_imbalance`` (one angle per channel) and
``amplitude_imbalance`` (one relative gain error per channel, 0.02 = +2 %) multiply each
channel's echoes by (1 + a_n) exp(j phi_n).
The raw product becomes ``raw_multichannel`` (channel, azimuth_time, range_time); aux
``rx_offset`` holds the (N, 3) receiver offsets and ``tx_offset`` the transmitter's.
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING

import numpy as np

from sarproc.product.config import param
from sarproc.product.errors import InputError
from sarproc.simulation.effects.base import ReceiverArray, offsets_along, register_effect

if TYPE_CHECKING:
    from sarproc.product.metadata import RadarMetadata
    from sarproc.simulation.scene import SceneParams


@dataclasses.dataclass(frozen=True)
class AzimuthChannelsParams:
    n_receivers: int = param(ge=1, le=64, doc="number of along-track receive channels N")
    spacing: float = param("length", gt=0, doc="along-track receiver spacing d")
    phase_imbalance: tuple[float, ...] = param(
        "angle", default=(), doc=("per-channel phase error (N angles; empty: none)")
    )
    amplitude_imbalance: tuple[float, ...] = param(
        default=(), doc=("per-channel relative amplitude error (N values, 0.02 = +2 %; empty: none)")
    )

    def validate(self) -> None:
        for key in ("phase_imbalance", "amplitude_imbalance"):
            v = getattr(self, key)
            if v and len(v) != self.n_receivers:
                raise InputError(f"{key}: {len(v)} values for {self.n_receivers} receivers")
        if any(a <= -1 for a in self.amplitude_imbalance):
            raise InputError("amplitude_imbalance: every value must be > -1 (a gain of 1 + a > 0)")


def along_track_offsets(n_receivers: int, spacing: float) -> np.ndarray:
    """dx_n, m: receivers centred on the transmitter."""
    return (np.arange(n_receivers, dtype=float) - (n_receivers - 1) / 2.0) * spacing


@register_effect("azimuth_channels")
class AzimuthChannels(ReceiverArray):
    order = 10
    Params = AzimuthChannelsParams
    product_kind = "raw_multichannel"

    def __init__(self, params: AzimuthChannelsParams, scene_params: SceneParams, radar: RadarMetadata) -> None:
        super().__init__(params, scene_params, radar)
        self.dx = along_track_offsets(params.n_receivers, params.spacing)
        self.receiver_offsets = offsets_along(self.dx, 0)
        n = params.n_receivers
        self.phase_imbalance = np.asarray(params.phase_imbalance or np.zeros(n), float)
        self.amplitude_imbalance = np.asarray(params.amplitude_imbalance or np.zeros(n), float)
        self.channel_gain = (1.0 + self.amplitude_imbalance) * np.exp(1j * self.phase_imbalance)

    def product_attrs(self, radar: RadarMetadata, aux: dict) -> dict:
        """With a channel imbalance, attribute ``channel_errors``: the imbalance simulated (``phase_imbalance`` rad,
        ``amplitude_imbalance`` per channel), from which evaluate predicts the ghosts it leaves (eq. 6 of
        docs/multichannel.md, :func:`sarproc.focus.multichannel.channels.ghost_predictions`)."""
        if np.all(self.channel_gain == 1):
            return {}
        return {
            "channel_errors": {
                "phase_imbalance": [float(p) for p in self.phase_imbalance],
                "amplitude_imbalance": [float(a) for a in self.amplitude_imbalance],
            }
        }

    def gains(
        self, t: np.ndarray, platform_pos: np.ndarray, target_pos: np.ndarray, channel: int, gains: np.ndarray
    ) -> np.ndarray:
        g = self.channel_gain[channel]
        return gains if g == 1 else gains * g
