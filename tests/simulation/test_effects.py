"""Effect plugins added after the foundation: varied receive range gate, platform motion, and the
antenna's sliding-spotlight steering seen through the simulated data."""

import copy
import dataclasses
import math

import numpy as np
import pytest

from helpers import assert_theory
from sarproc.focus.backprojection import BackprojectParams, backproject
from sarproc.product.metadata import C
from sarproc.quality.metrics import evaluate_product
from sarproc.simulation.effects.base import offsets_along
from sarproc.simulation.effects.range_gate import linear_range_rate
from sarproc.simulation.scene import scene_from_mapping
from sarproc.simulation.simulate import simulate

# 50-deg squinted spotlight: the scene centre walks v sin(theta) T_a ~ 148 m (~1 us two-way)
# through an ungated window, more than the 1 us pulse plus the ~40 m of target spread.
SQUINT50 = {
    "radar": {
        "carrier_frequency": "10 GHz",
        "bandwidth": "150 MHz",
        "pulse_duration": "1 us",
        "range_sampling_rate": "180 MHz",
        "prf": "400 Hz",
    },
    "platform": {"velocity": "150 m/s", "altitude": "2 km"},
    "geometry": {"reference_range": "6 km", "squint": "50 deg"},
    "acquisition": {"mode": "spotlight", "azimuth_resolution": "1 m"},
    "targets": {
        "frame": "los",
        "points": [
            {"name": "O"},
            {"name": "P", "azimuth": "12 m", "range": "-15 m"},
            {"name": "Q", "azimuth": "-15 m", "range": "12 m", "amplitude": 0.5},
        ],
    },
    "simulation": {"waveform": "continuous"},  # the window sizes below are the continuous pulse's
}

# Broadside spotlight with a wobbling track: 0.5 m cross-track (~33 wavelengths) over 0.2 s
# periods, 0.2 m vertical, 0.5 m/s along-track speed error; the aperture is ~0.53 s.
MOTION = {
    **copy.deepcopy(SQUINT50),
    "geometry": {"reference_range": "6 km", "squint": "0 deg"},
    "effects": {
        "platform_motion": {
            "cross_track_amplitude": "0.5 m",
            "cross_track_period": "0.2 s",
            "cross_track_phase": "30 deg",
            "vertical_amplitude": "0.2 m",
            "vertical_period": "0.3 s",
            "along_track_velocity_error": "0.5 m/s",
        }
    },
}


def with_effects(scene, **effects):
    out = copy.deepcopy(scene)
    out["effects"] = {**out.get("effects", {}), **effects}
    return out


@pytest.fixture(scope="module")
def squint_pair():
    """(ungated, gated with K = 4) raw products of the same squinted scene."""
    plain = simulate(scene_from_mapping(SQUINT50))
    gated = simulate(scene_from_mapping(with_effects(SQUINT50, range_gate={"pulses_per_step": 4})))
    return plain, gated


def test_range_gate_shrinks_the_window_and_focuses_to_theory(squint_pair):
    plain, gated = squint_pair
    r = plain.radar
    fs = r.range_sampling_rate
    walk_samples = 2 * r.velocity * math.sin(r.squint) * r.aperture_time / C * fs  # scene-centre walk, ~177
    n_plain, n_gated = plain.data.shape[1], gated.data.shape[1]
    assert n_gated < n_plain - 0.9 * walk_samples
    assert n_gated < 0.6 * n_plain
    params = BackprojectParams(frame="los", margin_cells=28)
    img_plain, img_gated = backproject(plain, params), backproject(gated, params)
    rep_plain, rep_gated = evaluate_product(img_plain), evaluate_product(img_gated)
    assert_theory(rep_gated)
    assert rep_gated.false_target.level_db < -30
    for tp, tg in zip(rep_plain.targets, rep_gated.targets):
        for ap, ag in zip(tp.axes, tg.axes):
            assert abs(ap.position - ag.position) < 0.05 * ag.irw_theory, (tg.name, ag.axis)
        assert tg.peak_amplitude == pytest.approx(tp.peak_amplitude, rel=1e-3)


