"""Issue 19: every mover detected, separated, estimated and relocated by ``reconstruct`` (reduced scenes).

The radar of configs/xu_scene.yaml (X band, 7.5 km/s, 600 km, 20 deg squint, 0.507 deg beam: Doppler
band 4 kHz at PRF 2500 Hz) with a 10 MHz chirp sampled at 12 MHz (12.5 m range cells: a third of
the samples) so each scene reconstructs in seconds. Truth movers are matched by the reconstruct stage
itself (moving_targets column truth_index), and checked here against the truth velocities.
"""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np
import pytest

from sarproc.focus.multichannel import detection
from sarproc.focus.multichannel.reconstruct import ReconstructParams, reconstruct
from sarproc.product.config import load_yaml
from sarproc.product.io import read_product, write_product
from sarproc.product.model import MOVING_TARGET_COLUMNS, moving_target_table
from sarproc.simulation.scene import scene_from_mapping
from sarproc.simulation.simulate import simulate

CONFIG = Path(__file__).resolve().parents[2] / "configs" / "xu_scene.yaml"


def scene(points, n_receivers=3, spacing="2 m", clutter=None):
    m = load_yaml(CONFIG)
    for key in ("reconstruct", "backproject", "evaluate"):
        m.pop(key, None)
    m["radar"].update({"bandwidth": "10 MHz", "range_sampling_rate": "12 MHz"})
    m["targets"]["points"] = points
    m["effects"]["azimuth_channels"] = {"n_receivers": n_receivers, "spacing": spacing}
    if clutter:
        m["effects"]["clutter"] = clutter
    return m


def vehicle(name, azimuth, rng, v_a, v_r, amplitude=1.0):
    return {
        "name": name,
        "azimuth": f"{azimuth} m",
        "range": f"{rng} m",
        "amplitude": amplitude,
        "velocity": [f"{v_a} m/s", f"{v_r} m/s", "0 m/s"],
    }


def found(rec):
    """{truth name: row} of the moving-target table, and the unmatched rows."""
    t = moving_target_table(rec.aux)
    names = [n.decode() for n in rec.targets["name"]]
    rows = [{k: float(v[i]) for k, v in t.items()} for i in range(len(t["id"]))]
    return {names[int(r["truth_index"])]: r for r in rows if r["truth_index"] >= 0}, [
        r for r in rows if r["truth_index"] < 0
    ]


def check(rec, truth_names, v_tol=0.1):
    by_name, false = found(rec)
    assert sorted(by_name) == sorted(truth_names), (sorted(by_name), false)
    assert not false
    tt = {n.decode(): k for k, n in enumerate(rec.targets["name"])}
    for name, row in by_name.items():
        k = tt[name]
        assert row["v_r"] == pytest.approx(rec.targets["vy"][k], abs=v_tol), name
        assert row["v_a"] == pytest.approx(rec.targets["vx"][k], abs=0.3), name
        err = np.hypot(row["relocated_x"] - rec.targets["x"][k], row["relocated_y"] - rec.targets["y"][k])
        # relocation within 3 sigma of what its velocity uncertainty implies, plus 2 m of apparent-position error
        assert err < 3 * row["relocation_sigma"] + 2.0, (name, err, row["relocation_sigma"])
    return by_name


@pytest.fixture(scope="module")
def two_movers():
    """Issue 19's case: v_r 10 and -6 m/s, 80 m apart in walk-corrected range (one old window)."""
    raw = simulate(scene_from_mapping(scene([vehicle("M1", 800, 0, 0, 10), vehicle("M2", 600, 148, 0, -6)])))
    return raw


def test_two_movers_in_one_range_window_are_both_found_and_estimated(two_movers, caplog):
    with caplog.at_level(logging.WARNING):
        rec = reconstruct(two_movers, ReconstructParams())
    check(rec, ["M1", "M2"])
    assert "search bound" not in caplog.text and "could not be separated" not in caplog.text
    assert rec.attrs["reconstruct"]["truth"] == {"movers": 2, "found": 2, "missed": [], "false_alarms": 0}


def test_movers_sharing_a_range_cell_are_separated_in_azimuth(caplog):
    """Two vehicles 3 m apart in range (one 12.5 m cell), opposite directions, one 6 dB weaker."""
    raw = simulate(scene_from_mapping(scene([vehicle("P", 0, 0, 4, 12), vehicle("Q", 0, 3, -4, -12, 0.5)])))
    with caplog.at_level(logging.WARNING):
        rec = reconstruct(raw, ReconstructParams())
    by_name = check(rec, ["P", "Q"])
    assert abs(by_name["P"]["range_cell_first"] - by_name["Q"]["range_cell_first"]) <= 1
    assert "could not be separated" not in caplog.text


def test_movers_at_one_apparent_position_are_reported_not_separated(caplog):
    """Same walk-corrected range and the same apparent azimuth: the warning names both and the cells."""
    # P and R: same v_los, so the same azimuth shift; R 60 m (5 cells) further in range, inside P's window.
    raw = simulate(scene_from_mapping(scene([vehicle("P", 0, 0, 0, 10), vehicle("R", 0, 60, 0, 10)])))
    with caplog.at_level(logging.WARNING):
        reconstruct(raw, ReconstructParams())
    assert "could not be separated" in caplog.text
    assert "search bound" not in caplog.text


