"""Cross-track receive array (paper 004, Du 2010, Fig. 1): one transmitter, N receivers across track.

The transmitter sits on the platform track (the array centre, Q in the paper); receiver n is at
cross-track offset v_n from it, so each channel's echo uses the exact bistatic path
|P_tx - T| + |P_rx,n - T| (the paper's eq. (4) is only the processor's approximation).

Layouts:
  symmetric (default): v_n = (n - (N + 1)/2) d, centred on the transmitter, L = (N - 1) d;
  paper: v_n = -L/2 + (n - 1) d with ``array_length`` L (the paper's formula as written; with
         N = 28, d = 0.0764 m, L = 2 m it is not centred: v_N = 1.063 m).
An optional receive element pattern (one-way, across track, boresight straight down) weights
each channel: sinc, gaussian or rect of ``element_beamwidth`` (see effects.antenna).
The raw product becomes ``raw_array`` (channel, azimuth_time, range_time); aux ``rx_offset``
holds the (N, 3) receiver offsets and ``tx_offset`` the transmitter's.
"""

from __future__ import annotations

import dataclasses
import math
from typing import TYPE_CHECKING

import numpy as np

from sarproc.product.config import param
from sarproc.product.errors import InputError
from sarproc.simulation.effects.antenna import one_way_amplitude
from sarproc.simulation.effects.base import ReceiverArray, offsets_along, register_effect

if TYPE_CHECKING:
    from sarproc.product.metadata import RadarMetadata
    from sarproc.simulation.scene import SceneParams


@dataclasses.dataclass(frozen=True)
class CrossTrackArrayParams:
    n_receivers: int = param(ge=1, le=4096, doc="number of receive elements N")
    spacing: float = param("length", gt=0, doc="element spacing d")
    layout: str = param(
        default="symmetric",
        choices=("symmetric", "paper"),
        doc=("symmetric: centred on the transmitter; paper: v_n = -L/2 + (n-1) d with array_length L"),
    )
    array_length: float | None = param("length", default=None, gt=0, doc="L for layout: paper")
    element_pattern: str = param(
        default="none",
        choices=("none", "sinc", "gaussian", "rect"),
        doc=("receive element pattern across track (one-way)"),
    )
    element_beamwidth: float = param(
        "angle", default=0.0, ge=0, lt=math.pi, doc=("one-way -3 dB beamwidth of the element pattern")
    )

    def validate(self) -> None:
        if self.layout == "paper" and self.array_length is None:
            raise InputError("array_length: required for layout: paper")
        if self.layout == "symmetric" and self.array_length is not None:
            raise InputError("array_length: only used with layout: paper (symmetric uses L = (N - 1) d)")
        if self.element_pattern != "none" and self.element_beamwidth <= 0:
            raise InputError("element_beamwidth: required (> 0) with an element_pattern")


def receiver_offsets(params: CrossTrackArrayParams) -> np.ndarray:
    """Cross-track offsets v_n, m (n = 1..N)."""
    n = np.arange(params.n_receivers, dtype=float)
    if params.layout == "paper":
        assert params.array_length is not None  # validate() requires it with layout: paper
        return -params.array_length / 2 + n * params.spacing
    return (n - (params.n_receivers - 1) / 2.0) * params.spacing


@register_effect("cross_track_array")
class CrossTrackArray(ReceiverArray):
    order = 10
    Params = CrossTrackArrayParams
    product_kind = "raw_array"

    def __init__(self, params: CrossTrackArrayParams, scene_params: SceneParams, radar: RadarMetadata) -> None:
        super().__init__(params, scene_params, radar)
        self.v = receiver_offsets(params)
        self.receiver_offsets = offsets_along(self.v, 1)

    def gains(
        self, t: np.ndarray, platform_pos: np.ndarray, target_pos: np.ndarray, channel: int, gains: np.ndarray
    ) -> np.ndarray:
        if self.params.element_pattern == "none":
            return gains
        rx = platform_pos + np.array([0.0, self.v[channel], 0.0])
        d = target_pos - rx[:, None, :]  # (n_t, n_tg, 3)
        angle = np.arctan2(d[..., 1], -d[..., 2])  # across-track angle off nadir
        return gains * one_way_amplitude(angle, self.params.element_beamwidth, self.params.element_pattern)
