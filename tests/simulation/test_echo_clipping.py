"""Echo envelopes cut by the receive window: the simulator equals a dense evaluation of the model.

Property test over random windows (before, across, inside, after the echo, and shorter than the
pulse), pulse lengths and geometries. Regression: an echo running past the window's last sample
indexed one column beyond the buffer (IndexError at simulate.py, issue 12).
"""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings, strategies as st

from sarproc.product.metadata import C
from sarproc.simulation.scene import scene_from_mapping
from sarproc.simulation.simulate import echo_block, plan_simulation


def _scene(tp_us, start_off, length, ref_range, altitude, squint_deg, az_off, n_pulses):
    r_target = ref_range
    return {
        "radar": {
            "carrier_frequency": "10 GHz",
            "bandwidth": "100 MHz",
            "pulse_duration": f"{tp_us} us",
            "range_sampling_rate": "120 MHz",
            "prf": "500 Hz",
        },
        "platform": {"velocity": "150 m/s", "altitude": f"{altitude} m"},
        "geometry": {"reference_range": f"{ref_range} m", "squint": f"{squint_deg} deg"},
        "acquisition": {
            "mode": "spotlight",
            "n_pulses": n_pulses,
            "range_window": {"start": f"{r_target + start_off} m", "end": f"{r_target + start_off + length} m"},
        },
        "targets": {"frame": "squint", "points": [{"name": "A", "azimuth": f"{az_off} m"}]},
        "simulation": {"waveform": "continuous"},  # the dense model is the continuous chirp's
    }


def _dense(scene, plan):
    """The baseband model evaluated at every window sample (no envelope bookkeeping)."""
    r = scene.radar
    t = plan.coords["azimuth_time"]
    tau = plan.coords["range_time"]
    pos = np.stack([r.velocity * t, np.zeros_like(t), np.full_like(t, r.altitude)], axis=1)
    d = 2 * np.linalg.norm(scene.target_xyz[0][None, :] - pos, axis=1) / C  # (n_t,)
    dt = tau[None, :] - d[:, None]
    inside = np.abs(dt) <= r.pulse_duration / 2
    phase = math.pi * r.chirp_rate * dt**2 - 2 * math.pi * r.carrier_frequency * d[:, None]
    edge = np.abs(np.abs(dt) - r.pulse_duration / 2) < 1e-12  # float rounding decides these samples
    return np.where(inside, np.exp(1j * phase), 0), edge


@settings(max_examples=60, deadline=None)
@given(
    tp_us=st.floats(0.05, 4.0),
    start_off=st.floats(-900.0, 900.0),
    length=st.floats(1.0, 600.0),
    ref_range=st.floats(1500.0, 6000.0),
    altitude=st.floats(0.0, 1000.0),
    squint_deg=st.floats(-40.0, 40.0),
    az_off=st.floats(-50.0, 50.0),
    n_pulses=st.integers(1, 6),
)
def test_echoes_clipped_by_the_window_equal_the_dense_model(
    tp_us, start_off, length, ref_range, altitude, squint_deg, az_off, n_pulses
):
    scene = scene_from_mapping(_scene(tp_us, start_off, length, ref_range, altitude, squint_deg, az_off, n_pulses))
    plan = plan_simulation(scene)
    got = echo_block(scene, plan, plan.coords["azimuth_time"])[0]
    want, edge = _dense(scene, plan)
    assert got.shape == want.shape
    np.testing.assert_allclose(np.where(edge, 0, got), np.where(edge, 0, want), atol=2e-5)


def test_issue_12_demo_window_past_the_echo_does_not_crash():
    """configs/demo.yaml-like spotlight: a window ending before the echo starts (the far pulses of the report)."""
    scene = scene_from_mapping(_scene(2.0, -500.0, 100.0, 10_000.0, 3000.0, 30.0, 0.0, 5))
    plan = plan_simulation(scene)
    got = echo_block(scene, plan, plan.coords["azimuth_time"])[0]
    want, edge = _dense(scene, plan)
    np.testing.assert_allclose(np.where(edge, 0, got), np.where(edge, 0, want), atol=2e-5)
