"""Static-equivalent (apparent) position of moving targets (sarproc.product.moving).

Checked against exact backprojection of simulated movers: the focused response's peak must lie where
``apparent_position`` says, to a fraction of a resolution cell, single-channel and multichannel, at
broadside and under squint, for slant-range and along-track velocities.
"""

from __future__ import annotations

import copy
import math
from pathlib import Path

import numpy as np
import pytest

from sarproc.focus.backprojection import BackprojectParams, backproject
from sarproc.focus.multichannel.reconstruct import ReconstructParams, reconstruct
from sarproc.product import moving
from sarproc.product.config import load_yaml
from sarproc.product.frames import make_frame
from sarproc.quality.metrics import EvaluateParams, evaluate_product
from sarproc.simulation.scene import scene_from_mapping
from sarproc.simulation.simulate import simulate

CONFIG = Path(__file__).resolve().parents[2] / "configs" / "xu_small.yaml"


def single_channel(points, squint="20 deg", prf="3000 Hz", aperture="0.3 s"):
    """xu_small.yaml as one channel at N PRF (the Doppler band sampled), shortened for speed."""
    m = load_yaml(CONFIG)
    m.pop("reconstruct", None)
    m.pop("backproject", None)
    m["effects"] = {"antenna": m["effects"]["antenna"], "target_motion": {}}
    m["radar"]["prf"] = prf
    m["geometry"]["squint"] = squint
    m["acquisition"]["aperture_time"] = aperture
    m["targets"]["points"] = points
    return simulate(scene_from_mapping(m))


def mover(v_a=0.0, v_r=0.0, **extra):
    return {"name": "T", "velocity": [f"{v_a} m/s", f"{v_r} m/s", "0 m/s"], **extra}


def peak_error_cells(rec, times=None):
    """Backproject ``rec`` around its targets' apparent positions; position errors (cells) of the peaks there."""
    frame = make_frame("squint", rec.radar)
    moved = copy.copy(rec)
    moved.targets = moving.apparent_targets(
        rec.targets, rec.radar, moving.pulse_times(rec) if times is None else times, frame, moving.phase_centres(rec)
    )
    for v in ("vx", "vy", "vz"):  # judged as static points at S, independently of backproject / evaluate
        moved.targets[v] = 0.0
    img = backproject(moved, BackprojectParams(oversample=2.0, margin_cells=16))
    report = evaluate_product(img, EvaluateParams(guard_cells=10))
    return {
        t.name: (t.axis("azimuth").position_error_cells, t.axis("range").position_error_cells) for t in report.targets
    }, moved.targets


@pytest.mark.parametrize(
    "squint, v_a, v_r", [("0 deg", 0.0, 5.0), ("20 deg", 0.0, -8.0), ("20 deg", 3.0, 6.0), ("-10 deg", -4.0, 0.0)]
)
def test_single_channel_mover_focuses_at_its_apparent_position(squint, v_a, v_r):
    raw = single_channel([mover(v_a, v_r)], squint=squint)
    errors, moved = peak_error_cells(raw)
    az, rg = errors["T"]
    truth = raw.targets[0]
    frame = make_frame("squint", raw.radar)
    shift = np.hypot(moved["azimuth"][0] - truth["azimuth"], moved["range"][0] - truth["range"])
    assert shift > 20 * 1.5, "the test needs a shift of many cells to mean something"
    assert abs(az) < 0.1 and abs(rg) < 0.1, (az, rg, shift)
    # the first-order rule of thumb agrees with the exact model to a few per cent of the shift
    s, t_c = moving.apparent_position(
        raw.radar, moving.pulse_times(raw), [truth["x"], truth["y"], truth["z"]], [v_a, v_r, 0.0]
    )
    at_tc = frame.from_xyz(np.array([truth["x"], truth["y"], truth["z"]]) + t_c * np.array([v_a, v_r, 0.0]))
    d_az, d_rg = moving.first_order_shift(
        raw.radar, raw.radar.reference_range, v_a, v_r, squint=math.radians(float(squint.split()[0]))
    )
    got = np.array(frame.from_xyz(s)) - np.array(at_tc)
    assert got == pytest.approx([d_az, d_rg], abs=0.02 * np.hypot(d_az, d_rg) + 0.5)


def test_multichannel_movers_focus_at_their_apparent_positions():
    """xu_small.yaml's three channels, modified reconstruction with the true velocities (B: v_r, C: v_r and v_a)."""
    m = load_yaml(CONFIG)
    m.pop("reconstruct", None)
    m["acquisition"]["aperture_time"] = "0.4 s"
    m["targets"]["points"] = [{"name": "C", "azimuth": "0 m", "velocity": ["6 m/s", "7 m/s", "0 m/s"]}]
    m["effects"]["target_motion"] = {}
    raw = simulate(scene_from_mapping(m))
    rec = reconstruct(raw, ReconstructParams(radial_velocity=7.0, along_track_velocity=6.0))
    errors, moved = peak_error_cells(rec)
    assert abs(moved["azimuth"][0]) > 500  # about -R v_los / (v cos^2): 720 m
    assert abs(errors["C"][0]) < 0.1 and abs(errors["C"][1]) < 0.1, errors


def test_static_target_is_its_own_apparent_position_and_relocation_inverts():
    raw_radar = scene_from_mapping(load_yaml(CONFIG)).radar
    times = (np.arange(601) - 300) / 1000.0
    xyz = np.array([raw_radar.scene_center[0] + 300.0, raw_radar.scene_center[1], 0.0])
    s, _ = moving.apparent_position(raw_radar, times, xyz, [0.0, 0.0, 0.0])
    assert np.array_equal(s, xyz)
    for vel in ([0.0, 10.0, 0.0], [10.0, 10.0, 0.0], [-15.0, 18.0, 0.0]):
        s, _ = moving.apparent_position(raw_radar, times, xyz, vel)
        assert np.linalg.norm(s - xyz) > 100
        back = moving.relocate(raw_radar, times, s, vel)
        assert np.linalg.norm(back - xyz) < 1e-3


def test_illumination_centre_follows_the_data_window():
    """A target whose beam crossing the data cut keeps the centre of what the data holds; continuous in x."""
    radar = scene_from_mapping(load_yaml(CONFIG)).radar
    times = (np.arange(601) - 300) / 1000.0
    y = radar.scene_center[1]
    centres = [
        moving.illumination_centre_time(radar, times, [radar.scene_center[0] + x, y, 0.0], [0, 0, 0])
        for x in (0.0, 0.4, 0.8)
    ]
    # interior: beam crossing at x / v, interpolated between pulses (not stepping by 1 / PRF)
    assert np.diff(centres) == pytest.approx([0.4 / radar.velocity] * 2, rel=0.02)
    # an edge target: illuminated from some pulse to the last one -> centre between them, not its crossing
    x_edge = 0.3 * radar.velocity
    t_edge = moving.illumination_centre_time(radar, times, [radar.scene_center[0] + x_edge, y, 0.0], [0, 0, 0])
    assert times[0] < t_edge < x_edge / radar.velocity
    assert moving.illumination_centre_time(radar.replace(azimuth_beamwidth=0.0), times, [0, y, 0], [0, 0, 0]) == 0.0


def test_slant_and_scene_velocity_round_trip_from_altitude():
    xyz = np.array([100.0, 400e3, 0.0])
    vel = moving.scene_velocity(xyz, 5.0, 4.6, altitude=500e3)
    assert vel[1] == pytest.approx(4.6 * math.hypot(400e3, 500e3) / 400e3)
    assert moving.slant_velocity(xyz, vel, 500e3) == pytest.approx((5.0, 4.6))
