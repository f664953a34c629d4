"""Where a moving point target appears in an image focused as if the scene were static, and back.

A processor that assumes a static scene (``backproject``; ``reconstruct``'s output, which holds a
moving target as a static point would appear) places a point target moving at constant velocity V
at the **static-equivalent point S**: the static point whose range R and range rate R' from the
antenna phase centre equal the target's at its **illumination-centre time t_c**, the centre of
the pulses whose -3 dB azimuth beam contains the moving target (clipped to the data window; the
middle of the data without an azimuth beam or in spotlight). At t_c the target is at
T_c = T_0 + V t_c (T_0: its position at azimuth time 0, the targets table's x, y, z). With the
phase centre at P = P(t_c) flying along +x at speed v (the radar metadata's track):

    R  = |T_c - P|,    R' = (T_c - P) . (V - v e_x) / R = u_T . V - v u_T,x,    u_T = (T_c - P) / R
    S  = P + R u_S,    u_S,x = -R' / v = u_T,x - u_T . V / v,
                       u_S,z = (z(T_c) - P_z) / R  (S at the target's height),  u_S,y: unit length, same side.

This is exact given t_c (range and Doppler centroid match); the range acceleration of a target
with an along-track velocity differs from S's, which defocuses it in a single-channel image
(symmetrically about S) and is removed about t_c by ``reconstruct``'s modified reconstruction.

First order, slant plane (altitude 0), beam-centre squint theta (+ forward), v_r the slant-range
(zero-Doppler, +y) velocity and v_a the along-track one: the line-of-sight velocity
v_los = u_T . V = v_r cos(theta) + v_a sin(theta) turns the look direction by -v_los / (v cos(theta)),
so S lies on the circle of radius R about P(t_c):

    scene:        dx = -R v_los / v,                  dy = +R v_los tan(theta) / v
    squint frame: d azimuth (x_n) = -R v_los / (v cos^2(theta)),
                  d range (r_0)   = +R v_los sin(theta) / (v cos^2(theta))

plus the target's own motion V t_c between azimuth time 0 and t_c (``first_order_shift``). At
broadside the shift is purely along track (-R v_r / v: the "train off the track"); under squint
v_a contributes through sin(theta) and the range shifts too. B of configs/xu_scene.yaml (v_r 10 m/s,
R 600 km, 20 deg): -851.5 m in azimuth, +291.7 m in range.

``relocate`` inverts the map: from an apparent position and a velocity (estimated or true), the
position at azimuth time 0 whose static equivalent it is. ``slant_velocity`` / ``scene_velocity``
convert between the scene velocity (vx, vy, vz) and the processor's (v_a, v_r) for a target on
the ground (vz = 0): v_r is the velocity along the zero-Doppler slant-range direction from the track
point (x, 0, H), v_r = vy y / sqrt(y^2 + (H - z)^2).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from sarproc.product import beam
from sarproc.product.errors import InputError
from sarproc.product.frames import targets_in_frame
from sarproc.product.metadata import RadarMetadata

if TYPE_CHECKING:
    from sarproc.product.frames import Frame
    from sarproc.product.model import Product


def nominal_track(radar: RadarMetadata, times: np.ndarray) -> np.ndarray:
    """(n, 3) platform positions of the radar metadata's track: (v t, 0, H)."""
    t = np.asarray(times, float)
    return np.stack([radar.velocity * t, np.zeros_like(t), np.full_like(t, radar.altitude)], axis=-1)


def pulse_times(product: Product) -> np.ndarray:
    """Pulse times (s) of a product: its azimuth_time axis, else its track's x / v (images keep the track)."""
    if "azimuth_time" in product.coords:
        return np.asarray(product.coords["azimuth_time"], float)
    pos = product.aux.get("platform_position")
    if pos is None:
        raise InputError(
            "product has neither an azimuth_time axis nor aux platform_position: "
            "the pulse times of its moving targets are unknown"
        )
    return np.asarray(pos, float)[:, 0] / product.radar.velocity


def phase_centres(product: Product) -> np.ndarray:
    """(n, 3) mean two-way phase centre per pulse: platform + (tx offset + mean rx offset) / 2."""
    pos = np.asarray(product.aux["platform_position"], float)
    tx = np.asarray(product.aux.get("tx_offset", np.zeros(3)), float).reshape(3)
    rx = np.asarray(product.aux.get("rx_offset", np.zeros((1, 3))), float).reshape(-1, 3)
    return pos + (tx + rx.mean(axis=0)) / 2


