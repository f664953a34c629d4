"""Placing the local scene frame on the Earth (WGS84) and in absolute time, for the standard formats.

The scene frame (metadata.py) is a flat local frame: x along the flight track, z up, the scene centre
on z = 0. Standard formats (SICD, CPHD) need Earth-centred, Earth-fixed (ECF) positions and UTC times.
The frame is placed rigidly: its scene centre goes to the WGS84 point (latitude, longitude, height),
z along the ellipsoid normal there, x at ``heading`` clockwise from north (y = z x x). A rigid map keeps
every range and angle of the simulation, so data exported this way focus exactly as they did locally;
far from the centre the flat z = 0 plane departs from the ellipsoid (about d^2 / 2R: 0.8 m at 3 km).

Where these come from, first found wins: the export's own parameters (``--config``, section
``geolocation:``), the product's radar metadata (the scene YAML's ``reference:`` section), then the
documented defaults below (logged as a warning, since a file placed by default is placed nowhere real).
"""

from __future__ import annotations

import dataclasses
import datetime as dt
import logging
import math

import numpy as np
from numpy.typing import ArrayLike

from sarproc.product.config import param
from sarproc.product.metadata import RadarMetadata, parse_utc

log = logging.getLogger(__name__)

DEFAULT_UTC = "2000-01-01T12:00:00.000000Z"  # J2000 epoch: obviously not a real collection
DEFAULT_LAT_LON_HEIGHT = (0.0, 0.0, 0.0)  # rad, rad, m: "null island"

# WGS84 ellipsoid (NGA.STND.0036)
_A = 6378137.0
_F = 1.0 / 298.257223563
_E2 = _F * (2.0 - _F)


@dataclasses.dataclass(frozen=True)
class GeolocationParams:
    time: str | None = param(
        default=None,
        doc="UTC of azimuth time 0, ISO 8601 with a zone (default: the product's reference, else 2000-01-01T12:00:00Z)",
    )
    latitude: float | None = param(
        "angle",
        default=None,
        ge=-math.pi / 2,
        le=math.pi / 2,
        doc="WGS84 latitude of the scene centre (default: the product's, else 0)",
    )
    longitude: float | None = param(
        "angle",
        default=None,
        ge=-math.pi,
        le=math.pi,
        doc="WGS84 longitude of the scene centre (default: the product's, else 0)",
    )
    height: float | None = param("length", default=None, doc="height above the ellipsoid (default: product's, else 0)")
    heading: float = param(
        "angle",
        default=0.0,
        ge=-2 * math.pi,
        le=2 * math.pi,
        doc="direction of the flight track (+x), clockwise from north",
    )


def geodetic_to_ecf(lat: float, lon: float, height: float) -> np.ndarray:
    """WGS84 geodetic (rad, rad, m) -> ECF (m)."""
    n = _A / math.sqrt(1.0 - _E2 * math.sin(lat) ** 2)
    return np.array(
        [
            (n + height) * math.cos(lat) * math.cos(lon),
            (n + height) * math.cos(lat) * math.sin(lon),
            (n * (1.0 - _E2) + height) * math.sin(lat),
        ]
    )


def ecf_to_geodetic(xyz: np.ndarray) -> np.ndarray:
    """ECF (..., 3) m -> (..., 3) latitude (rad), longitude (rad), height (m); Bowring's iteration to 1e-12."""
    xyz = np.asarray(xyz, float)
    x, y, z = xyz[..., 0], xyz[..., 1], xyz[..., 2]
    lon = np.arctan2(y, x)
    p = np.hypot(x, y)
    lat = np.arctan2(z, p * (1.0 - _E2))
    for _ in range(10):
        n = _A / np.sqrt(1.0 - _E2 * np.sin(lat) ** 2)
        h = p / np.cos(lat) - n
        lat = np.arctan2(z, p * (1.0 - _E2 * n / (n + h)))
    n = _A / np.sqrt(1.0 - _E2 * np.sin(lat) ** 2)
    h = p / np.cos(lat) - n
    return np.stack([lat, lon, h], axis=-1)


