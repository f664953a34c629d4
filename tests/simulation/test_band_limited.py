"""simulation.waveform: band_limited: every echo compresses to the exact band-limited response.

Reference: a unit echo delayed by tau, range-compressed with the flat filter over |f| <= B/2, is
(1/n_band) sum over the band's DFT bins of exp(j 2 pi f (t - tau)) times the carrier phase (a
Dirichlet kernel), whatever fraction of a sample tau falls on. The continuous chirp sampled at a
fractional delay misses it by its aliased spectral tails (the pedestal); the band-limited echo matches
it to the DAC filter's rejection.
"""

from __future__ import annotations

import numpy as np
import pytest

from sarproc.dsp.rangecomp import range_compress
from sarproc.product.errors import InputError
from sarproc.product.metadata import C
from sarproc.simulation.scene import scene_from_mapping
from sarproc.simulation.simulate import echo_block, plan_simulation


def _scene(waveform: str, fs: str = "180 MHz") -> dict:
    return {
        "radar": {
            "carrier_frequency": "10 GHz",
            "bandwidth": "150 MHz",
            "pulse_duration": "2 us",
            "range_sampling_rate": fs,
            "prf": "500 Hz",
        },
        "platform": {"velocity": "150 m/s", "altitude": "0 m"},
        "geometry": {"reference_range": "3000 m", "squint": "0 deg"},
        "acquisition": {"mode": "spotlight", "n_pulses": 6, "range_margin": "100 m"},
        "targets": {"frame": "squint", "points": [{"name": "A", "azimuth": "40 m", "range": "0.37 m"}]},
        "simulation": {"waveform": waveform},
    }


def _compressed_and_exact(waveform: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(compressed echoes, the exact band-limited responses, fractional delays in samples) per pulse."""
    scene = scene_from_mapping(_scene(waveform))
    plan = plan_simulation(scene)
    r = scene.radar
    t = plan.coords["azimuth_time"]
    echoes = echo_block(scene, plan, t, dtype=np.complex128)[0]
    got = range_compress(echoes.astype(np.complex128), r).astype(np.complex128)
    fs, rt = r.range_sampling_rate, plan.coords["range_time"]
    pos = np.stack([r.velocity * t, np.zeros_like(t), np.full_like(t, r.altitude)], axis=1)
    tau = 2 * np.linalg.norm(scene.target_xyz[0][None, :] - pos, axis=1) / C
    from sarproc.dsp.rangecomp import replica_fft_size

    n_fft = replica_fft_size(r, len(rt))
    f = np.fft.fftfreq(n_fft, 1 / fs)
    band = f[np.abs(f) <= r.bandwidth / 2]
    rel = (rt[None, :] - tau[:, None])[..., None]
    exact = np.exp(2j * np.pi * band * rel).sum(axis=-1) / len(band)
    exact *= np.exp(-2j * np.pi * r.carrier_frequency * tau)[:, None]
    return got, exact, (tau - rt[0]) * fs % 1


def test_band_limited_echo_compresses_to_the_exact_response():
    got, exact, frac = _compressed_and_exact("band_limited")
    assert np.all((frac > 0.05) & (frac < 0.95))  # between samples: the case the continuous chirp gets wrong
    peak = np.abs(exact).max()
    err_db = 20 * np.log10(np.abs(got - exact).max() / peak)
    assert err_db < -110, err_db  # complex64 output and the filter's 120 dB
    # the continuous chirp sampled between samples leaves its aliasing pedestal, 40-60 dB down
    got_c, exact_c, _ = _compressed_and_exact("continuous")
    pedestal_db = 20 * np.log10(np.abs(got_c - exact_c).max() / peak)
    assert -60 < pedestal_db < -30, pedestal_db


def test_band_limited_echo_on_a_sample_is_the_sampled_chirp():
    """Kernel p(j) = [j == 0]: a delay on a sample gives exactly the continuous model's samples."""
    scene = scene_from_mapping(_scene("band_limited"))
    plan = plan_simulation(scene)
    r = scene.radar
    fs = r.range_sampling_rate
    from sarproc.simulation.echo_kernel import accumulate_echoes, window_chirp
    from sarproc.simulation.simulate import band_limited_echoes

    n = len(plan.coords["range_time"])
    t0 = float(plan.coords["range_time"][0])
    tau = np.array([[t0 + 1000 / fs, t0 + 1900 / fs]])
    gains = np.array([[1.0 + 0.5j, -0.25]], dtype=complex)
    gate = np.zeros(1)
    got = band_limited_echoes(r, tau, gains, gate, t0, n)
    want = np.zeros((1, n), complex)
    accumulate_echoes(
        want,
        tau,
        gains,
        gate,
        t0,
        fs,
        r.pulse_duration,
        r.chirp_rate,
        r.carrier_frequency,
        window_chirp(n, fs, r.chirp_rate),
    )
    assert np.abs(got - want).max() < 1e-9


def test_band_limited_needs_a_transition_band():
    with pytest.raises(InputError, match="simulation.waveform"):
        scene_from_mapping(_scene("band_limited", fs="150 MHz"))


def test_tabulated_kaiser_window_is_within_its_stated_error():
    """The kernel interpolates the window between KAISER_PER_SAMPLE points a sample: within 1e-8 of
    I0(beta sqrt(1 - (t/J)^2)) / I0(beta) everywhere (-160 dB, under the filter's 120 dB)."""
    from sarproc.simulation import echo_aot

    half_taps, beta = echo_aot.kaiser_design(180e6, 150e6)
    table = echo_aot.kaiser_table(half_taps, beta)
    t = np.random.default_rng(1).uniform(-half_taps, half_taps, 100_000)
    u = (t + half_taps) * echo_aot.KAISER_PER_SAMPLE
    m = u.astype(int)
    approx = table[m] + (u - m) * (table[m + 1] - table[m])
    exact = np.i0(beta * np.sqrt(1 - (t / half_taps) ** 2)) / np.i0(beta)
    assert np.abs(approx - exact).max() < 1e-8
    assert table[0] == table[-1] == 1 / np.i0(beta)  # the edges from inside, not zero


def test_default_waveform_is_band_limited_where_the_sampling_allows():
    """waveform: auto (the default) simulates band_limited above 1.01 B sampling, else continuous; the scene
    records which."""
    m = _scene("band_limited")
    del m["simulation"]
    assert scene_from_mapping(m).params.simulation.waveform == "band_limited"
    m["radar"]["range_sampling_rate"] = "150 MHz"
    assert scene_from_mapping(m).params.simulation.waveform == "continuous"
