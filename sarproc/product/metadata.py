"""Typed radar/platform metadata, stored as attributes of the HDF5 ``radar`` group (SI units).

Geometry convention (shared by every stage): a right-handed scene frame (x, y, z) in metres,
z up. The platform flies along +x at height ``altitude`` over the plane z = 0 and is at
x = 0 at azimuth time 0 (the aperture centre). Targets lie at y > 0. Azimuth time is slow
time relative to the aperture centre; range time is fast time since pulse transmission.
"""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np

from sarproc.product.errors import InputError

C = 299_792_458.0  # speed of light, m/s

_FORMAT_VERSION = "1"


@dataclasses.dataclass(frozen=True)
class RadarMetadata:
    """Radar and platform parameters in SI units.

    Attributes (units in the names' docs):
      carrier_frequency: Hz.  bandwidth: chirp bandwidth, Hz.  pulse_duration: s.
      chirp_rate: Hz/s, signed (+ for up-chirp).  range_sampling_rate: Hz.  prf: Hz.
      velocity: platform speed along +x, m/s.  altitude: m above the z = 0 plane.
      squint: squint of the beam centre line at the aperture centre, rad (+ looks forward).
      reference_range: slant range from the aperture-centre position to the scene centre, m.
      scene_center: (x, y, z) of the scene centre, m.  mode: stripmap | spotlight | sliding_spotlight.
      azimuth_beamwidth / elevation_beamwidth: one-way -3 dB beamwidths, rad (0: no pattern).
      aperture_time: s.  n_channels: receive channels.
      beam_rotation_range: sliding spotlight rotation point's slant range from the aperture centre, m.
    """

    carrier_frequency: float
    bandwidth: float
    pulse_duration: float
    chirp_rate: float
    range_sampling_rate: float
    prf: float
    velocity: float
    altitude: float
    squint: float
    reference_range: float
    scene_center: tuple[float, float, float]
    mode: str = "spotlight"
    azimuth_beamwidth: float = 0.0
    elevation_beamwidth: float = 0.0
    aperture_time: float = 0.0
    n_channels: int = 1
    beam_rotation_range: float = 0.0

    @property
    def wavelength(self) -> float:
        return C / self.carrier_frequency

    @property
    def range_resolution(self) -> float:
        """Theoretical slant-range IRW of unweighted processing, m (0.886 c / 2B)."""
        return 0.886 * C / (2.0 * self.bandwidth)

    def validate(self) -> None:
        positive = ("carrier_frequency", "bandwidth", "pulse_duration", "range_sampling_rate", "prf",
                    "velocity", "reference_range")
        for name in positive:
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise InputError(f"radar.{name}: must be a positive finite number, got {v!r}")
        if self.range_sampling_rate < self.bandwidth:
            raise InputError(
                f"radar.range_sampling_rate: {self.range_sampling_rate:g} Hz is below the bandwidth "
                f"{self.bandwidth:g} Hz (complex sampling needs fs >= B)"
            )
        if not abs(self.squint) < math.pi / 2:
            raise InputError(f"radar.squint: {self.squint!r} rad must be within (-90, 90) deg")
        if self.altitude < 0:
            raise InputError(f"radar.altitude: must be >= 0, got {self.altitude!r}")

    def to_attrs(self) -> dict:
        out = {}
        for f in dataclasses.fields(self):
            v = getattr(self, f.name)
            out[f.name] = np.asarray(v, dtype=float) if f.name == "scene_center" else v
        return out

    @classmethod
    def from_attrs(cls, attrs, where: str = "radar") -> "RadarMetadata":
        kwargs = {}
        for f in dataclasses.fields(cls):
            if f.name not in attrs:
                if f.default is dataclasses.MISSING:
                    raise InputError(f"{where}: missing attribute {f.name!r}")
                continue
            v = attrs[f.name]
            if f.name == "scene_center":
                v = tuple(float(a) for a in np.asarray(v, dtype=float).reshape(3))
            elif f.name == "mode":
                v = v.decode() if isinstance(v, bytes) else str(v)
            elif f.name == "n_channels":
                v = int(v)
            else:
                v = float(v)
            kwargs[f.name] = v
        meta = cls(**kwargs)
        meta.validate()
        return meta

    def replace(self, **changes) -> "RadarMetadata":
        return dataclasses.replace(self, **changes)

    def to_json(self) -> str:
        return json.dumps(dataclasses.asdict(self))


def aperture_center_position(radar: RadarMetadata) -> np.ndarray:
    """Platform position at azimuth time 0, m."""
    return np.array([0.0, 0.0, radar.altitude])


def scene_center_from_geometry(reference_range: float, squint: float, altitude: float) -> tuple[float, float, float]:
    """Scene centre on z = 0 seen at ``reference_range`` with ``squint`` from the aperture centre.

    With altitude 0 this is paper 000's slant-plane geometry: (r sin(theta), r cos(theta), 0).
    """
    across = (reference_range * math.cos(squint)) ** 2 - altitude**2
    if across < 0:
        raise InputError(
            f"geometry: reference range {reference_range:g} m at squint {math.degrees(squint):.3g} deg "
            f"does not reach the ground from altitude {altitude:g} m"
        )
    return (reference_range * math.sin(squint), math.sqrt(across), 0.0)


FORMAT_VERSION = _FORMAT_VERSION