def test_a_gated_raw_product_records_the_samples_a_fixed_gate_would_need(squint_pair):
    """fixed_gate_samples: the ungated window of the same echoes (what the varied gate saves); only when gated."""
    plain, gated = squint_pair
    assert "fixed_gate_samples" not in plain.attrs
    assert gated.attrs["fixed_gate_samples"] == plain.data.shape[1] > gated.data.shape[1]


def test_gated_echoes_are_the_ungated_ones_shifted_by_the_gate(squint_pair):
    plain, gated = squint_pair
    fs = plain.radar.range_sampling_rate
    gate = gated.aux["range_gate_offset"]
    # Absolute fast time of gated sample j of pulse i: range_time[j] + gate[i].
    shift = np.rint((gated.coords["range_time"][0] + gate - plain.coords["range_time"][0]) * fs).astype(int)
    # The gated window may reach past the ungated one (where it holds no echo): pad with zeros.
    pad = 64
    assert shift.min() > -pad and shift.max() + gated.data.shape[1] < plain.data.shape[1] + pad
    padded = np.pad(plain.data, ((0, 0), (pad, pad)))
    rows = np.arange(len(gate))[:, None]
    cols = pad + shift[:, None] + np.arange(gated.data.shape[1])[None, :]
    np.testing.assert_allclose(gated.data, padded[rows, cols], rtol=0, atol=1e-4)
    # Nothing was lost: every echo sample of the ungated data is inside the gated window.
    assert np.sum(np.abs(gated.data) ** 2) == pytest.approx(np.sum(np.abs(plain.data) ** 2), rel=1e-6)


@pytest.mark.parametrize(
    "gate_cfg,k_step", [({}, 1), ({"pulses_per_step": 5}, 5), ({"pulses_per_step": 3, "range_step": "2.5 m"}, 3)]
)
def test_gate_schedule_is_quantised_stepped_and_follows_the_linear_range(gate_cfg, k_step):
    m = with_effects(SQUINT50, range_gate=gate_cfg)
    m["acquisition"] = {"mode": "spotlight", "n_pulses": 103}
    m["simulation"] = {"block_pulses": 7}  # blocks straddle the gate steps
    raw = simulate(scene_from_mapping(m))
    r = raw.radar
    t = raw.coords["azimuth_time"]
    gate = raw.aux["range_gate_offset"]
    quantum = 2 * 2.5 / C if "range_step" in gate_cfg else 1 / r.range_sampling_rate
    n = gate / quantum
    np.testing.assert_allclose(n, np.rint(n), rtol=0, atol=1e-9)  # whole gates (whole samples by default)
    steps = np.rint(n)
    for s in range(0, len(t), k_step):
        assert np.all(steps[s : s + k_step] == steps[s]), s  # constant within each K-pulse step
    rate = linear_range_rate(r)
    assert rate == pytest.approx(-r.velocity * math.sin(r.squint), rel=1e-12)
    # Follows the linear range term 2 rdot t / c to within half a gate plus half a step of walk.
    tol = quantum / 2 + abs(2 * rate / C) * (k_step / 2) / r.prf + 1e-12
    assert np.max(np.abs(gate - 2 * rate * t / C)) <= tol
    assert gate[0] > 0 > gate[-1]  # forward squint: the range shrinks, the gate opens earlier over time
    # Block size does not matter (the schedule depends on the pulse time only).
    m["simulation"] = {"block_pulses": 256}
    np.testing.assert_array_equal(simulate(scene_from_mapping(m)).data, raw.data)


def test_platform_motion_focuses_with_the_stored_track_and_not_without():
    raw = simulate(scene_from_mapping(MOTION))
    r = raw.radar
    t = raw.coords["azimuth_time"]
    nominal = np.stack([r.velocity * t, np.zeros_like(t), np.full_like(t, r.altitude)], axis=-1)
    dev = raw.aux["platform_position"] - nominal
    assert np.max(np.abs(dev[:, 1])) == pytest.approx(0.5, rel=1e-3)
    assert np.max(np.abs(dev[:, 2])) == pytest.approx(0.2, rel=1e-3)
    np.testing.assert_allclose(dev[:, 0], 0.5 * t, atol=1e-9)
    params = BackprojectParams(frame="los", margin_cells=28)
    known = evaluate_product(backproject(raw, params))
    assert_theory(known)
    straight = dataclasses.replace(raw, aux={**raw.aux, "platform_position": nominal})
    ignored = evaluate_product(backproject(straight, params))
    for tk, ti in zip(known.targets, ignored.targets):
        assert ti.peak_amplitude < 0.3 * tk.peak_amplitude, tk.name  # > 10 dB of focus lost
        az = ti.axis("azimuth")
        assert az.pslr_db > -6.0 and az.islr_db > 0.0, tk.name  # energy spread over side lobes
        assert az.irw_ratio > 1.1, tk.name


