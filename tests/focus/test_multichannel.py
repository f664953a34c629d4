"""Paper 003 (multichannel reconstruct): channel model, filter bank, velocity estimation, hard cases.

Small spaceborne scene (configs/xu_small.yaml): X band, 7.5 km/s, 600 km, 20 deg squint, three
channels at PRF 1000 Hz (the uniform PRF), Doppler band 2.4 kHz. Moving targets are judged at their
static-equivalent position (sarproc.product.moving: backproject's grid and evaluate follow them there)
and with the static theory IRW of their true position (recorded by backproject); false targets are
read on a strip along azimuth in the squint_lrwc frame (a ghost keeps the target's range history, so
it lies at the same range after walk correction).
"""

from __future__ import annotations

import logging
import math
from pathlib import Path

import numpy as np
import pytest
import scipy.fft as sfft

from helpers import assert_theory
from sarproc.focus.backprojection import BackprojectParams, backproject
from sarproc.focus.multichannel import channels
from sarproc.focus.multichannel.reconstruct import ReconstructParams, reconstruct
from sarproc.product.config import load_yaml
from sarproc.product.errors import InputError
from sarproc.product.metadata import C
from sarproc.quality.metrics import EvaluateParams, evaluate_product
from sarproc.simulation.scene import scene_from_mapping
from sarproc.simulation.simulate import simulate

CONFIG = Path(__file__).resolve().parents[2] / "configs" / "xu_small.yaml"


def scene(points=None, **changes):
    m = load_yaml(CONFIG)
    for key in ("reconstruct", "backproject"):
        m.pop(key, None)
    if points is not None:
        m["targets"]["points"] = points
        if any("velocity" in p for p in points):
            m["effects"]["target_motion"] = {}
    for section, values in changes.items():
        if values is None:
            m.pop(section, None)
        elif isinstance(values, dict) and isinstance(m.get(section), dict):
            m[section].update(values)
            m[section] = {k: v for k, v in m[section].items() if v is not None}
        else:
            m[section] = values
    return m


def mover(name="B", v_r=0.0, v_a=0.0, **extra):
    return {"name": name, "velocity": [f"{v_a} m/s", f"{v_r} m/s", "0 m/s"], **extra}


def focused(rec, raw, **bp):
    """Backprojected image around each target: backproject's default grid follows moving targets to their
    static-equivalent positions and records their own theory (of their true position); evaluate measures
    them there."""
    return backproject(rec, BackprojectParams(**bp))


def false_target_db(rec, raw) -> float:
    """Strongest response outside +-0.45 ghost spacing of the target on a strip covering +-(N - 0.5) PRF ghosts."""
    spacing = channels.ghost_spacing(rec.radar, raw.radar.prf)
    n = raw.data.shape[0]
    extent = 2 * (max(n, 2) - 0.5) * spacing
    strip = backproject(
        rec, BackprojectParams(frame="squint_lrwc", azimuth_extent=extent, range_extent=40.0, oversample=1.2)
    )
    # Guard 0.45 ghost spacings (245 cells): the target's own sinc side lobes there are about -57 dB.
    guard = 0.45 * spacing / strip.attrs["theoretical_irw"][0]
    report = evaluate_product(strip, EvaluateParams(guard_cells=guard))
    return report.false_target.level_db


@pytest.fixture(scope="module")
def static_case():
    raw = simulate(scene_from_mapping(scene()))
    single = scene(effects={"azimuth_channels": None}, radar={"prf": "3000 Hz"})
    single["effects"] = {"antenna": single["effects"]["antenna"]}
    return raw, simulate(scene_from_mapping(single))


@pytest.fixture(scope="module")
def moving_case():
    raw = simulate(scene_from_mapping(scene([mover(v_r=10.0)])))
    return raw, {m: reconstruct(raw, ReconstructParams(method=m)) for m in ("conventional", "modified")}


# ---------------------------------------------------------------------------------------------- model