def _crossing(t: np.ndarray, angle: np.ndarray, level: float, i: int, j: int) -> float:
    """Time between pulses i and j where ``angle`` crosses ``level`` (linear between them)."""
    if angle[j] == angle[i]:
        return float(t[i])
    return float(t[i] + (level - angle[i]) * (t[j] - t[i]) / (angle[j] - angle[i]))


def illumination_interval(
    radar: RadarMetadata,
    times: np.ndarray,
    xyz: np.ndarray,
    velocity: npt.ArrayLike,
    positions: np.ndarray | None = None,
) -> tuple[float, float]:
    """(start, end) times (s) of the pulses whose -3 dB azimuth beam holds the moving point.

    The beam edges are interpolated between pulses (so the result is continuous in the position);
    an illumination cut by the data window ends at the data's edge. No azimuth beam, or spotlight
    (the beam follows the scene): the whole data. A point the beam never holds: the pulse of the
    smallest off-boresight angle, twice.
    """
    t = np.asarray(times, float)
    xyz, velocity = np.asarray(xyz, float).reshape(3), np.asarray(velocity, float).reshape(3)
    if len(t) == 0:
        raise InputError("illumination_interval: no pulses")
    if radar.azimuth_beamwidth <= 0 or radar.mode == "spotlight":
        return float(t[0]), float(t[-1])
    pos = nominal_track(radar, t) if positions is None else np.asarray(positions, float)
    tg = (xyz[None, :] + t[:, None] * velocity[None, :])[:, None, :]
    az = np.abs(beam.off_boresight_angles(beam.boresight(radar, pos), pos, tg)[0][:, 0])
    half = radar.azimuth_beamwidth / 2
    lit = np.nonzero(az <= half)[0]
    if len(lit) == 0:
        return float(t[np.argmin(az)]), float(t[np.argmin(az)])
    first, last = int(lit[0]), int(lit[-1])
    start = _crossing(t, az, half, first - 1, first) if first > 0 else t[0]
    end = _crossing(t, az, half, last, last + 1) if last + 1 < len(t) else t[-1]
    return float(start), float(end)


def illumination_centre_time(
    radar: RadarMetadata,
    times: np.ndarray,
    xyz: np.ndarray,
    velocity: npt.ArrayLike,
    positions: np.ndarray | None = None,
) -> float:
    """Centre time (s) of the pulses whose -3 dB azimuth beam holds the moving point (module docstring):
    the middle of :func:`illumination_interval`."""
    start, end = illumination_interval(radar, times, xyz, velocity, positions)
    return float((start + end) / 2)


def static_equivalent(
    xyz_at_tc: np.ndarray, velocity: np.ndarray, platform_position: np.ndarray, platform_speed: float
) -> np.ndarray:
    """The static point S with the moving point's range and range rate from ``platform_position``.

    ``xyz_at_tc``: the target's position at that time; the platform flies along +x at ``platform_speed``.
    """
    t_c = np.asarray(xyz_at_tc, float).reshape(3)
    p = np.asarray(platform_position, float).reshape(3)
    d = t_c - p
    r = float(np.linalg.norm(d))
    u = d / r
    ux = u[0] - float(u @ np.asarray(velocity, float).reshape(3)) / platform_speed
    uz = u[2]
    across2 = 1.0 - ux**2 - uz**2
    if across2 < 0:
        raise InputError(
            f"moving target: range rate {-ux * platform_speed:.1f} m/s exceeds what a static point "
            f"can have at this elevation; no static-equivalent position"
        )
    uy = math.copysign(math.sqrt(across2), u[1] if u[1] != 0 else 1.0)
    return p + r * np.array([ux, uy, uz])


def _track_at(radar: RadarMetadata, times: np.ndarray, positions: np.ndarray | None, t_c: float) -> np.ndarray:
    if positions is None:
        return nominal_track(radar, np.array([t_c]))[0]
    pos = np.asarray(positions, float)
    t = np.asarray(times, float)
    return np.array([np.interp(t_c, t, pos[:, k]) for k in range(3)])


def apparent_position(
    radar: RadarMetadata,
    times: np.ndarray,
    xyz: npt.ArrayLike,
    velocity: npt.ArrayLike,
    positions: np.ndarray | None = None,
) -> tuple[np.ndarray, float]:
    """(S, t_c): where a point at ``xyz`` (time 0) moving at ``velocity`` appears, and its centre time.

    ``positions``: (n, 3) phase centres at ``times`` (default: the nominal track). A static point
    (zero velocity) is its own S.
    """
    xyz, velocity = np.asarray(xyz, float).reshape(3), np.asarray(velocity, float).reshape(3)
    t_c = illumination_centre_time(radar, times, xyz, velocity, positions)
    if not np.any(velocity != 0):
        return xyz.copy(), t_c
    p = _track_at(radar, times, positions, t_c)
    return static_equivalent(xyz + velocity * t_c, velocity, p, radar.velocity), t_c


