"""Where a moving target appears in an image focused as if the scene were static.

A processor that assumes a static scene (``backproject``) places a moving target at the static
point S whose range history matches the target's at its beam-centre time t_c in range and
range rate (R(t_c) and R'(t_c)): the familiar azimuth displacement of about R v_los / v (the
"train off the track"). The reconstruct stage also removes the target's range-acceleration
difference (its along-track velocity), so S is where the focused response lies; tests and
reports compare positions with S. With the platform at P(t_c) moving at v along +x and S on
z = 0: S = P(t_c) + R u, u_x = -R'(t_c) / v, u_z = -H / R, u_y = +sqrt(1 - u_x^2 - u_z^2).
"""

from __future__ import annotations

import numpy as np

from sarproc.product import beam
from sarproc.product.frames import targets_in_frame
from sarproc.product.metadata import RadarMetadata


def beam_centre_time(radar: RadarMetadata, times: np.ndarray, xyz, velocity) -> float:
    """Pulse time at which the moving point crosses the beam centre (spotlight, no beam: t = 0)."""
    xyz, velocity = np.asarray(xyz, float), np.asarray(velocity, float)
    if radar.mode == "spotlight" or radar.azimuth_beamwidth <= 0:
        return 0.0
    t = np.asarray(times, float)
    pos = np.stack([radar.velocity * t, np.zeros_like(t), np.full_like(t, radar.altitude)], axis=1)
    tg = (xyz[None, :] + t[:, None] * velocity[None, :])[:, None, :]
    az, _ = beam.off_boresight_angles(beam.boresight(radar, pos), pos, tg)
    az = az[:, 0]
    k = np.nonzero(np.diff(np.sign(az)) != 0)[0]
    if len(k) == 0:
        return float(t[np.argmin(np.abs(az))])
    i = int(k[0])
    return float(t[i] - az[i] * (t[i + 1] - t[i]) / (az[i + 1] - az[i]))


def static_equivalent(radar: RadarMetadata, xyz, velocity, t_c: float) -> np.ndarray:
    """The static point S with the moving target's range and range rate at time t_c (module docstring)."""
    xyz, velocity = np.asarray(xyz, float), np.asarray(velocity, float)
    p = np.array([radar.velocity * t_c, 0.0, radar.altitude])
    d = xyz + velocity * t_c - p
    r = float(np.linalg.norm(d))
    rdot = float(d @ (velocity - np.array([radar.velocity, 0.0, 0.0]))) / r
    ux = -rdot / radar.velocity
    uz = -radar.altitude / r
    uy = np.sqrt(max(0.0, 1.0 - ux**2 - uz**2))
    return p + r * np.array([ux, uy, uz])


def apparent_targets(targets: np.ndarray, radar: RadarMetadata, times: np.ndarray, frame) -> np.ndarray:
    """Copy of a targets table with every moving target moved to its static equivalent S (in ``frame``)."""
    out = np.array(targets, copy=True)
    for k in range(len(out)):
        vel = np.array([out["vx"][k], out["vy"][k], out["vz"][k]], float)
        if not np.any(vel != 0):
            continue
        xyz = np.array([out["x"][k], out["y"][k], out["z"][k]], float)
        s = static_equivalent(radar, xyz, vel, beam_centre_time(radar, times, xyz, vel))
        out["x"][k], out["y"][k], out["z"][k] = s
    return targets_in_frame(out, frame)
