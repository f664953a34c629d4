"""The residual's model of a SAR support whose range edges are arcs (issue 20, the evaluate campaign's rect-beam
scenes 20 and 21): a 2 deg aperture at 1.5 % fractional bandwidth (150 MHz at 10 GHz) bows its range edges by 1 %
of the band, which the straight model left at -47 dB beside the range ridge, constant far along it."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sarproc.quality.metrics import evaluate_image

DIMS = ("azimuth", "range")
CARRIER = 10e9 / 150e6  # carrier over bandwidth
HALF_ANGLE = math.radians(1.0)  # half the look angles (a 2 deg rect beam, fully lit)


def sector_response(x: np.ndarray, y: np.ndarray, centre_deg: float, n_angles: int = 400) -> np.ndarray:
    """The annular sector's response at range x and azimuth y (range nulls: bandwidth 1): the sum over look angles
    phi of sinc(rho) exp(j 2 pi CARRIER rho), rho = x cos(phi) + y sin(phi), phi spread evenly over the aperture."""
    phi = math.radians(centre_deg) + HALF_ANGLE * ((np.arange(n_angles) + 0.5) / n_angles * 2 - 1)
    out = np.zeros(np.broadcast(x, y).shape, complex)
    for c, s in zip(np.cos(phi), np.sin(phi)):
        rho = x * c + y * s
        out += np.sinc(rho) * np.exp(2j * np.pi * CARRIER * rho)
    return out / n_angles


@pytest.mark.parametrize("centre_deg", [0.0, 8.0])
def test_arcs_of_a_range_band_are_subtracted(centre_deg):
    """A lone target whose support is an annular sector (rect beam, no window) floors under -55 dB: its range
    edges' bow is part of the model (-48 dB without it, squint 0)."""
    null_az = 1.0 / (2 * CARRIER * math.sin(HALF_ANGLE))
    az = (np.arange(260) - 130) * null_az / 2.26
    rg = (np.arange(120) - 60) / 2.26
    A, R = np.meshgrid(az, rg, indexing="ij")
    img = sector_response(R, A, centre_deg).astype(np.complex64)
    rep = evaluate_image(img, DIMS, [az, rg], (0.886 * null_az, 0.886), [(0.0, 0.0)], metric=np.eye(2))
    assert rep.residual is not None and rep.residual.misfit_targets == ()
    assert rep.residual.floor_db < -55.0, rep.residual
    assert rep.false_targets is not None and rep.false_targets.entries == ()


def near_field_response(x: np.ndarray, y: np.ndarray, centre_deg: float, distance: float, n_angles: int = 400):
    """The response of a target at the origin imaged from ``distance`` (range nulls) over the look angles about
    ``centre_deg``, each pulse's wavefront a circle about its platform position (backprojection's): the sum over
    phi of sinc(rho) exp(j 2 pi CARRIER rho), rho = |x - P_phi| - |P_phi| (P_phi the platform at -distance along
    phi)."""
    phi = math.radians(centre_deg) + HALF_ANGLE * ((np.arange(n_angles) + 0.5) / n_angles * 2 - 1)
    out = np.zeros(np.broadcast(x, y).shape, complex)
    for c, s in zip(np.cos(phi), np.sin(phi)):
        rho = np.hypot(x + distance * c, y + distance * s) - distance
        out += np.sinc(rho) * np.exp(2j * np.pi * CARRIER * rho)
    return out / n_angles


def test_a_bent_azimuth_ridge_is_subtracted():
    """The azimuth ridge of a target seen from 2000 range nulls (the evaluate campaign's geometry: 1 m cells at
    1.9 km) bends away in range with the wavefront (|x|^2 / 2R: half a null 45 m out), and the look angles'
    chirps differ at 17.6 deg squint. A second target 90 nulls along it puts that stretch of the ridge in a guard
    window (campaign scene 20): the model's warp follows it there (the straight model: -47.5 dB)."""
    null_az = 1.0 / (2 * CARRIER * math.sin(HALF_ANGLE))
    az = (np.arange(500) - 250) * null_az / 2.26
    rg = (np.arange(100) - 50) / 2.26
    A, R = np.meshgrid(az, rg, indexing="ij")
    far = (90 * null_az, 6.0)
    img = near_field_response(R, A, 17.6, 2000.0) + 0.5 * near_field_response(R - far[1], A - far[0], 17.6, 2000.0)
    truth = [(0.0, 0.0), far]
    rep = evaluate_image(img.astype(np.complex64), DIMS, [az, rg], (0.886 * null_az, 0.886), truth, metric=np.eye(2))
    assert rep.residual is not None and rep.residual.misfit_targets == ()
    assert rep.residual.floor_db < -55.0, rep.residual
    assert rep.false_targets is not None and rep.false_targets.entries == ()