RELOCATE_TOLERANCE = 1e-4  # m: relocate's fixed-point steps stop when the apparent position is matched this close


def relocate(
    radar: RadarMetadata,
    times: np.ndarray,
    apparent_xyz: npt.ArrayLike,
    velocity: npt.ArrayLike,
    positions: np.ndarray | None = None,
    tolerance: float = RELOCATE_TOLERANCE,
    max_iterations: int = 50,
) -> np.ndarray:
    """Position at azimuth time 0 of a point moving at ``velocity`` that appears at ``apparent_xyz``.

    Solves apparent_position(T_0) = S by fixed-point steps T_0 <- T_0 + (S - S(T_0)) (the map is a
    near-translation: its Jacobian differs from the identity by O(|V| / v)); stops at ``tolerance`` m.
    """
    s = np.asarray(apparent_xyz, float).reshape(3)
    velocity = np.asarray(velocity, float).reshape(3)
    if not np.any(velocity != 0):
        return s.copy()
    t0 = s.copy()
    for _ in range(max_iterations):
        err = s - apparent_position(radar, times, t0, velocity, positions)[0]
        t0 = t0 + err
        if float(np.linalg.norm(err)) < tolerance:
            return t0
    raise InputError(
        f"relocate: no position at time 0 appears at {s.tolist()} with velocity {velocity.tolist()} "
        f"(residual {float(np.linalg.norm(err)):.3g} m after {max_iterations} steps)"
    )


def apparent_targets(
    targets: np.ndarray, radar: RadarMetadata, times: np.ndarray, frame: Frame, positions: np.ndarray | None = None
) -> np.ndarray:
    """Copy of a targets table with every moving target at its static equivalent S (x, y, z and ``frame``)."""
    out = np.array(targets, copy=True)
    for k in range(len(out)):
        vel = np.array([out["vx"][k], out["vy"][k], out["vz"][k]], float)
        if np.any(vel != 0):
            s, _ = apparent_position(radar, times, [out["x"][k], out["y"][k], out["z"][k]], vel, positions)
            out["x"][k], out["y"][k], out["z"][k] = s
    return targets_in_frame(out, frame)


def is_moving(targets: np.ndarray) -> np.ndarray:
    """Boolean per row of a targets table: nonzero velocity."""
    return (targets["vx"] != 0) | (targets["vy"] != 0) | (targets["vz"] != 0)


def slant_velocity(xyz: np.ndarray, velocity: npt.ArrayLike, altitude: float) -> tuple[float, float]:
    """(v_a, v_r) of a scene velocity: along track, and along the zero-Doppler slant range from (x, 0, H)."""
    xyz, velocity = np.asarray(xyz, float).reshape(3), np.asarray(velocity, float).reshape(3)
    e = np.array([0.0, xyz[1], xyz[2] - altitude])
    e /= np.linalg.norm(e)
    return float(velocity[0]), float(velocity @ e)


def scene_velocity(xyz: np.ndarray, v_a: float, v_r: float, altitude: float) -> np.ndarray:
    """Scene velocity (vx, vy, 0) of a target on a horizontal surface with along-track v_a and slant-range v_r."""
    xyz = np.asarray(xyz, float).reshape(3)
    rho = math.hypot(xyz[1], xyz[2] - altitude)
    if xyz[1] == 0:
        raise InputError("scene_velocity: a target under the track has no slant-range velocity on the ground")
    return np.array([v_a, v_r * rho / xyz[1], 0.0])


def first_order_shift(
    radar: RadarMetadata, slant_range: float, v_a: float, v_r: float, squint: float | None = None
) -> tuple[float, float]:
    """(d azimuth, d range) in the squint frame, m, of S from the target at t_c (module docstring).

    Slant plane, beam-centre squint ``squint`` (default the radar's); a check and a rule of thumb,
    ``apparent_position`` is the exact model.
    """
    th = radar.squint if squint is None else squint
    v_los = v_r * math.cos(th) + v_a * math.sin(th)
    scale = slant_range * v_los / (radar.velocity * math.cos(th) ** 2)
    return -scale, scale * math.sin(th)
