import math

import numpy as np
import pytest

from sarproc.product.errors import InputError
from sarproc.product.metadata import C
from sarproc.simulation.scene import scene_from_mapping
from sarproc.simulation.simulate import simulate


def direct_echo(product, scene, pulse, sample):
    """The echo equation evaluated sample by sample with the math module: no numpy, no vectors."""
    r = product.radar
    t = float(product.coords["azimuth_time"][pulse])
    tau = float(product.coords["range_time"][sample])
    platform = (r.velocity * t, 0.0, r.altitude)
    total = 0j
    for (x, y, z), (vx, vy, vz), amp in zip(
        scene.target_xyz.tolist(), scene.target_velocity.tolist(), scene.target_amplitude.tolist()
    ):
        target = (x + vx * t, y + vy * t, z + vz * t)
        delay = 2.0 * math.dist(platform, target) / C
        dt = tau - delay
        if abs(dt) <= r.pulse_duration / 2:
            phase = math.pi * r.chirp_rate * dt * dt - 2.0 * math.pi * r.carrier_frequency * delay
            total += amp * complex(math.cos(phase), math.sin(phase))
    return total


def test_echo_matches_direct_evaluation(scene_mapping):
    m = scene_mapping(
        platform={"altitude": "1 km"},
        geometry={"squint": "20 deg"},
        targets={
            "frame": "squint",
            "points": [
                {"name": "A"},
                {"name": "B", "azimuth": "5 m", "range": "30 m", "amplitude": 0.7, "phase": "40 deg"},
                {"name": "M", "azimuth": "-8 m", "range": "-20 m", "velocity": ["3 m/s", "-2 m/s", "0 m/s"]},
            ],
        },
        effects={"target_motion": {}},
        radar={"chirp": "down"},
    )
    scene = scene_from_mapping(m)
    raw = simulate(scene)
    rng = np.random.default_rng(1)
    checked = 0
    for pulse in rng.integers(0, raw.data.shape[0], 6):
        row = np.abs(raw.data[pulse])
        for sample in rng.choice(np.flatnonzero(row > 0), 4):
            expected = direct_echo(raw, scene, int(pulse), int(sample))
            assert abs(raw.data[pulse, sample] - expected) <= 1e-5 * max(abs(expected), 1.0)
            checked += 1
    assert checked == 24


def test_samples_outside_every_envelope_are_exactly_zero(scene_mapping):
    scene = scene_from_mapping(scene_mapping())
    raw = simulate(scene)
    r = raw.radar
    t = raw.coords["azimuth_time"][:, None]
    delay = 2 * np.hypot(r.velocity * t - scene.target_xyz[0, 0], scene.target_xyz[0, 1]) / C
    inside = np.abs(raw.coords["range_time"][None, :] - delay) <= r.pulse_duration / 2
    assert np.all(raw.data[~inside] == 0)
    assert np.all(np.abs(raw.data[inside]) > 0.99)


def test_blocks_do_not_change_the_result(scene_mapping):
    m = scene_mapping(targets={"points": [{"name": "A"}, {"name": "B", "range": "15 m", "azimuth": "3 m"}]})
    one = simulate(scene_from_mapping(m))
    m["simulation"] = {**m["simulation"], "block_pulses": 7}
    many = simulate(scene_from_mapping(m))
    np.testing.assert_array_equal(one.data, many.data)


def test_rect_beam_stripmap_illuminates_only_inside_the_beam(scene_mapping):
    m = scene_mapping(
        acquisition={"mode": "stripmap", "aperture_time": "0.8 s"},
        effects={"antenna": {"pattern": "rect", "azimuth_beamwidth": "1 deg"}},
    )
    raw = simulate(scene_from_mapping(m))
    lit = np.any(raw.data != 0, axis=1)
    x = raw.radar.velocity * raw.coords["azimuth_time"]
    angle = np.arctan2(x, 2000.0)  # target at x = 0, 2 km broadside
    np.testing.assert_array_equal(lit, np.abs(angle) <= math.radians(0.5))
    assert 0 < lit.sum() < len(lit)


def test_noise_power_matches_snr(scene_mapping):
    m = scene_mapping(
        effects={"noise": {"snr": "10 dB"}}, acquisition={"range_window": {"start": "1.9 km", "end": "2.1 km"}}
    )
    raw = simulate(scene_from_mapping(m))
    clean = simulate(
        scene_from_mapping(scene_mapping(acquisition={"range_window": {"start": "1.9 km", "end": "2.1 km"}}))
    )
    noise = raw.data - clean.data
    assert np.mean(np.abs(noise) ** 2) == pytest.approx(0.1, rel=0.03)
    again = simulate(scene_from_mapping(m))
    np.testing.assert_array_equal(raw.data, again.data)  # seeded


def test_undeclared_effects_are_not_simulated(scene_mapping):
    raw = simulate(scene_from_mapping(scene_mapping()))
    assert raw.kind == "raw" and raw.data.ndim == 2
    assert set(raw.aux) == {"platform_position", "tx_offset", "rx_offset"}  # no gate schedule, no beam
    assert raw.radar.azimuth_beamwidth == 0


@pytest.mark.parametrize(
    "changes,message",
    [
        ({"acquisition": {"mode": "stripmap"}}, "acquisition.mode: stripmap needs effects.antenna"),
        ({"radar": {"range_sampling_rate": "80 MHz"}}, "radar.range_sampling_rate: 8e.07 Hz is below the bandwidth"),
        ({"radar": {"bandwidth": "10 m"}}, r"radar.bandwidth: unit 'm' is not a frequency unit"),
        ({"radar": {"bandwidth": "-5 MHz"}}, "radar.bandwidth: '-5 MHz' is out of range"),
        ({"geometry": {"squint": 30}}, "geometry.squint: an angle needs a unit"),
        ({"effects": {"wind": {}}}, "effects: unknown effect 'wind'"),
        (
            {"targets": {"points": [{"name": "A", "velocity": ["1 m/s", "0 m/s", "0 m/s"]}]}},
            "a target has a velocity but effects.target_motion is not declared",
        ),
        ({"acquisition": {"aperture_time": "1 s", "n_pulses": 10}}, "acquisition: give exactly one of"),
        ({"colour": "red"}, r"unknown key\(s\) 'colour'"),
    ],
)
def test_bad_scenes_are_refused_with_the_key(scene_mapping, changes, message):
    with pytest.raises(InputError, match=message):
        scene_from_mapping(scene_mapping(**changes), source="scene.yaml")


def test_prf_and_folding_warnings(scene_mapping, caplog):
    m = scene_mapping(
        radar={"prf": "100 Hz"},
        acquisition={"mode": "stripmap", "aperture_time": "0.5 s"},
        effects={"antenna": {"azimuth_beamwidth": "3 deg"}},
    )
    with caplog.at_level("WARNING"):
        scene_from_mapping(m)
    assert "the beam's Doppler band" in caplog.text and "azimuth aliasing" in caplog.text
    caplog.clear()
    m = scene_mapping(radar={"prf": "100 Hz"}, targets={"points": [{"name": "A"}, {"name": "B", "azimuth": "60 m"}]})
    with caplog.at_level("WARNING"):
        scene_from_mapping(m)
    assert "instantaneous Doppler spread" in caplog.text and "azimuth aliasing" in caplog.text
