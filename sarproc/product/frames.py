"""Image frames: named coordinate systems mapping image axes to scene (x, y, z) positions.

Every image stores its frame as a JSON spec (``{"name": ..., params}``) in the ``frame``
attribute, so evaluate and backproject can map targets and pixels. New frames register
themselves with :func:`register_frame` (paper 004 adds a 3D elevation frame this way).

Frames (2D ones map onto z = 0 except ``los``, which is the slant plane):
  squint: paper 000's frame. (azimuth, range) = (x_n, r_0): r_0 is the distance from the
          track point (x_n, 0, H) along the ray squinted by ``squint`` to the target on z = 0,
          so P = (x_n + r_0 sin(theta), sqrt((r_0 cos(theta))^2 - H^2), 0). squint = 0 gives
          the zero-Doppler (closest approach) frame.
  squint_lrwc: (x_n, r_0 + x_n sin(theta)), the squint frame before paper 000's final range shift.
  ground: (azimuth, range) = (x, y) on z = 0.
  los:    slant-plane Cartesian frame of a spotlight aperture: ``range`` is slant range from
          the aperture centre measured along the line of sight to the scene centre, ``azimuth``
          the distance from the scene centre along the velocity direction orthogonal to it.
  ground_los: paper 002's ground frame (x', y') (Nie 2016, eq. 6): on z = 0, ``range`` along the
          ground projection of the line of sight from the aperture centre to the origin (ground
          range from the aperture centre's nadir), ``azimuth`` across it, (azimuth, range, up)
          right-handed. The polar-format images live here.
"""

from __future__ import annotations

import abc
import json
import math
from typing import TYPE_CHECKING

import numpy as np

from sarproc.product.errors import InputError
from sarproc.product.metadata import RadarMetadata, aperture_center_position

if TYPE_CHECKING:
    from collections.abc import Callable, Mapping
    from typing import Any

    import numpy.typing as npt

_FRAMES: dict[str, type] = {}


def register_frame(name: str) -> Callable[[type[Frame]], type[Frame]]:
    def deco(cls: type[Frame]) -> type[Frame]:
        cls.name = name
        _FRAMES[name] = cls
        return cls

    return deco


class Frame(abc.ABC):
    """Base class. ``axes`` names the image axes in the order of ``to_xyz`` arguments."""

    name = "base"
    axes: tuple[str, ...] = ("azimuth", "range")

    @abc.abstractmethod
    def to_xyz(self, *coords: Any) -> np.ndarray:  # subclasses name their axes (azimuth, range_, ...)
        """Scene positions (..., 3) of points given by their frame coordinates."""

    @abc.abstractmethod
    def from_xyz(self, xyz: np.ndarray) -> tuple[np.ndarray, ...]:
        """Frame coordinates, one array per axis, of scene positions (..., 3)."""

    def params(self) -> dict:
        return {}

    def metric(self) -> np.ndarray | None:
        """Local basis of the image plane: row a is the displacement (m) per unit of axis a, or None
        when the axes are not lengths. Quality metrics use it to give widths along oblique cuts."""
        return None

    @property
    def spec(self) -> dict:
        return {"name": self.name, **self.params()}

    def to_json(self) -> str:
        return json.dumps(self.spec)


