"""The compiled echo accumulation against the echo equation evaluated in float64 with numpy.

The reference takes the simulator's own geometry (positions, gate offsets, the effects' gains)
and evaluates exp(j 2 pi [K/2 dt^2 - f_c tau]) on every window sample; only the samples' values
come from the compiled kernel under test.
"""

from __future__ import annotations

import numpy as np
import pytest

from sarproc.simulation import simulate as sim
from sarproc.simulation.scene import scene_from_mapping


def reference_block(scene, plan, t):
    """(n_ch, n_t, n_range) complex128 echoes, every window sample evaluated in float64."""
    r = scene.radar
    fs, tp, k, fc = r.range_sampling_rate, r.pulse_duration, r.chirp_rate, r.carrier_frequency
    n = np.arange(len(plan.coords["range_time"]))
    pos, tg = sim._positions(scene, t), sim._target_positions(scene, t)
    gate = sim._gate_offsets(scene, t, 2 * r.reference_range / sim.C)
    amplitude = sim._scatterers(scene)[2]
    out = np.zeros((len(plan.rx_offsets), len(t), len(n)), complex)
    for ch, rx in enumerate(plan.rx_offsets):
        tau = sim._delays(pos + plan.tx_offset, pos + rx, tg)
        gains = np.broadcast_to(amplitude[None, :], tau.shape).astype(complex)
        for e in scene.effects:
            gains = e.gains(t, pos, tg, ch, gains)
        for j in range(tau.shape[1]):
            rel = tau[:, j] - gate - plan.coords["range_time"][0]
            dt = n[None, :] / fs - rel[:, None]
            cycles = 0.5 * k * dt**2 - fc * tau[:, j, None]
            cycles -= np.floor(cycles)
            out[ch] += np.where(np.abs(dt) <= tp / 2, gains[:, j, None] * np.exp(2j * np.pi * cycles), 0)
    return out


SCENES = {
    "squinted, moving target, down chirp": dict(
        platform={"altitude": "1 km"},
        geometry={"squint": "20 deg"},
        radar={"chirp": "down"},
        targets={
            "frame": "squint",
            "points": [
                {"name": "A"},
                {"name": "B", "azimuth": "5 m", "range": "30 m", "amplitude": 0.7, "phase": "40 deg"},
                {"name": "M", "azimuth": "-8 m", "range": "-20 m", "velocity": ["3 m/s", "-2 m/s", "0 m/s"]},
            ],
        },
        effects={"target_motion": {}},
    ),
    "antenna, varied gate, platform motion, 3 channels": dict(
        acquisition={"mode": "stripmap", "aperture_time": "0.5 s"},
        targets={"frame": "squint", "points": [{"name": "A"}, {"name": "B", "azimuth": "12 m", "range": "9 m"}]},
        effects={
            "antenna": {"pattern": "sinc", "azimuth_beamwidth": "2 deg"},
            "range_gate": {"pulses_per_step": 5},
            "platform_motion": {
                "cross_track_amplitude": "0.3 m",
                "cross_track_period": "0.2 s",
                "vertical_amplitude": "0.1 m",
                "vertical_period": "0.3 s",
            },
            "azimuth_channels": {"n_receivers": 3, "spacing": "1 m"},
        },
    ),
    "clutter": dict(
        effects={"clutter": {"n_scatterers": 40, "azimuth_extent": "40 m", "range_extent": "40 m", "seed": 2}}
    ),
    "pulse longer than the window": dict(
        targets={"frame": "squint", "points": [{"name": "A"}, {"name": "B", "range": "40 m"}]},
        acquisition={"range_window": {"start": "1990 m", "end": "2010 m"}},
    ),
}


@pytest.mark.parametrize("changes", SCENES.values(), ids=SCENES.keys())
def test_compiled_echoes_equal_float64_equation(scene_mapping, changes):
    scene = scene_from_mapping(scene_mapping(**changes))
    plan = sim.plan_simulation(scene)
    t = plan.coords["azimuth_time"]
    got = np.concatenate([b for _, b in sim.simulate_blocks(scene, plan)], axis=1)  # complex64, as stored
    want = reference_block(scene, plan, t)
    assert got.shape == want.shape and np.count_nonzero(want) > 0
    # the same samples are lit, and each value is the float64 echo to complex64 rounding
    np.testing.assert_array_equal(got != 0, want != 0)
    scale = np.abs(want).max()
    err = np.abs(got - want)
    assert err.max() <= 3e-7 * scale, err.max() / scale
    assert err.max() <= 2 * np.abs(want.astype(np.complex64) - want).max() + 1e-7 * scale


@pytest.mark.parametrize("changes", [SCENES["clutter"], SCENES["antenna, varied gate, platform motion, 3 channels"]])
def test_complex64_block_is_the_rounded_complex128_block(scene_mapping, changes):
    # the kernel rounds each complex128 sum once into a complex64 block: bit for bit the old cast
    scene = scene_from_mapping(scene_mapping(**changes))
    plan = sim.plan_simulation(scene)
    t = plan.coords["azimuth_time"][:50]
    wide = sim.echo_block(scene, plan, t, dtype=np.complex128)
    narrow = sim.echo_block(scene, plan, t, dtype=np.complex64)
    assert narrow.dtype == np.complex64 and np.count_nonzero(narrow) > 0
    assert narrow.tobytes() == wide.astype(np.complex64).tobytes()


def test_noise_is_added_before_the_rounding_in_block_order(scene_mapping):
    # with a finalize step the blocks stay complex128 until noise is added, drawn block after block
    m = scene_mapping(effects={"noise": {"snr": "10 dB"}}, simulation={"seed": 5, "block_pulses": 7})
    scene = scene_from_mapping(m)
    plan = sim.plan_simulation(scene)
    (noise,) = scene.effects
    got = np.concatenate([b for _, b in sim.simulate_blocks(scene, plan)], axis=1)
    rng = np.random.default_rng(5)
    power = float(np.max(np.abs(scene.target_amplitude)) ** 2)
    t = plan.coords["azimuth_time"]
    want = [noise.finalize(sim.echo_block(scene, plan, t[s : s + 7]), rng, power) for s in range(0, len(t), 7)]
    assert got.tobytes() == np.concatenate(want, axis=1).astype(np.complex64).tobytes()