def test_movers_in_clutter_are_found_after_the_clutter_null():
    """Four receivers, 150 clutter scatterers (rms 1 each, as bright as the movers) in their range cells."""
    raw = simulate(
        scene_from_mapping(
            scene(
                [
                    vehicle("V1", -100, 20, 8, -12, 0.7),
                    vehicle("V2", 120, -10, -6, 15),
                    {"name": "S", "azimuth": "50 m", "range": "60 m"},
                ],
                n_receivers=4,
                spacing="1.5 m",
                clutter={"n_scatterers": 150, "azimuth_extent": "600 m", "range_extent": "250 m", "seed": 4},
            )
        )
    )
    rec = reconstruct(raw, ReconstructParams(clutter_suppression=True))
    check(rec, ["V1", "V2"])


def test_mover_free_scene_with_clutter_gives_no_false_alarm():
    raw = simulate(
        scene_from_mapping(
            scene(
                [{"name": "S1"}, {"name": "S2", "azimuth": "100 m", "range": "-40 m"}],
                n_receivers=4,
                spacing="1.5 m",
                clutter={"n_scatterers": 150, "azimuth_extent": "600 m", "range_extent": "250 m", "seed": 4},
            )
        )
    )
    rec = reconstruct(raw, ReconstructParams(clutter_suppression=True))
    assert rec.aux["moving_targets"].shape == (0, len(MOVING_TARGET_COLUMNS))
    assert "truth" not in rec.attrs["reconstruct"]  # no moving truth target to find


def test_moving_target_table_is_written_read_and_carried(two_movers, tmp_path):
    rec = reconstruct(two_movers, ReconstructParams())
    path = tmp_path / "rec.h5"
    write_product(path, rec)
    back = read_product(path)
    np.testing.assert_array_equal(back.aux["moving_targets"], rec.aux["moving_targets"])
    assert len(moving_target_table(back.aux)["v_r"]) == 2


def test_detection_keeps_a_weak_peak_beside_a_strong_one_and_drops_side_lobes():
    n = 2048
    t = np.arange(n) / 1000.0
    power = np.full((n, 40), 1e-6, np.float32)
    x = np.arange(n) - 1000.0
    power[:, 20] += (1e4 * np.sinc(x / 2.0) ** 2).astype(np.float32)  # strong point, sinc side lobes
    power[1300, 24] += 50.0  # weak target 4 cells away in range
    found, dropped = detection.find_detections(power, detection.background(power), t, 15.0, -40.0, 1.2, 10)
    cells = sorted((d.index, d.cell) for d in found)
    assert cells == [(1000, 20), (1300, 24)]
    assert dropped == 0


def test_extraction_separates_two_chirps_in_one_range_cell():
    prf, ka, n = 2500.0, 5300.0, 3000
    t = (np.arange(n) - n / 2) / prf
    x = np.zeros((1, n, 1), np.complex64)
    for t0, a in ((-0.1, 1.0), (0.05, 0.5)):  # two targets 150 ms apart in apparent time
        inside = np.abs(t - t0) < 0.3
        x[0, :, 0] += (a * inside * np.exp(-1j * np.pi * ka * (t - t0) ** 2)).astype(np.complex64)
    one = detection.extract(x, t, prf, 0.05, np.array([ka]), 25.0)
    inside = np.abs(t - 0.05) < 0.3
    ref = 0.5 * inside * np.exp(-1j * np.pi * ka * (t - 0.05) ** 2)
    other = inside_other = np.abs(t + 0.1) < 0.3
    other = inside_other * np.exp(-1j * np.pi * ka * (t + 0.1) ** 2)
    err = np.linalg.norm(one[0, :, 0] - ref) / np.linalg.norm(ref)
    leak = abs(np.vdot(other, one[0, :, 0])) / (np.linalg.norm(other) * np.linalg.norm(one[0, :, 0]))
    assert err < 0.1  # this one kept (its hard illumination edges are smoothed by the mask)
    assert leak < 0.01  # the other one gone


def test_a_moving_target_table_of_the_wrong_width_is_refused(two_movers, tmp_path):
    from sarproc.product.errors import InputError

    rec = reconstruct(two_movers, ReconstructParams(method="conventional"))
    rec.aux["moving_targets"] = np.zeros((1, 5))
    write_product(tmp_path / "bad.h5", rec)
    with pytest.raises(InputError, match="moving_targets' has 5 columns"):
        read_product(tmp_path / "bad.h5")


def test_a_static_target_in_a_movers_range_cells_is_unaffected():
    """S shares P's walk-corrected range cells 200 m away in azimuth: its image equals S imaged alone."""
    from sarproc.focus.backprojection import BackprojectParams, backproject

    s_pt = {"name": "S", "azimuth": "200 m", "range": "-68 m"}  # 200 sin(20 deg) = 68 m: P's cells
    both = reconstruct(simulate(scene_from_mapping(scene([vehicle("P", 0, 0, 4, 12), s_pt]))), ReconstructParams())
    alone = reconstruct(simulate(scene_from_mapping(scene([s_pt]))), ReconstructParams())
    assert len(moving_target_table(both.aux)["id"]) == 1 and len(moving_target_table(alone.aux)["id"]) == 0
    chip = BackprojectParams(azimuth_extent=30.0, range_extent=60.0, azimuth_center=200.0, range_center=600000 - 68.0)
    a, b = (backproject(p, chip).data for p in (both, alone))
    level = 20 * np.log10(np.abs(a - b).max() / np.abs(b).max())
    assert level < -40.0, level  # P leaves S within -40 dB (measured -67 dB)