@register_frame("squint")
class SquintFrame(Frame):
    axes = ("azimuth", "range")

    def __init__(self, squint: float, altitude: float = 0.0) -> None:
        self.squint = float(squint)
        self.altitude = float(altitude)

    def params(self) -> dict:
        return {"squint": self.squint, "altitude": self.altitude}

    def metric(self) -> np.ndarray:
        # slant plane: x_n along track, r_0 along the squinted ray (skewed axes)
        s, c = math.sin(self.squint), math.cos(self.squint)
        return np.array([[1.0, 0.0], [s, c]])

    def to_xyz(self, azimuth: npt.ArrayLike, range_: npt.ArrayLike) -> np.ndarray:
        azimuth, range_ = np.broadcast_arrays(np.asarray(azimuth, float), np.asarray(range_, float))
        s, c = math.sin(self.squint), math.cos(self.squint)
        across2 = (range_ * c) ** 2 - self.altitude**2
        if np.any(across2 < 0):
            raise InputError("squint frame: a range is shorter than the altitude allows")
        return np.stack([azimuth + range_ * s, np.sqrt(across2), np.zeros_like(azimuth)], axis=-1)

    def from_xyz(self, xyz: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        xyz = np.asarray(xyz, float)
        rho = np.hypot(xyz[..., 1], self.altitude - xyz[..., 2])
        r0 = rho / math.cos(self.squint)
        return xyz[..., 0] - r0 * math.sin(self.squint), r0


@register_frame("squint_lrwc")
class SquintLrwcFrame(Frame):
    """Paper 000's frame before the final range correction: (x_n, r_0 + x_n sin(theta)).

    The range axis is the range after linear range-walk correction (about the range from the
    aperture centre); the fast chain's point response is separable along these axes, so
    quality metrics are read here while positions are read in the ``squint`` frame.
    """

    axes = ("azimuth", "range")

    def __init__(self, squint: float, altitude: float = 0.0) -> None:
        self.base = SquintFrame(squint, altitude)
        self.squint, self.altitude = float(squint), float(altitude)

    def params(self) -> dict:
        return {"squint": self.squint, "altitude": self.altitude}

    def metric(self) -> np.ndarray:
        # x_n at fixed r_0 + x_n sin(theta) moves across the line of sight: (c^2, -s c)
        s, c = math.sin(self.squint), math.cos(self.squint)
        return np.array([[c * c, -s * c], [s, c]])

    def to_xyz(self, azimuth: npt.ArrayLike, range_: npt.ArrayLike) -> np.ndarray:
        az = np.asarray(azimuth, float)
        return self.base.to_xyz(az, np.asarray(range_, float) - az * math.sin(self.squint))

    def from_xyz(self, xyz: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        xn, r0 = self.base.from_xyz(xyz)
        return xn, r0 + xn * math.sin(self.squint)


@register_frame("ground")
class GroundFrame(Frame):
    axes = ("azimuth", "range")

    def metric(self) -> np.ndarray:
        return np.eye(2)

    def to_xyz(self, azimuth: npt.ArrayLike, range_: npt.ArrayLike) -> np.ndarray:
        azimuth, range_ = np.broadcast_arrays(np.asarray(azimuth, float), np.asarray(range_, float))
        return np.stack([azimuth, range_, np.zeros_like(azimuth)], axis=-1)

    def from_xyz(self, xyz: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        xyz = np.asarray(xyz, float)
        return xyz[..., 0].copy(), xyz[..., 1].copy()


class _PlaneFrame(Frame):
    """A plane through ``origin`` with orthonormal axes u_azimuth, u_range; range counted from ``range0``.

    Subclasses set origin, aperture_center, u_azimuth, u_range and range0 (m).
    """

    axes = ("azimuth", "range")
    origin: np.ndarray
    aperture_center: np.ndarray
    u_azimuth: np.ndarray
    u_range: np.ndarray
    range0: float

    def params(self) -> dict:
        return {"origin": self.origin.tolist(), "aperture_center": self.aperture_center.tolist()}

    def metric(self) -> np.ndarray:
        return np.eye(2)

    def to_xyz(self, azimuth: npt.ArrayLike, range_: npt.ArrayLike) -> np.ndarray:
        azimuth, range_ = np.broadcast_arrays(np.asarray(azimuth, float), np.asarray(range_, float))
        along = range_ - self.range0
        # one coordinate at a time (same values): broadcasting onto a last axis of 3 runs numpy's inner loops
        # 3 elements per call, 1.5x slower on a 2048^2 grid
        return np.stack(
            [self.origin[k] + azimuth * self.u_azimuth[k] + along * self.u_range[k] for k in range(3)], axis=-1
        )

    def from_xyz(self, xyz: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        d = np.asarray(xyz, float) - self.origin
        return d @ self.u_azimuth, self.range0 + d @ self.u_range


@register_frame("los")
class LosFrame(_PlaneFrame):
    def __init__(
        self, origin: npt.ArrayLike, aperture_center: npt.ArrayLike, velocity_dir: npt.ArrayLike = (1.0, 0.0, 0.0)
    ) -> None:
        self.origin = np.asarray(origin, float).reshape(3)
        self.aperture_center = np.asarray(aperture_center, float).reshape(3)
        los = self.origin - self.aperture_center
        self.reference_range = float(np.linalg.norm(los))
        self.u_range = los / self.reference_range
        v = np.asarray(velocity_dir, float).reshape(3)
        u_az = v - np.dot(v, self.u_range) * self.u_range
        self.u_azimuth = u_az / np.linalg.norm(u_az)
        self.range0 = self.reference_range


@register_frame("ground_los")
class GroundLosFrame(_PlaneFrame):
    """Ground plane rotated onto the aperture centre's line of sight (Nie 2016, eq. 6).

    e_r is the unit ground projection of origin - aperture_center, e_a = e_r x z (so that
    e_a x e_r = z); azimuth = (P - origin) . e_a, range = R_g + (P - origin) . e_r with R_g the
    ground distance from the aperture centre's nadir to the origin. Points map onto z = origin z.
    """

    def __init__(self, origin: npt.ArrayLike, aperture_center: npt.ArrayLike) -> None:
        self.origin = np.asarray(origin, float).reshape(3)
        self.aperture_center = np.asarray(aperture_center, float).reshape(3)
        d = self.origin[:2] - self.aperture_center[:2]
        self.ground_range = float(np.hypot(*d))
        if not self.ground_range > 0:
            raise InputError("ground_los frame: the aperture centre is above the origin (no ground line of sight)")
        er = d / self.ground_range
        self.u_range = np.array([er[0], er[1], 0.0])
        self.u_azimuth = np.array([er[1], -er[0], 0.0])
        self.range0 = self.ground_range

    @property
    def rotation(self) -> float:
        """Angle of e_r from +y towards +x, rad (the ground squint theta_0 of eq. 6)."""
        return float(math.atan2(self.u_range[0], self.u_range[1]))


@register_frame("elevation")
class ElevationFrame(Frame):
    """Paper 004's cylindrical frame about the platform track (Du 2010, eq. 3), 3D.

    Axes (elevation, azimuth, range): elevation is the across-track angle from nadir in rad
    (positive towards +y), azimuth is x, range the slant distance from the track (x, 0, H):
    P = (x, r sin(elevation), H - r cos(elevation)).
    """

    axes = ("elevation", "azimuth", "range")

    def __init__(self, altitude: float) -> None:
        self.altitude = float(altitude)

    def params(self) -> dict:
        return {"altitude": self.altitude}

    def to_xyz(self, elevation: npt.ArrayLike, azimuth: npt.ArrayLike, range_: npt.ArrayLike) -> np.ndarray:
        el, az, r = np.broadcast_arrays(
            np.asarray(elevation, float), np.asarray(azimuth, float), np.asarray(range_, float)
        )
        return np.stack([az, r * np.sin(el), self.altitude - r * np.cos(el)], axis=-1)

    def from_xyz(self, xyz: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        xyz = np.asarray(xyz, float)
        down = self.altitude - xyz[..., 2]
        return np.arctan2(xyz[..., 1], down), xyz[..., 0].copy(), np.hypot(xyz[..., 1], down)


def frame_from_spec(spec: str | bytes | Mapping[str, Any]) -> Frame:
    """Rebuild a frame from its JSON spec (a dict or a JSON string)."""
    fields = dict(json.loads(spec) if isinstance(spec, (bytes, str)) else spec)
    name = fields.pop("name", None)
    if name not in _FRAMES:
        raise InputError(f"unknown image frame {name!r}; known: {sorted(_FRAMES)}")
    return _FRAMES[name](**fields)


def make_frame(name: str, radar: RadarMetadata, **params: Any) -> Frame:
    """A frame with parameters taken from the radar geometry unless given."""
    if name == "squint":
        return SquintFrame(params.get("squint", radar.squint), params.get("altitude", radar.altitude))
    if name == "squint_lrwc":
        return SquintLrwcFrame(params.get("squint", radar.squint), params.get("altitude", radar.altitude))
    if name == "zero_doppler":
        return SquintFrame(0.0, params.get("altitude", radar.altitude))
    if name == "ground":
        return GroundFrame()
    if name == "los":
        return LosFrame(
            params.get("origin", radar.scene_center), params.get("aperture_center", aperture_center_position(radar))
        )
    if name == "ground_los":
        return GroundLosFrame(
            params.get("origin", radar.scene_center), params.get("aperture_center", aperture_center_position(radar))
        )
    if name == "elevation":
        return ElevationFrame(params.get("altitude", radar.altitude))
    if name in _FRAMES:
        return _FRAMES[name](**params)
    raise InputError(f"unknown image frame {name!r}; known: {sorted(_FRAMES) + ['zero_doppler']}")


def frame_coordinates(frame: Frame, xyz: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(azimuth, range, elevation) of points ``xyz`` (n, 3) in ``frame``; zeros for axes it lacks."""
    xyz = np.asarray(xyz, float).reshape(-1, 3)
    values = dict(zip(frame.axes, frame.from_xyz(xyz))) if len(xyz) else {}
    zero = np.zeros(len(xyz))
    az, rg, el = (np.asarray(values.get(ax, zero), float) for ax in ("azimuth", "range", "elevation"))
    return az, rg, el


def targets_in_frame(targets: np.ndarray, frame: Frame) -> np.ndarray:
    """A copy of a targets table with (azimuth, range, elevation) recomputed in ``frame`` (and its ``ridge_angle``,
    a frame's, 0: not recorded)."""
    out = np.array(targets, copy=True)
    if "ridge_angle" in (out.dtype.names or ()):
        out["ridge_angle"] = 0.0
    xyz = np.stack([out["x"], out["y"], out["z"]], axis=-1)
    for name, values in zip(("azimuth", "range", "elevation"), frame_coordinates(frame, xyz)):
        out[name] = values
    return out


def image_axis(
    values: np.ndarray,
    irw: float,
    oversample: float,
    margin_cells: float,
    spacing: float | None = None,
    centre: float | None = None,
    extent: float | None = None,
    default_centre: float = 0.0,
    finest: float | None = None,
) -> tuple[float, float, int]:
    """(centre, spacing, pixels) of one axis of a focuser's image grid, the rule backproject and pfa2 share.

    ``values``: the targets' coordinates on the axis; ``irw``: the image's theoretical IRW there. Unset
    keys default to: spacing min(irw, ``finest``) / oversample (``finest``: the finest target's own IRW),
    centre the middle of the targets (``default_centre`` without targets), extent the targets' span plus
    margin_cells IRWs each side. At least two pixels; pixel i lies at centre + (i - pixels // 2) spacing.
    """
    spacing = spacing or min(irw, irw if finest is None else finest) / oversample
    if centre is None:
        centre = float((values.min() + values.max()) / 2) if len(values) else default_centre
    if extent is None:
        span = float(values.max() - values.min()) if len(values) else 0.0
        extent = span + 2 * margin_cells * irw
    return centre, spacing, max(2, int(math.ceil(extent / spacing)))


def frame_names() -> list[str]:
    return sorted(_FRAMES) + ["zero_doppler"]
