"""Beam geometry shared by the antenna effect (simulation) and processors (theory, weighting).

Boresight per pulse for each acquisition mode, and the angles of targets off it: azimuth
(towards the velocity) and elevation (across it). Stripmap keeps the boresight of the aperture
centre (pointing at the scene centre at t = 0); spotlight points it at the scene centre every
pulse; sliding spotlight points it at a rotation point on the central line of sight at
``beam_rotation_range`` from the aperture centre.
"""

from __future__ import annotations

import numpy as np

from sarproc.product.errors import InputError
from sarproc.product.metadata import SINC_IRW_FACTOR, RadarMetadata


def boresight(radar: RadarMetadata, platform_pos: np.ndarray) -> np.ndarray:
    """(n_t, 3) unit boresight vectors for platform positions (n_t, 3)."""
    centre = np.asarray(radar.scene_center, float)
    ap = np.array([0.0, 0.0, radar.altitude])
    los = (centre - ap) / np.linalg.norm(centre - ap)
    if radar.mode == "stripmap":
        return np.broadcast_to(los, platform_pos.shape)
    if radar.mode == "spotlight":
        aim = centre
    elif radar.mode == "sliding_spotlight":
        if not radar.beam_rotation_range > 0:
            raise InputError("radar.beam_rotation_range: sliding spotlight needs a positive rotation range")
        aim = ap + los * radar.beam_rotation_range
    else:
        raise InputError(f"radar.mode: unknown acquisition mode {radar.mode!r}")
    d = aim - platform_pos
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


def off_boresight_angles(
    bore: np.ndarray, platform_pos: np.ndarray, target_pos: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Azimuth and elevation angles (rad), each (n_t, n_tg), of targets (n_t, n_tg, 3)."""
    x = np.array([1.0, 0.0, 0.0])
    e_az = x - (bore @ x)[:, None] * bore
    e_az /= np.linalg.norm(e_az, axis=-1, keepdims=True)
    e_el = np.cross(bore, e_az)
    u = target_pos - platform_pos[:, None, :]
    u = u / np.linalg.norm(u, axis=-1, keepdims=True)
    az = np.arcsin(np.clip(np.einsum("tgk,tk->tg", u, e_az), -1, 1))
    el = np.arcsin(np.clip(np.einsum("tgk,tk->tg", u, e_el), -1, 1))
    return az, el


def one_way_amplitude(angle: np.ndarray, beamwidth: float, pattern: str) -> np.ndarray:
    """One-way amplitude pattern with -3 dB (power) beamwidth ``beamwidth``."""
    if pattern == "sinc":
        return np.sinc(SINC_IRW_FACTOR * np.sin(angle) / beamwidth)
    if pattern == "gaussian":
        return np.exp(-2.0 * np.log(2.0) * (angle / beamwidth) ** 2)
    if pattern == "rect":
        return (np.abs(angle) <= beamwidth / 2).astype(float)
    raise InputError(f"antenna pattern {pattern!r} is not one of ['sinc', 'gaussian', 'rect']")


def illuminated(radar: RadarMetadata, platform_pos: np.ndarray, point: np.ndarray) -> np.ndarray:
    """Pulses (bool (n_t,)) whose -3 dB azimuth beam contains ``point``; all if no pattern."""
    if radar.azimuth_beamwidth <= 0:
        return np.ones(len(platform_pos), bool)
    az, _ = off_boresight_angles(
        boresight(radar, platform_pos),
        platform_pos,
        np.broadcast_to(np.asarray(point, float), (len(platform_pos), 1, 3)),
    )
    return np.abs(az[:, 0]) <= radar.azimuth_beamwidth / 2