def test_filter_bank_recovers_a_band_limited_signal_uniform_and_not():
    """Eq. (3): N channels delayed by tau_n, sampled at PRF, give back the signal at N PRF."""
    n, prf, n_az = 4, 100.0, 64
    dx = (np.arange(n) - 1.5) * 1.0
    rng = np.random.default_rng(1)
    freqs = np.arange(-n * n_az // 2, n * n_az // 2) * prf / n_az
    coef = rng.standard_normal(len(freqs)) + 1j * rng.standard_normal(len(freqs))

    def signal(t):
        return np.exp(2j * np.pi * np.outer(t, freqs)) @ coef

    t = np.arange(n_az) / prf
    truth = signal(np.arange(n * n_az) / (n * prf))
    for v, cond_max in ((prf * n / 2, 1.0 + 1e-9), (prf * n / 2 * 0.7, 10.0)):  # uniform, then clumped
        tau = channels.channel_delays(dx, v)
        bank = channels.filter_bank(tau, prf, n_az)
        s = np.stack([signal(t + tn) for tn in tau]).astype(np.complex64)
        y = sfft.ifft(channels.apply_filter_bank(sfft.fft(s, axis=1), bank))
        assert np.max(np.abs(y - truth)) / np.max(np.abs(truth)) < 1e-5
        assert 1.0 - 1e-9 <= bank.max_condition <= cond_max
    assert channels.filter_bank(channels.channel_delays(dx, prf * n / 2), prf, n_az).noise_gain == pytest.approx(1.0)


def test_doppler_power_spectrum_removes_the_squint_centroid():
    """A tone at the squint's Doppler centroid 2 v sin(theta) / lambda plus f0 (a bin) lands wholly in f0's bin of
    an ascending grid over the PRF, its power kept (Parseval); left in, the centroid (233 kHz, 170.67 bins past a
    multiple of the PRF) would put the peak elsewhere and spread it."""
    from types import SimpleNamespace

    radar = SimpleNamespace(velocity=7000.0, squint=math.radians(30), wavelength=0.03, prf=2000.0)
    n = 256
    t = (np.arange(n) - n / 2) / radar.prf
    centroid = 2 * radar.velocity * math.sin(radar.squint) / radar.wavelength
    f0 = 37 * radar.prf / n
    data = np.exp(2j * np.pi * (centroid + f0) * t)[:, None] * np.array([1.0, 0.5j, -0.25])
    product = SimpleNamespace(radar=radar, data=data, coords={"azimuth_time": t})
    freqs, power = channels.doppler_power_spectrum(product)
    assert len(freqs) == n and np.all(np.diff(freqs) > 0)
    assert freqs[0] == pytest.approx(-radar.prf / 2)
    assert freqs[np.argmax(power)] == pytest.approx(f0)
    assert power.sum() == pytest.approx(n * np.sum(np.abs(data) ** 2), rel=1e-9)
    assert power.max() / power.sum() > 0.999
    with pytest.raises(ValueError, match="single-channel"):
        channels.doppler_power_spectrum(SimpleNamespace(radar=radar, data=data[None], coords={"azimuth_time": t}))


def test_channel_model_matches_exact_bistatic_paths():
    """Eqs. (1), (2) and the v_r phase: |P - T| + |P + dx - T| = 2 R_mono(t + tau_n) - 2 v_r cos(theta) tau_n + e_n."""
    v, squint, r0, lam = 7500.0, math.radians(20), 600e3, C / 9.6e9
    v_a, v_r = 10.0, 10.0
    target0 = np.array([r0 * math.sin(squint), r0 * math.cos(squint), 0.0])
    vel = np.array([v_a, v_r, 0.0])
    dx = np.array([-5.0, 0.0, 5.0])
    tau = channels.channel_delays(dx, v, v_a)
    excess = channels.bistatic_excess(dx, squint, r0)
    t = np.linspace(-0.2, 0.2, 41)

    def mono(tt):
        p = np.stack([v * tt, 0 * tt, 0 * tt], axis=1)
        return np.linalg.norm(target0 + np.outer(tt, vel) - p, axis=1)

    for k in range(3):
        p = np.stack([v * t, 0 * t, 0 * t], axis=1)
        tg = target0 + np.outer(t, vel)
        exact = np.linalg.norm(tg - p, axis=1) + np.linalg.norm(tg - p - [dx[k], 0, 0], axis=1)
        model = 2 * mono(t + tau[k]) - 2 * v_r * math.cos(squint) * tau[k] + excess[k]
        # The paper's channel phase imbalance is the v_r term: up to 1.3 rad here; the model error stays < 0.01 rad.
        assert np.max(np.abs(exact - model)) * 2 * np.pi / lam < 0.01


# ---------------------------------------------------------------------------------------------- static


def test_static_target_conventional_modified_and_single_channel_agree(static_case):
    raw, single = static_case
    ref = backproject(single, BackprojectParams())
    images = {}
    for method in ("conventional", "modified"):
        rec = reconstruct(raw, ReconstructParams(method=method))
        assert rec.kind == "raw" and rec.data.shape[0] == 3 * raw.data.shape[1]
        assert rec.radar.prf == pytest.approx(3000.0)
        assert rec.attrs["reconstruct"]["moving_targets"] == []  # nothing moves: no window is re-processed
        images[method] = backproject(rec, BackprojectParams())
        assert_theory(evaluate_product(images[method]), irw_tol=0.01, db_tol=0.25, pos_cells=0.02, n_targets=1)
    a, b, c = images["conventional"].data, images["modified"].data, ref.data
    assert np.linalg.norm(a - b) / np.linalg.norm(a) < 1e-5  # modified == conventional up to rounding
    assert np.linalg.norm(a - c) / np.linalg.norm(c) < 0.02  # the N PRF single-channel simulation
    assert abs(20 * np.log10(np.abs(a).max() / np.abs(c).max())) < 0.05


# ---------------------------------------------------------------------------------------------- moving


def test_moving_target_conventional_ghosts_and_modified_suppression(moving_case):
    raw, rec = moving_case
    conv, mod = rec["conventional"], rec["modified"]
    assert false_target_db(conv, raw) > -10.0  # the channel imbalance folds energy into ghosts
    assert false_target_db(mod, raw) < -50.0
    (mt,) = mod.attrs["reconstruct"]["moving_targets"]
    assert mt["radial_velocity"] == pytest.approx(10.0, abs=0.1)
    assert abs(mt["along_track_velocity"]) < 0.2
    assert mod.aux["velocity_search_0"].shape[1] == 2 and len(mod.aux["velocity_search_0"]) < 80
    assert_theory(evaluate_product(focused(mod, raw)), irw_tol=0.02, db_tol=0.3, pos_cells=0.1)


@pytest.mark.parametrize("error", [0.2, 0.5, 1.0])
def test_false_target_level_against_velocity_error_follows_first_order_theory(moving_case, error):
    """A slant-range velocity error e leaves channel phases 4 pi e cos(theta) tau_n / lambda:
    eq. (6) predicts the ghost."""
    raw, _ = moving_case
    r = raw.radar
    rec = reconstruct(raw, ReconstructParams(radial_velocity=10.0 + error, along_track_velocity=0.0))
    tau = channels.channel_delays(raw.aux["rx_offset"][:, 0], r.velocity)
    phase = 4 * np.pi * error * math.cos(r.squint) * tau / r.wavelength
    half_band = r.velocity * math.cos(r.squint) * r.azimuth_beamwidth / r.wavelength
    predicted = channels.ghost_level_db(tau, r.prf, phase, half_band)
    assert false_target_db(rec, raw) == pytest.approx(predicted, abs=1.0)


def test_moving_target_with_along_track_velocity_is_estimated_and_focused():
    raw = simulate(scene_from_mapping(scene([mover("C", v_r=10.0, v_a=10.0)])))
    rec = reconstruct(raw, ReconstructParams())
    (mt,) = rec.attrs["reconstruct"]["moving_targets"]
    assert mt["radial_velocity"] == pytest.approx(10.0, abs=0.1)
    assert mt["along_track_velocity"] == pytest.approx(10.0, abs=0.3)
    assert_theory(evaluate_product(focused(rec, raw)), irw_tol=0.02, db_tol=0.3, pos_cells=0.1)
    conv = reconstruct(raw, ReconstructParams(method="conventional"))
    report = evaluate_product(focused(conv, raw))
    assert report.targets[0].axis("azimuth").irw_ratio > 1.2  # v_a defocuses the conventional result


def test_noise_gives_no_false_window_and_keeps_the_estimate():
    """Raw SNR 0 dB: noise-only range cells stay below the detection floor; C is still estimated."""
    m = scene([mover("C", v_r=10.0, v_a=10.0)])
    m["effects"]["noise"] = {"snr": "0 dB"}
    raw = simulate(scene_from_mapping(m))
    (mt,) = reconstruct(raw, ReconstructParams()).attrs["reconstruct"]["moving_targets"]
    assert mt["radial_velocity"] == pytest.approx(10.0, abs=0.1)
    assert mt["along_track_velocity"] == pytest.approx(10.0, abs=0.3)


def test_blind_velocities_are_told_apart_by_range_walk():
    """v_r and v_r - lambda PRF / (2 cos) give the same channel samples; the estimate must not take the alias."""
    raw = simulate(scene_from_mapping(scene([mover(v_r=-12.0)])))
    rec = reconstruct(raw, ReconstructParams(autofocus=False, along_track_velocity=0.0))
    (mt,) = rec.attrs["reconstruct"]["moving_targets"]
    assert mt["radial_velocity"] == pytest.approx(-12.0, abs=0.1)
    alias = -12.0 + C / 9.6e9 * 1000.0 / (2 * math.cos(math.radians(20)))  # lambda PRF / (2 cos(theta)) = 16.6 m/s
    at_alias = reconstruct(raw, ReconstructParams(autofocus=False, along_track_velocity=0.0, radial_velocity=alias))
    (ma,) = at_alias.attrs["reconstruct"]["moving_targets"]
    assert ma["leakage"] == pytest.approx(mt["leakage"], rel=0.2)  # the leakage criterion alone cannot choose


def test_blind_velocity_alias_is_chosen_again_with_the_along_track_velocity():
    """v_r 18, v_a 10 m/s at 20 deg: at v_a = 0 its v_los reads as v_r 18 + 10 tan(20 deg) = 21.6 m/s, beyond the
    [-20, 20] search, so the first search keeps an alias; with v_a estimated the true v_r is inside the bounds."""
    raw = simulate(scene_from_mapping(scene([mover(v_r=18.0, v_a=10.0)])))
    (mt,) = reconstruct(raw, ReconstructParams()).attrs["reconstruct"]["moving_targets"]
    assert mt["radial_velocity"] == pytest.approx(18.0, abs=0.2)  # not 18 - 16.6 (one blind velocity)
    assert mt["along_track_velocity"] == pytest.approx(10.0, abs=0.3)
    assert not mt["at_bound"]


# ---------------------------------------------------------------------------------------------- hard cases


@pytest.mark.parametrize("v_r", [20.0, 20.5])
def test_velocity_on_and_beyond_the_search_bound_stays_finite(v_r, caplog):
    raw = simulate(scene_from_mapping(scene([mover(v_r=v_r)])))
    with caplog.at_level(logging.WARNING):
        rec = reconstruct(raw, ReconstructParams(autofocus=False, along_track_velocity=0.0))
    assert np.all(np.isfinite(rec.data))
    (mt,) = rec.attrs["reconstruct"]["moving_targets"]
    assert -20.0 <= mt["radial_velocity"] <= 20.0
    if v_r == 20.0:
        assert mt["radial_velocity"] == pytest.approx(20.0, abs=0.1)
    else:  # beyond the bound: only an alias (20.5 - 16.6 m/s) is inside; its range walk gives it away
        assert mt["at_bound"]
    assert mt["at_bound"] == ("search bound" in caplog.text)


def test_single_channel_is_passed_through(caplog):
    m = scene(radar={"prf": "3000 Hz"})
    m["effects"]["azimuth_channels"] = {"n_receivers": 1, "spacing": "5 m"}
    raw = simulate(scene_from_mapping(m))
    assert raw.kind == "raw_multichannel" and raw.data.shape[0] == 1
    rec = reconstruct(raw, ReconstructParams(method="conventional"))
    assert rec.attrs["reconstruct"]["condition_number"] == pytest.approx(1.0)
    np.testing.assert_allclose(rec.data, raw.data[0], atol=2e-5 * np.abs(raw.data).max())


def test_channel_imbalance_gives_bounded_reported_ghosts():
    """3 deg / 3 % errors on one channel: the filter bank cannot see them; ghosts rise but stay small."""
    m = scene()
    m["effects"]["azimuth_channels"].update(
        phase_imbalance=["0 deg", "0 deg", "3 deg"], amplitude_imbalance=[0, 0, 0.03]
    )
    raw = simulate(scene_from_mapping(m))
    rec = reconstruct(raw, ReconstructParams(method="conventional"))
    assert np.all(np.isfinite(rec.data))
    r = raw.radar
    gain = np.array([1.0, 1.0, 1.03 * np.exp(1j * np.radians(3.0))])
    tau = channels.channel_delays(raw.aux["rx_offset"][:, 0], r.velocity)
    half_band = r.velocity * math.cos(r.squint) * r.azimuth_beamwidth / r.wavelength
    predicted = channels.ghost_level_db(tau, r.prf, -1j * np.log(gain), half_band)  # eq. (6): about -36 dB
    assert -40.0 < predicted < -30.0
    assert false_target_db(rec, raw) == pytest.approx(predicted, abs=1.5)
    # the product's own prediction: delays from the transmitter (a common delay shift moves every ghost piece
    # of band offset k by the same phase, so the level is the same)
    assert channels.product_ghost_level_db(raw, -1j * np.log(gain)) == pytest.approx(predicted, abs=1e-9)
    assert channels.product_ghost_level_db(raw, np.zeros(3)) < -200  # no error: no ghost (round-off only)


def test_ill_conditioned_prf_reports_condition_and_regularises(caplog):
    m = scene(radar={"prf": "1500 Hz"})  # phase centres clump: 1.5 x the uniform PRF
    raw = simulate(scene_from_mapping(m))
    with caplog.at_level(logging.WARNING):
        plain = reconstruct(raw, ReconstructParams(method="conventional"))
    info = plain.attrs["reconstruct"]
    assert info["condition_number"] > 100 and "condition number" in caplog.text
    reg = reconstruct(raw, ReconstructParams(method="conventional", regularization=1e-2))
    info_reg = reg.attrs["reconstruct"]
    assert np.all(np.isfinite(reg.data)) and np.all(np.isfinite(plain.data))
    assert info_reg["noise_gain_db"] < info["noise_gain_db"] - 10


def test_clutter_is_nulled_with_a_redundant_channel():
    """N = 3 channels, Doppler band 1.6 kHz at PRF 1 kHz: two aliases carry clutter, one channel is spare."""
    m = scene([mover("B", v_r=10.0, amplitude=0.0)])
    m["effects"]["antenna"]["azimuth_beamwidth"] = "0.2 deg"
    m["effects"]["clutter"] = {"n_scatterers": 60, "azimuth_extent": "300 m", "range_extent": "200 m"}
    raw = simulate(scene_from_mapping(m))
    rec = reconstruct(raw, ReconstructParams(method="conventional", clutter_suppression=True))
    info = rec.attrs["reconstruct"]
    assert info["clutter_redundant_channels"] == 1
    assert info["clutter_suppression_db"] < -23.0  # measured -26.0 dB; the rect beam's tails limit it


def test_clutter_null_leaves_exactly_the_clutter_spectrum_beyond_its_band():
    """The null's residual is the clutter's own Doppler spectrum outside the nulled band (issue 19).

    The same clutter seen by one channel at N PRF (no aliasing, no channel model) has that much of its
    spectrum beyond clutter_band x B_a / 2: any error of the null's steering model (channel phase against
    range or Doppler, time alignment, the channels' antenna gains) would add to it."""
    from sarproc.focus.multichannel import reconstruct as rc

    def in_band(m, null):
        raw = simulate(scene_from_mapping(m))
        g = rc._geometry(raw, ReconstructParams())
        spec, f_r, *_ = rc._to_deramped(raw, g)
        fa = sfft.fft(spec[:, :, np.abs(f_r) <= raw.radar.bandwidth / 2], axis=1)
        if null:
            out = rc.clutter_null(fa, g, band)[0]
        else:
            out = fa * (np.abs(np.fft.fftfreq(fa.shape[1], 1 / g.prf)) > band * g.half_band)[None, :, None]
        return 10 * math.log10(float(np.sum(np.abs(out) ** 2) / np.sum(np.abs(fa) ** 2)))

    m = scene([mover("B", v_r=10.0, amplitude=0.0)])
    m["effects"]["antenna"]["azimuth_beamwidth"] = "0.2 deg"
    m["effects"]["clutter"] = {"n_scatterers": 30, "azimuth_extent": "300 m", "range_extent": "200 m"}
    one = dict(m)
    one["radar"] = dict(m["radar"], prf="3000 Hz")  # N PRF, one receiver
    one["effects"] = dict(m["effects"], azimuth_channels={"n_receivers": 1, "spacing": "5 m"})
    band = ReconstructParams().clutter_band
    nulled, beyond = in_band(m, True), in_band(one, False)
    # measured -27.16 dB (the null -27.15): the rect beam's Fresnel tails beyond 1.2 B_a / 2
    assert -40.0 < beyond < -20.0
    assert abs(nulled - beyond) < 0.1


def test_wrong_products_are_refused():
    raw = simulate(scene_from_mapping(scene(effects={"azimuth_channels": None})))
    with pytest.raises(InputError, match="raw_multichannel"):
        reconstruct(raw, ReconstructParams())
    with pytest.raises(InputError, match="velocity_max"):
        from sarproc.product.config import build

        build(
            ReconstructParams,
            {"velocity_min": "5 m/s", "velocity_max": "-5 m/s"},
            source="t.yaml",
            section="reconstruct",
        )


def test_multichannel_and_clutter_effects_declare_their_geometry_and_cost():
    raw = simulate(scene_from_mapping(scene()))
    assert raw.kind == "raw_multichannel" and raw.dims == ("channel", "azimuth_time", "range_time")
    np.testing.assert_allclose(raw.aux["rx_offset"], [[-5, 0, 0], [0, 0, 0], [5, 0, 0]])
    np.testing.assert_allclose(raw.aux["tx_offset"], [0, 0, 0])
    m = scene()
    m["effects"]["clutter"] = {
        "n_scatterers": 1000,
        "azimuth_extent": "100 m",
        "range_extent": "100 m",
        "max_evaluations": 1e6,
    }
    with pytest.raises(InputError, match="max_evaluations"):  # 600 pulses x 3 ch x 1000 x 146 samples
        scene_from_mapping(m)
    with pytest.raises(InputError, match="phase_imbalance"):
        m = scene()
        m["effects"]["azimuth_channels"]["phase_imbalance"] = ["1 deg"]
        scene_from_mapping(m)


def test_ground_moving_target_seen_from_500_km_altitude():
    """With altitude the estimate is the slant-range component v_y y / sqrt(y^2 + H^2) of a ground velocity v_y."""
    raw = simulate(scene_from_mapping(scene([mover(v_r=10.0, v_a=5.0)], platform={"altitude": "500 km"})))
    t = raw.targets[0]
    slant = 10.0 * t["y"] / math.hypot(t["y"], 500e3)  # 4.62 m/s
    rec = reconstruct(raw, ReconstructParams())
    (mt,) = rec.attrs["reconstruct"]["moving_targets"]
    assert mt["radial_velocity"] == pytest.approx(slant, abs=0.1)
    assert mt["along_track_velocity"] == pytest.approx(5.0, abs=0.3)
    assert_theory(evaluate_product(focused(rec, raw)), irw_tol=0.02, db_tol=0.3, pos_cells=0.1)


def test_reconstruct_counts_the_non_finite_samples_it_writes(static_case):
    """attrs['reconstruct']['non_finite_samples']: the NaN / Inf samples of the output (scripts/hard_cases_003.py
    counted them itself before): 0 on a clean scene, and the output's own count where one bad input sample
    spreads through the filter bank."""
    raw, _ = static_case
    rec = reconstruct(raw, ReconstructParams(method="conventional"))
    assert rec.attrs["reconstruct"]["non_finite_samples"] == 0
    bad = raw.derive(raw.kind, raw.data.copy(), raw.dims, raw.coords)
    bad.data[1, 100, 50] = np.nan
    rec = reconstruct(bad, ReconstructParams(method="conventional"))
    count = int(np.count_nonzero(~np.isfinite(rec.data)))
    assert count > 0 and rec.attrs["reconstruct"]["non_finite_samples"] == count


def test_detections_matched_to_the_static_truth_points():
    """reconstruct's truth record against the static points (scripts/mover_campaign.py matched them itself
    before): per static point the table rows within TRUTH_MATCH_M of it, per row matched to no mover its nearest
    static point, the distance and whether it lies at it."""
    from sarproc.focus.multichannel import reconstruct as rc
    from sarproc.product.model import MOVING_TARGET_COLUMNS, make_targets

    xyz = [[0.0, 1000.0, 0.0], [500.0, 1000.0, 0.0], [0.0, 1300.0, 0.0]]
    truth = make_targets(["S1", "M", "S2"], xyz, [1, 1, 1], velocity=[[0, 0, 0], [0, 5, 0], [0, 0, 0]])
    col = [name for name, _, _ in MOVING_TARGET_COLUMNS]
    rows = np.zeros((3, len(col)))
    apparent = [[300.0, 1000.0, 0.0], [3.0, 1004.0, 0.0], [40.0, 1270.0, 0.0]]  # M's, 5 m from S1, 50 m from S2
    for i, (a, k) in enumerate(zip(apparent, (1, -1, -1))):
        rows[i, col.index("apparent_x") : col.index("apparent_z") + 1] = a
        rows[i, col.index("truth_index")] = k
    out = rc._static_matches(truth, rows, ["S1", "M", "S2"], [0, 2])
    assert out["static_points"] == [{"name": "S1", "detections_within": 1}, {"name": "S2", "detections_within": 0}]
    (u1, u2) = out["unmatched"]
    assert u1 == {"row": 1, "nearest_static": "S1", "distance": pytest.approx(5.0), "at_static": True}
    assert u2 == {"row": 2, "nearest_static": "S2", "distance": pytest.approx(50.0), "at_static": False}
    none = rc._static_matches(truth, rows, ["S1", "M", "S2"], [])
    assert none["static_points"] == [] and none["unmatched"][0]["nearest_static"] is None
    assert none["unmatched"][0]["at_static"] is False and rc.TRUTH_MATCH_M == 20.0


# ---------------------------------------------------------------------------------------------- range compression


def _cross_window_lines(rec, raw, window_range: float) -> list[float]:
    """A static target A's (at 0, 0) range response inside a mover's velocity window, reconstructed with the
    mover's velocity: its line at A's -1 and +1 ambiguities (max over 40 m of azimuth), mean power over the
    window's 120 m of walk-corrected range, dB re A's peak."""
    spacing = channels.ghost_spacing(rec.radar, raw.radar.prf)
    ref = rec.radar.reference_range
    chip = dict(frame="squint_lrwc", range_extent=8.0, azimuth_extent=8.0, oversample=2)
    peak = float(np.abs(backproject(rec, BackprojectParams(**chip, azimuth_center=0.0, range_center=ref)).data).max())
    out = []
    for side in (-1, 1):
        line = backproject(
            rec,
            BackprojectParams(
                frame="squint_lrwc",
                azimuth_center=side * spacing,
                azimuth_extent=40.0,
                range_center=ref + window_range,
                range_extent=120.0,
                oversample=1.2,
            ),
        )
        out.append(10 * math.log10(float(np.mean(np.max(np.abs(line.data) / peak, axis=0) ** 2))))
    return out


def test_band_limited_echoes_compress_with_their_replica_so_cross_window_ghosts_fall():
    """Band-limited echoes carry the sampled replica's spectrum H_s (its aliased Fresnel tails, the same in every
    pulse and channel); compressed with the ideal chirp's phasor they leave a coherent plateau out to c T_p / 2
    (600 m here) that a mover's velocity window cuts into ghosts of the static target beside it (docs/multichannel.md
    sections 15, 16). Measured with A 300 m from the mover's window: ideal-chirp compression (main before) -53.03 /
    -59.30 dB, 2.3 / 2.5 dB above the continuous echoes' -55.31 / -61.82; the replica's equalisation -66.61 / -74.46.
    Continuous echoes keep the ideal chirp's phasor."""
    offset = -300.0
    points = [{"name": "A"}, mover("C", v_r=10.0, range=f"{offset} m")]
    lines, compression = {}, {}
    for waveform in ("continuous", "band_limited"):
        raw = simulate(scene_from_mapping(scene(points, simulation={"waveform": waveform})))
        rec = reconstruct(raw, ReconstructParams())
        (mt,) = rec.attrs["reconstruct"]["moving_targets"]
        assert mt["radial_velocity"] == pytest.approx(10.0, abs=0.1)
        lines[waveform] = _cross_window_lines(rec, raw, offset)
        compression[waveform] = rec.attrs["reconstruct"].get("range_compression")
    for bl, cont in zip(lines["band_limited"], lines["continuous"]):
        assert bl < cont - 6.0
    assert compression == {"continuous": "stationary_phase", "band_limited": "replica_equalised"}


@pytest.mark.parametrize("waveform", ["continuous", "band_limited"])
def test_range_compression_is_undone_exactly(waveform):
    """The compression is one filter per range frequency, undone by its reciprocal after the reconstruction, so
    a conventional (static) reconstruction does not depend on it: the replica's equalisation gives the ideal
    chirp's product to float precision (it has no zero bin; replica_flat, zero beyond B/2, would not), and a
    continuous product is compressed exactly as before (auto: stationary_phase, the same samples)."""
    raw = simulate(scene_from_mapping(scene(simulation={"waveform": waveform})))
    auto = reconstruct(raw, ReconstructParams(method="conventional"))
    ideal = reconstruct(raw, ReconstructParams(method="conventional", range_compression="stationary_phase"))
    if waveform == "continuous":
        assert auto.attrs["reconstruct"]["range_compression"] == "stationary_phase"
        np.testing.assert_array_equal(auto.data, ideal.data)
    else:
        assert auto.attrs["reconstruct"]["range_compression"] == "replica_equalised"
        err = np.max(np.abs(auto.data - ideal.data)) / np.max(np.abs(ideal.data))
        assert err < 1e-5  # complex64 rounding
        flat = reconstruct(raw, ReconstructParams(method="conventional", range_compression="replica_flat"))
        assert np.max(np.abs(flat.data - ideal.data)) / np.max(np.abs(ideal.data)) > 1e-3


@pytest.mark.parametrize("offset", [0.0, 0.7, 1.9])
def test_replica_compression_leaves_no_copy_one_pulse_length_away(offset):
    """A band-limited echo's replica spectrum |H_s| beyond B/2 is two aliased Fresnel tails (of the pulse's end
    and its start) beating with period 1 / T_p; the compressed spectrum kept that beat beyond B/2 (|H_s|^2 to
    f_s / 2) and so put a copy of every response one pulse length either side in range: -36 dB here, where a band
    B's response has side lobes of 1 / (pi B T_p) = -51.5 dB at T_p. The CFAR took such copies for targets (the
    -600 m sinc scene's false alarm, docs/multichannel.md sections 26.3 and 30). The roll-off is now the replica's
    power with its aliases summed in power: the copy is under that side-lobe level (-56.5 ... -61 dB), at
    fractional delays too, and so is every far side lobe."""
    from sarproc.focus.multichannel import reconstruct as rc

    raw = simulate(scene_from_mapping(scene([{"name": "A", "range": f"{offset} m"}], simulation=None)))
    r = raw.radar
    n_rg = raw.data.shape[2]
    n_fft = sfft.next_fast_len(4 * n_rg)
    f_r = sfft.fftfreq(n_fft, 1.0 / r.range_sampling_rate)
    comp, expand, mode = rc.range_compression_filters(raw, f_r)
    assert mode == "replica_equalised"
    x = np.zeros(n_fft, complex)
    x[:n_rg] = raw.data[0, raw.data.shape[1] // 2]
    y = np.abs(sfft.ifft(sfft.fft(x) * comp))
    k = int(np.argmax(y))
    lag = round(r.pulse_duration * r.range_sampling_rate)
    side_lobe = 20 * math.log10(1 / (math.pi * r.bandwidth * r.pulse_duration))
    for centre in (k - lag, k + lag):
        copy = 20 * math.log10(float(y[centre - 4 : centre + 5].max() / y[k]))
        assert copy < side_lobe - 3.0, (offset, centre - k, copy, side_lobe)
    far = 20 * math.log10(float(np.max(np.r_[y[k - 2 * lag : k - 60], y[k + 60 : k + 2 * lag]]) / y[k]))
    assert far < side_lobe, far
    assert np.all(np.abs(comp) > 0) and np.allclose(comp * expand, 1.0)