def _lit_times(mode, azimuth_offset, **antenna):
    m = {
        "radar": {
            "carrier_frequency": "10 GHz",
            "bandwidth": "50 MHz",
            "pulse_duration": "1 us",
            "range_sampling_rate": "60 MHz",
            "prf": "400 Hz",
        },
        "platform": {"velocity": "100 m/s", "altitude": "0 m"},
        "geometry": {"reference_range": "2 km", "squint": "0 deg"},
        "acquisition": {"mode": mode, "aperture_time": "2 s"},
        "targets": {"frame": "squint", "points": [{"name": "A", "azimuth": f"{azimuth_offset} m"}]},
        "effects": {"antenna": {"pattern": "rect", "azimuth_beamwidth": "2 deg", **antenna}},
    }
    raw = simulate(scene_from_mapping(m))
    lit = np.any(raw.data != 0, axis=1)
    return raw.coords["azimuth_time"][lit], len(lit)


def test_sliding_spotlight_footprint_is_between_stripmap_and_spotlight():
    r_rot, offsets = 6000.0, (-25.0, 25.0)
    n_pulses = None
    centres = {}
    for x in offsets:
        spot, n_pulses = _lit_times("spotlight", x)
        strip, _ = _lit_times("stripmap", x)
        slide, _ = _lit_times("sliding_spotlight", x, rotation_range=f"{r_rot} m")
        assert len(spot) == n_pulses
        assert len(strip) < len(slide) < n_pulses, x
        assert slide[0] > spot[0] and slide[-1] < spot[-1], x  # lit span strictly inside the aperture
        centres[x] = (0.5 * (strip[0] + strip[-1]), 0.5 * (slide[0] + slide[-1]))
    dt_strip = centres[offsets[1]][0] - centres[offsets[0]][0]
    dt_slide = centres[offsets[1]][1] - centres[offsets[0]][1]
    v = 100.0
    v_strip, v_slide = (offsets[1] - offsets[0]) / dt_strip, (offsets[1] - offsets[0]) / dt_slide
    assert v_strip == pytest.approx(v, rel=0.02)  # stripmap footprint moves with the platform
    assert v_slide == pytest.approx(v * (1 - 2000.0 / r_rot), rel=0.02)  # rotation point beyond the scene
    assert v_slide < 0.8 * v


def test_undeclared_effects_stay_off():
    raw = simulate(scene_from_mapping(SQUINT50))
    assert "range_gate_offset" not in raw.aux
    r, t = raw.radar, raw.coords["azimuth_time"]
    nominal = np.stack([r.velocity * t, np.zeros_like(t), np.full_like(t, r.altitude)], axis=-1)
    np.testing.assert_array_equal(raw.aux["platform_position"], nominal)
    moved = simulate(scene_from_mapping(MOTION))
    assert "range_gate_offset" not in moved.aux
    gated = simulate(scene_from_mapping(with_effects(SQUINT50, range_gate={})))
    np.testing.assert_array_equal(gated.aux["platform_position"], nominal)  # the gate does not move the platform


def test_platform_motion_needs_a_period():
    from sarproc.product.errors import InputError

    with pytest.raises(InputError, match="cross_track_period: required"):
        scene_from_mapping(with_effects(SQUINT50, platform_motion={"cross_track_amplitude": "1 m"}))


def test_receiver_offsets_lie_along_the_named_axis_only():
    np.testing.assert_array_equal(offsets_along(np.array([-1.5, 0.0, 1.5]), 1), [[0, -1.5, 0], [0, 0, 0], [0, 1.5, 0]])