@dataclasses.dataclass(frozen=True)
class Placement:
    """Rigid map scene frame -> ECF, and azimuth time -> UTC."""

    utc: str  # UTC of azimuth time 0, 'YYYY-MM-DDTHH:MM:SS.ffffffZ'
    lat_lon_height: tuple  # of the scene centre: rad, rad, m
    heading: float  # rad
    anchor: np.ndarray  # scene-frame point placed at the reference (the scene centre), m
    origin_ecf: np.ndarray  # its ECF position, m
    rotation: np.ndarray  # (3, 3): columns are the scene frame's x, y, z axes in ECF

    def to_ecf(self, xyz: np.ndarray) -> np.ndarray:
        return self.origin_ecf + (np.asarray(xyz, float) - self.anchor) @ self.rotation.T

    def vector_to_ecf(self, v: ArrayLike) -> np.ndarray:
        return np.asarray(v, float) @ self.rotation.T

    def from_ecf(self, ecf: np.ndarray) -> np.ndarray:
        return self.anchor + (np.asarray(ecf, float) - self.origin_ecf) @ self.rotation

    def datetime64(self, seconds: float = 0.0) -> np.datetime64:
        """Absolute time of azimuth time ``seconds`` (ns precision)."""
        t0 = np.datetime64(self.utc.rstrip("Z"), "ns")
        return t0 + np.timedelta64(int(round(seconds * 1e9)), "ns")


def enu_axes(lat: float, lon: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """East, north and up unit vectors (ECF) at a geodetic point (up = ellipsoid normal)."""
    east = np.array([-math.sin(lon), math.cos(lon), 0.0])
    north = np.array([-math.sin(lat) * math.cos(lon), -math.sin(lat) * math.sin(lon), math.cos(lat)])
    up = np.array([math.cos(lat) * math.cos(lon), math.cos(lat) * math.sin(lon), math.sin(lat)])
    return east, north, up


def placement(radar: RadarMetadata, params: GeolocationParams = GeolocationParams()) -> Placement:
    """Where and when the product's scene frame is, from ``params``, the radar metadata, or the defaults."""
    defaulted = []
    utc = params.time or radar.reference_utc
    if utc is None:
        utc = DEFAULT_UTC
        defaulted.append(f"time {DEFAULT_UTC}")
    utc = parse_utc(utc, "geolocation.time")
    geo = (params.latitude, params.longitude, params.height)
    if geo[0] is None:
        geo = (radar.reference_latitude, radar.reference_longitude, radar.reference_height)
    if geo[0] is None:
        geo = DEFAULT_LAT_LON_HEIGHT
        defaulted.append("scene centre at latitude 0, longitude 0, height 0")
    lat, lon, height = geo[0], geo[1], geo[2] if geo[2] is not None else 0.0
    assert lat is not None and lon is not None  # given together (GeolocationParams, RadarMetadata checks)
    if defaulted:
        log.warning(
            "no absolute reference in the product or the config (geolocation:, or the scene's reference:); using %s",
            " and ".join(defaulted),
        )
    east, north, up = enu_axes(lat, lon)
    ex = math.cos(params.heading) * north + math.sin(params.heading) * east
    ey = np.cross(up, ex)
    return Placement(
        utc=utc,
        lat_lon_height=(lat, lon, height),
        heading=params.heading,
        anchor=np.asarray(radar.scene_center, float),
        origin_ecf=geodetic_to_ecf(lat, lon, height),
        rotation=np.stack([ex, ey, up], axis=1),
    )


def utc_string(t: np.datetime64) -> str:
    """numpy datetime64 -> ISO 8601 UTC with microseconds."""
    return dt.datetime.fromisoformat(str(np.datetime_as_string(t, unit="us"))).strftime("%Y-%m-%dT%H:%M:%S.%fZ")


def utc_datetime(t: np.datetime64) -> dt.datetime:
    """numpy datetime64 -> timezone-aware datetime (UTC, microseconds), as sarkit's XML dates take them."""
    return dt.datetime.fromisoformat(utc_string(t).replace("Z", "+00:00"))
