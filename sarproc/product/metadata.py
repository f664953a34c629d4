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
import re
from typing import TYPE_CHECKING

import numpy as np

from sarproc.product.errors import InputError

if TYPE_CHECKING:
    from collections.abc import Mapping
    from typing import Any

C = 299_792_458.0  # speed of light, m/s
SINC_IRW_FACTOR = 0.886  # -3 dB width of sinc^2 times the bandwidth (0.8859 exactly): unweighted IRW x B

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
      antenna_pattern: the pattern's shape, sinc | gaussian | rect (None: not recorded; processors'
        theory then takes the -3 dB beam as flat, as before the field existed).
      aperture_time: s.  n_channels: receive channels.
      beam_rotation_range: sliding spotlight rotation point's slant range from the aperture centre, m.
      reference_utc: optional absolute time of azimuth time 0, ISO 8601 UTC ('2024-05-01T10:00:00.000000Z').
      reference_latitude / reference_longitude: optional WGS84 geodetic position of the scene centre, rad.
      reference_height: its height above the WGS84 ellipsoid, m. (All four absent = a local scene.)
      polarization: optional transmit:receive polarisation, SICD spelling ('V:V', 'H:V', 'RHC:RHC', ...);
        None = not recorded (the exports then write UNKNOWN).
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
    reference_utc: str | None = None
    reference_latitude: float | None = None
    reference_longitude: float | None = None
    reference_height: float | None = None
    polarization: str | None = None
    antenna_pattern: str | None = None

    @property
    def wavelength(self) -> float:
        return C / self.carrier_frequency

    @property
    def range_resolution(self) -> float:
        """Theoretical slant-range IRW of unweighted processing, m (0.886 c / 2B)."""
        return SINC_IRW_FACTOR * C / (2.0 * self.bandwidth)

    def validate(self) -> None:
        positive = (
            "carrier_frequency",
            "bandwidth",
            "pulse_duration",
            "range_sampling_rate",
            "prf",
            "velocity",
            "reference_range",
        )
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
        if self.mode not in ("stripmap", "spotlight", "sliding_spotlight"):
            raise InputError(f"radar.mode: {self.mode!r} is not one of stripmap, spotlight, sliding_spotlight")
        if self.n_channels < 1:
            raise InputError(f"radar.n_channels: must be >= 1, got {self.n_channels!r}")
        geo = (self.reference_latitude, self.reference_longitude, self.reference_height)
        if any(g is not None for g in geo) and any(g is None for g in geo):
            raise InputError("radar.reference_latitude/longitude/height: give all three or none")
        if self.reference_latitude is not None and not abs(self.reference_latitude) <= math.pi / 2:
            raise InputError(f"radar.reference_latitude: {self.reference_latitude!r} rad is outside [-90, 90] deg")
        if self.reference_longitude is not None and not abs(self.reference_longitude) <= math.pi:
            raise InputError(f"radar.reference_longitude: {self.reference_longitude!r} rad is outside [-180, 180] deg")
        if self.reference_height is not None and not math.isfinite(self.reference_height):
            raise InputError("radar.reference_height: must be finite")
        if self.reference_utc is not None:
            parse_utc(self.reference_utc, "radar.reference_utc")
        if self.antenna_pattern is not None and self.antenna_pattern not in ("sinc", "gaussian", "rect"):
            raise InputError(f"radar.antenna_pattern: {self.antenna_pattern!r} is not one of sinc, gaussian, rect")
        if self.polarization is not None and not POLARIZATION_RE.fullmatch(self.polarization):
            raise InputError(
                f"radar.polarization: {self.polarization!r} is not TX:RCV with TX, RCV one of "
                f"{', '.join(POLARIZATIONS)} (e.g. 'V:V', 'H:V')"
            )

    def to_attrs(self) -> dict:
        """HDF5 attributes: every set field (None ones are left out) and a JSON ``units`` map."""
        out = {}
        for f in dataclasses.fields(self):
            v = getattr(self, f.name)
            if v is None:
                continue
            out[f.name] = np.asarray(v, dtype=float) if f.name == "scene_center" else v
        out["units"] = json.dumps({k: RADAR_UNITS[k] for k in out if k in RADAR_UNITS})
        return out

    @classmethod
    def from_attrs(cls, attrs: Mapping[str, Any], where: str = "radar") -> RadarMetadata:
        """Read back :meth:`to_attrs`; a missing or mistyped attribute is named with ``where``."""
        kwargs = {}
        for f in dataclasses.fields(cls):
            if f.name not in attrs:
                if f.default is dataclasses.MISSING:
                    raise InputError(f"{where}: missing attribute {f.name!r}")
                continue
            v = attrs[f.name]
            kwargs[f.name] = _attr_as(f.name, v, where)
        try:
            meta = cls(**kwargs)
            meta.validate()
        except InputError as exc:
            msg = str(exc)
            if msg.startswith("radar."):  # name the file and the attribute: "<file>: radar: attribute 'prf': ..."
                key, _, rest = msg[len("radar.") :].partition(":")
                raise InputError(f"{where}: attribute {key!r}:{rest}") from None
            raise InputError(f"{where}: {msg}") from None
        return meta

    def replace(self, **changes: Any) -> RadarMetadata:
        return dataclasses.replace(self, **changes)

    def to_json(self) -> str:
        return json.dumps(dataclasses.asdict(self))


# Units of the radar attributes (CF/UDUNITS spellings), stored as the group's JSON ``units`` map.
RADAR_UNITS = {
    "carrier_frequency": "Hz",
    "bandwidth": "Hz",
    "pulse_duration": "s",
    "chirp_rate": "Hz/s",
    "range_sampling_rate": "Hz",
    "prf": "Hz",
    "velocity": "m/s",
    "altitude": "m",
    "squint": "rad",
    "reference_range": "m",
    "scene_center": "m",
    "mode": "",
    "azimuth_beamwidth": "rad",
    "elevation_beamwidth": "rad",
    "aperture_time": "s",
    "n_channels": "1",
    "beam_rotation_range": "m",
    "reference_utc": "UTC (ISO 8601)",
    "reference_latitude": "rad",
    "reference_longitude": "rad",
    "reference_height": "m",
    "polarization": "",
    "antenna_pattern": "",
}

_STRING_FIELDS = ("mode", "reference_utc", "polarization", "antenna_pattern")

# single polarisations of SICD/CPHD (NGA.STND.0024 PolarizationType, less the OTHER* free forms)
POLARIZATIONS = ("V", "H", "X", "Y", "S", "E", "RHC", "LHC")
POLARIZATION_RE = re.compile(r"(V|H|X|Y|S|E|RHC|LHC):(V|H|X|Y|S|E|RHC|LHC)")


def _attr_as(name: str, v: object, where: str) -> Any:
    """One radar attribute converted to its field's type; a wrong type names the attribute."""
    if isinstance(v, bytes):
        try:
            v = v.decode()
        except UnicodeDecodeError:
            raise InputError(f"{where}: attribute {name!r} is not UTF-8 text") from None
    arr = np.asarray(v)
    if name in _STRING_FIELDS:
        if not isinstance(v, str):
            raise InputError(f"{where}: attribute {name!r} must be a string, got {arr.dtype} {v!r}")
        return v
    unit = RADAR_UNITS.get(name, "")
    if arr.dtype.kind not in "fiu":
        raise InputError(
            f"{where}: attribute {name!r} must be a number{' in ' + unit if unit not in ('', '1') else ''}"
            f", got {arr.dtype.name} {v!r}; store it as a float in SI"
        )
    if name == "scene_center":
        if arr.size != 3:
            raise InputError(f"{where}: attribute 'scene_center' must hold 3 numbers (x, y, z) m, got {arr.size}")
        xyz = tuple(float(a) for a in arr.astype(float).reshape(3))
        if not all(math.isfinite(a) for a in xyz):
            raise InputError(f"{where}: attribute 'scene_center' must be finite, got {xyz}")
        return xyz
    if arr.size != 1:
        raise InputError(f"{where}: attribute {name!r} must be a single number, got shape {arr.shape}")
    if name == "n_channels":
        if arr.dtype.kind == "f" and not float(arr).is_integer():
            raise InputError(f"{where}: attribute 'n_channels' must be an integer, got {v!r}")
        return int(arr)
    out = float(arr)
    if not math.isfinite(out):
        raise InputError(f"{where}: attribute {name!r} must be finite, got {out!r}")
    return out


def parse_utc(text: str, where: str = "reference time") -> str:
    """ISO 8601 time with a zone (or 'Z') -> canonical UTC string 'YYYY-MM-DDTHH:MM:SS.ffffffZ'."""
    import datetime as dt

    s = str(text).strip()
    try:
        t = dt.datetime.fromisoformat(s[:-1] + "+00:00" if s.endswith(("Z", "z")) else s)
    except ValueError:
        raise InputError(
            f"{where}: cannot read {text!r} as an ISO 8601 time; write e.g. '2024-05-01T10:00:00Z'"
        ) from None
    if t.tzinfo is None:
        raise InputError(f"{where}: {text!r} has no time zone; append 'Z' for UTC")
    return t.astimezone(dt.UTC).strftime("%Y-%m-%dT%H:%M:%S.%fZ")


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
            f"geometry.reference_range: {reference_range:g} m at geometry.squint {math.degrees(squint):.3g} deg "
            f"does not reach the ground from platform.altitude {altitude:g} m; the slant range must exceed "
            f"{altitude / max(math.cos(squint), 1e-12):.6g} m"
        )
    return (reference_range * math.sin(squint), math.sqrt(across), 0.0)


FORMAT_VERSION = _FORMAT_VERSION
