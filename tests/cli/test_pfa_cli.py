"""sarproc pfa2 and sarproc import-gotcha through the command line."""

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml
from click.testing import CliRunner

from sarproc.cli.main import cli
from sarproc.product.io import read_product
from tests.quality.test_ground_plane_ridges import SCENE as GROUND_PLANE_SCENE

ROOT = Path(__file__).resolve().parents[2]
GOTCHA = ROOT.parent / "shared" / "data" / "gotcha"
SMALL = yaml.safe_load((ROOT / "configs" / "nie2016_small.yaml").read_text())


def run(*args):
    return CliRunner().invoke(cli, [str(a) for a in args], catch_exceptions=False)


@pytest.fixture(scope="module")
def raw_file(tmp_path_factory):
    d = tmp_path_factory.mktemp("pfa")
    scene = dict(SMALL, targets={"frame": "ground_los", "points": [{"name": "C"}, {"name": "P", "azimuth": "20 m"}]})
    (d / "scene.yaml").write_text(yaml.safe_dump(scene))
    res = run("simulate", d / "scene.yaml", "-o", d / "raw.h5")
    assert res.exit_code == 0, res.output
    return d / "raw.h5"


def test_pfa2_help_lists_the_section():
    res = run("pfa2", "--help")
    assert res.exit_code == 0 and "pfa2:" in res.output
    assert run("import-gotcha", "--help").exit_code == 0


def test_pfa2_writes_a_ground_los_image(tmp_path, raw_file):
    cfg = tmp_path / "c.yaml"
    cfg.write_text(yaml.safe_dump({"pfa2": {"method": "plain", "azimuth_extent": "60 m", "range_extent": "40 m"}}))
    res = run("pfa2", raw_file, "-o", tmp_path / "image.h5", "--config", cfg)
    assert res.exit_code == 0, res.output
    img = read_product(tmp_path / "image.h5")
    assert img.kind == "image" and img.attrs["frame"]["name"] == "ground_los"
    assert img.dims == ("azimuth", "range") and len(img.attrs["theoretical_irw"]) == 2
    assert res.exit_code == 0 and run("evaluate", tmp_path / "image.h5", "-o", tmp_path / "r.json").exit_code == 0


def test_pfa2_bad_key_and_value_exit_2(tmp_path, raw_file):
    cfg = tmp_path / "c.yaml"
    cfg.write_text(yaml.safe_dump({"pfa2": {"methd": "plain"}}))
    res = run("pfa2", raw_file, "-o", tmp_path / "image.h5", "--config", cfg)
    assert res.exit_code == 2 and "methd" in res.output and str(cfg) in res.output
    cfg.write_text(yaml.safe_dump({"pfa2": {"method": "three_step"}}))
    res = run("pfa2", raw_file, "-o", tmp_path / "image.h5", "--config", cfg)
    assert res.exit_code == 2 and "pfa2.method" in res.output
    assert not (tmp_path / "image.h5").exists()


def pfa2_process_modules(raw, config, image):
    """The modules a `sarproc pfa2` process has imported when it is done."""
    code = (
        "import json, sys\nfrom sarproc.cli.main import run_cli\n"
        f"assert run_cli(['pfa2', {str(raw)!r}, '--config', {str(config)!r}, '-o', {str(image)!r}, '-q']) == 0\n"
        "print(json.dumps(sorted(sys.modules)))"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=dict(os.environ))
    assert done.returncode == 0, done.stderr[-2000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


def test_two_step_pfa_imports_no_scipy_interpolate(tmp_path, raw_file):
    # the two-step with its distortion warp, as a process runs it: scipy.interpolate (with the scipy.linalg,
    # sparse, special and fft it brings) cost a pfa2 process ~0.5 s (docs/performance.md, "Per-process overhead")
    loaded = pfa2_process_modules(raw_file, ROOT / "configs" / "nie2016_small.yaml", tmp_path / "image.h5")
    assert "sarproc.focus.pfa.two_step" in loaded
    assert not [m for m in loaded if m.startswith(("scipy.interpolate", "scipy.fft"))]


def test_de_aliasing_pfa_imports_no_scipy_interpolate(tmp_path):
    # the sub-aperture de-aliasing splines the track at the upsampled pulses: through CubicSpline it imported
    # scipy.interpolate (nie2016_sliding_small's dealias step 2.25 s of a loaded machine, 0.24 s without)
    config = ROOT / "configs" / "nie2016_sliding_small.yaml"
    res = run("simulate", config, "-o", tmp_path / "raw.h5")
    assert res.exit_code == 0, res.output
    loaded = pfa2_process_modules(tmp_path / "raw.h5", config, tmp_path / "image.h5")
    assert "sarproc.focus.pfa.dealias" in loaded
    assert not [m for m in loaded if m.startswith(("scipy.interpolate", "scipy.fft"))]


@pytest.mark.skipif(not GOTCHA.exists(), reason="Gotcha data not present")
def test_gotcha_pfa_and_backprojection_agree(tmp_path):
    res = run("import-gotcha", GOTCHA, "-o", tmp_path / "raw.h5")
    assert res.exit_code == 0, res.output
    raw = read_product(tmp_path / "raw.h5")
    assert raw.kind == "raw" and raw.aux["platform_position"].shape == (raw.data.shape[0], 3)
    from sarproc.focus.pfa.chain import image_frame

    # 24 m x 24 m around the brightest scatterer (a calibration-like point 22 m, 15 m from the centre)
    grid = {
        "azimuth_extent": 24.0,
        "range_extent": 24.0,
        "azimuth_spacing": 0.1,
        "range_spacing": 0.1,
        "azimuth_center": 22.0,
        "range_center": image_frame(raw).ground_range + 15.0,
    }
    cfg = tmp_path / "g.yaml"
    cfg.write_text(
        yaml.safe_dump(
            {
                "pfa2": {"method": "plain", "correct_distortion": True, **grid},
                "backproject": {"frame": "product", **grid},
            }
        )
    )
    assert run("pfa2", tmp_path / "raw.h5", "-o", tmp_path / "pfa.h5", "--config", cfg).exit_code == 0
    assert run("backproject", tmp_path / "raw.h5", "-o", tmp_path / "bp.h5", "--config", cfg).exit_code == 0
    a, b = read_product(tmp_path / "pfa.h5"), read_product(tmp_path / "bp.h5")
    assert all(np.allclose(a.coords[d], b.coords[d]) for d in ("azimuth", "range"))
    A, B = np.abs(a.data), np.abs(b.data)
    ncc = ((A - A.mean()) * (B - B.mean())).sum() / np.sqrt(((A - A.mean()) ** 2).sum() * ((B - B.mean()) ** 2).sum())
    assert ncc > 0.95
    ia, ib = np.unravel_index(np.argmax(A), A.shape), np.unravel_index(np.argmax(B), B.shape)
    assert max(abs(i - j) for i, j in zip(ia, ib)) <= 1  # the brightest point on the same pixel


@pytest.fixture(scope="module")
def wide_raw(tmp_path_factory):
    # the reduced Table 1 scene's plain PFA valid radius (eq. 7) is 97.7 m: C and R inside, F beyond
    d = tmp_path_factory.mktemp("pfa_wide")
    points = [{"name": "C"}, {"name": "R", "range": "80 m"}, {"name": "F", "azimuth": "150 m"}]
    (d / "scene.yaml").write_text(yaml.safe_dump(dict(SMALL, targets={"frame": "ground_los", "points": points})))
    res = run("simulate", d / "scene.yaml", "-o", d / "raw.h5")
    assert res.exit_code == 0, res.output
    return d / "raw.h5"


def _warnings(output, phrase):
    return [line for line in output.splitlines() if "WARNING" in line and phrase in line]


def test_plain_pfa_beyond_the_valid_radius_warns_naming_radius_reach_and_targets(tmp_path, wide_raw):
    cfg = tmp_path / "c.yaml"
    cfg.write_text(yaml.safe_dump({"pfa2": {"method": "plain"}}))
    res = run("pfa2", wide_raw, "-o", tmp_path / "image.h5", "--config", cfg)
    assert res.exit_code == 0, res.output
    img = read_product(tmp_path / "image.h5")
    radius = img.attrs["valid_radius"]
    assert 80 < radius < 150
    (text,) = _warnings(res.output, "valid radius")
    assert f"{radius:.4g} m" in text and f"F 150 m ({150 / radius:.2f} radii)" in text and "1 target(s)" in text
    reach = img.attrs["focus_limits"]["image_reach"]
    assert reach > 150 and f"reaches {reach:.4g} m" in text
    assert img.attrs["focus_limits"]["beyond_valid_radius"] == pytest.approx({"F": 150.0})
    res = run("evaluate", tmp_path / "image.h5", "-o", tmp_path / "r.json")
    assert res.exit_code == 0, res.output
    notes = {t["name"]: t["notes"] for t in json.loads((tmp_path / "r.json").read_text())["targets"]}
    assert any("beyond plain PFA's valid radius" in n for n in notes["F"])
    assert not any("valid radius" in n for n in notes["C"] + notes["R"])
    assert "- F: beyond plain PFA's valid radius: 150 m" in res.output


def test_plain_pfa_inside_the_valid_radius_and_two_step_are_silent(tmp_path, raw_file):
    cfg = tmp_path / "c.yaml"
    cfg.write_text(yaml.safe_dump({"pfa2": {"method": "plain"}}))
    res = run("pfa2", raw_file, "-o", tmp_path / "plain.h5", "--config", cfg)
    assert res.exit_code == 0 and not _warnings(res.output, "valid radius"), res.output
    limits = read_product(tmp_path / "plain.h5").attrs["focus_limits"]
    assert (
        limits["beyond_valid_radius"] == {}
        and limits["image_reach"] < read_product(tmp_path / "plain.h5").attrs["valid_radius"]
    )
    res = run("pfa2", raw_file, "-o", tmp_path / "two_step.h5")
    assert res.exit_code == 0 and "WARNING" not in res.output, res.output


def test_two_step_subimages_reaching_past_the_valid_radius_warn(tmp_path, wide_raw):
    cfg = tmp_path / "c.yaml"
    cfg.write_text(yaml.safe_dump({"pfa2": {"method": "two_step"}}))
    res = run("pfa2", wide_raw, "-o", tmp_path / "default.h5", "--config", cfg)
    assert res.exit_code == 0 and not _warnings(res.output, "valid radius"), res.output
    cfg.write_text(yaml.safe_dump({"pfa2": {"method": "two_step", "subimage_size": "400 m"}}))
    res = run("pfa2", wide_raw, "-o", tmp_path / "big.h5", "--config", cfg)
    assert res.exit_code == 0, res.output
    radius = read_product(tmp_path / "default.h5").attrs["valid_radius_eq7"]
    (text,) = _warnings(res.output, "valid radius")
    assert "sub-images of 400 m" in text and f"valid radius of {radius:.4g} m" in text


def test_plain_pfa_without_distortion_correction_notes_the_predicted_displacement(tmp_path, wide_raw):
    # R, 80 m down range, inside the valid radius: its plain PFA response sits ~0.4 cells from the truth on
    # each axis, which is the planar-wavefront distortion left in; evaluate measures it and says so
    cfg = tmp_path / "c.yaml"
    cfg.write_text(yaml.safe_dump({"pfa2": {"method": "plain"}}))
    assert run("pfa2", wide_raw, "-o", tmp_path / "image.h5", "--config", cfg).exit_code == 0
    res = run("evaluate", tmp_path / "image.h5", "-o", tmp_path / "r.json", "--targets", "C,R")
    assert res.exit_code == 0, res.output
    attrs = read_product(tmp_path / "image.h5").attrs
    limits = attrs["focus_limits"]
    report = {t["name"]: t for t in json.loads((tmp_path / "r.json").read_text())["targets"]}
    predicted = np.array(limits["distortion_uncorrected"]["R"]) / np.array(attrs["theoretical_irw"])
    measured = np.array([a["position_error_cells"] for a in report["R"]["axes"]])
    assert np.all(np.abs(predicted) > 0.3) and np.allclose(measured, predicted, atol=0.05)
    (note,) = report["R"]["notes"]
    assert "distortion, left in (pfa2 correct_distortion: false)" in note
    assert f"azimuth {limits['distortion_uncorrected']['R'][0]:+.3g} m ({predicted[0]:+.2f} cells)" in note
    assert report["C"]["notes"] == [] and "- R: its position error includes" in res.output
    # corrected, the responses sit at the truth and nothing is noted
    cfg.write_text(yaml.safe_dump({"pfa2": {"method": "plain", "correct_distortion": True}}))
    assert run("pfa2", wide_raw, "-o", tmp_path / "corrected.h5", "--config", cfg).exit_code == 0
    assert "distortion_uncorrected" not in read_product(tmp_path / "corrected.h5").attrs["focus_limits"]
    res = run("evaluate", tmp_path / "corrected.h5", "-o", tmp_path / "c.json", "--targets", "C,R")
    report = {t["name"]: t for t in json.loads((tmp_path / "c.json").read_text())["targets"]}
    assert report["R"]["notes"] == [] and all(abs(a["position_error_cells"]) < 0.05 for a in report["R"]["axes"])


def test_a_scene_files_stage_section_is_named_when_not_applied(tmp_path):
    # the scene's pfa2 section is applied with --config SCENE; without it the defaults run, and a warning says
    # which of the scene's keys are left out (none when the section only repeats the defaults: raw_file's)
    scene = tmp_path / "scene.yaml"
    points = [{"name": "C"}, {"name": "P", "azimuth": "20 m"}]
    scene.write_text(
        yaml.safe_dump(dict(SMALL, targets={"frame": "ground_los", "points": points}, pfa2={"method": "plain"}))
    )
    assert run("simulate", scene, "-o", tmp_path / "raw.h5").exit_code == 0
    res = run("pfa2", tmp_path / "raw.h5", "-o", tmp_path / "default.h5")
    assert res.exit_code == 0, res.output
    (text,) = _warnings(res.output, "not applied")
    assert f"simulation of {scene}, whose `pfa2:` section (method: plain)" in text
    assert "defaults run (method: two_step)" in text and f"--config {scene}" in text
    assert read_product(tmp_path / "default.h5").attrs["method"] == "two_step"
    res = run("pfa2", tmp_path / "raw.h5", "-o", tmp_path / "plain.h5", "--config", scene)
    assert res.exit_code == 0 and not _warnings(res.output, "not applied"), res.output
    assert read_product(tmp_path / "plain.h5").attrs["method"] == "plain"
    assert "not applied" in " ".join(run("pfa2", "--help").output.split())


def test_a_scene_section_repeating_the_defaults_is_not_named(tmp_path, raw_file):
    assert SMALL["pfa2"] == {"method": "two_step"}  # raw_file's scene
    res = run("pfa2", raw_file, "-o", tmp_path / "image.h5")
    assert res.exit_code == 0 and not _warnings(res.output, "not applied"), res.output


def test_two_step_writes_the_pslr_rise_its_track_predicts_with_units(tmp_path, raw_file):
    """pfa2 two-step's track_pslr_rise (dB) and what it is figured from, as attrs with units: at the bound's
    sub-images the rise is the track phase budget's, at eq. (7)'s on the issue's cross-track motion 0.6 dB."""
    import h5py

    from sarproc.focus.pfa.chain import antenna_positions, image_frame
    from sarproc.focus.pfa.polar import wavenumbers
    from sarproc.focus.pfa.two_step import pslr_rise_db, track_pslr_rise_db

    motion = {"cross_track_amplitude": "0.4 m", "cross_track_period": "0.7 s"}
    scene = dict(
        SMALL,
        targets={"frame": "ground_los", "points": [{"name": "C"}]},
        effects={**SMALL["effects"], "platform_motion": motion},
    )
    (tmp_path / "scene.yaml").write_text(yaml.safe_dump(scene))
    assert run("simulate", tmp_path / "scene.yaml", "-o", tmp_path / "raw.h5").exit_code == 0
    raw = read_product(tmp_path / "raw.h5")
    pos, origin = antenna_positions(raw), image_frame(raw).origin
    cfg = tmp_path / "c.yaml"
    eq7 = 97.72952064134462
    for name, section in (("bound", {}), ("eq7", {"subimage_size": f"{eq7} m"})):
        cfg.write_text(yaml.safe_dump({"pfa2": {"method": "two_step", **section}}))
        assert run("pfa2", tmp_path / "raw.h5", "-o", tmp_path / f"{name}.h5", "--config", cfg).exit_code == 0
        with h5py.File(tmp_path / f"{name}.h5") as f:
            units = json.loads(f["image"].attrs["attribute_units"])
        assert {k: units[k] for k in ("track_pslr_rise", "track_reference_range", "track_k_max")} == {
            "track_pslr_rise": "dB",
            "track_reference_range": "m",
            "track_k_max": "rad/m",
        }
        a = read_product(tmp_path / f"{name}.h5", load=False).attrs
        assert a["track_reference_range"] == pytest.approx(np.linalg.norm(pos[len(pos) // 2] - origin), rel=1e-9)
        k = wavenumbers(raw.radar.carrier_frequency, raw.radar.bandwidth / 2)
        assert a["track_k_max"] == pytest.approx(k, rel=1e-3)
        assert a["track_pslr_rise"] == track_pslr_rise_db(
            a["track_residual"], a["track_reference_range"], a["track_k_max"], a["subimage_core"]
        )
        if name == "bound":  # the sub-images are cut at the track's limit: the budget's rise
            assert a["subimage_core"] == a["track_core_limit"]
            assert a["track_pslr_rise"] == pytest.approx(pslr_rise_db(0.0126), rel=1e-9)
        else:  # docs/pfa.md, "Curved tracks": predicted <= 0.62 dB on the reduced scene
            assert a["subimage_core"] == eq7 and 0.55 < a["track_pslr_rise"] < 0.7
    # a straight track: no rise to speak of
    assert run("pfa2", raw_file, "-o", tmp_path / "straight.h5").exit_code == 0
    assert 0 <= read_product(tmp_path / "straight.h5", load=False).attrs["track_pslr_rise"] < 0.01


def test_simulate_writes_the_fixed_gate_samples_of_a_varied_gate_with_units(raw_file):
    """nie2016_small's range_gate: the raw product says how many samples per pulse a fixed gate would take
    (scripts/reproduce_002.py's saving), the same as simulating the scene without the gate would."""
    import h5py

    from sarproc.simulation.scene import scene_from_mapping
    from sarproc.simulation.simulate import plan_simulation

    raw = read_product(raw_file, load=False)
    with h5py.File(raw_file) as f:
        assert json.loads(f["signal"].attrs["attribute_units"])["fixed_gate_samples"] == "1"
    ungated = {k: v for k, v in SMALL.items() if k != "effects"}
    ungated["targets"] = {"frame": "ground_los", "points": [{"name": "C"}, {"name": "P", "azimuth": "20 m"}]}
    n_fixed = plan_simulation(scene_from_mapping(ungated)).shape[-1]
    assert raw.attrs["fixed_gate_samples"] == n_fixed > len(raw.coords["range_time"])


def test_pfa2_records_each_targets_distance_from_the_scene_centre(tmp_path, raw_file):
    """target_distance (m, ground plane, from the scene reference): C at the centre, P 20 m along azimuth;
    both methods (scripts/reproduce_002.py's distance column)."""
    cfg = tmp_path / "c.yaml"
    for method in ("plain", "two_step"):
        cfg.write_text(yaml.safe_dump({"pfa2": {"method": method}}))
        assert run("pfa2", raw_file, "-o", tmp_path / f"{method}.h5", "--config", cfg).exit_code == 0
        dist = read_product(tmp_path / f"{method}.h5", load=False).attrs["target_distance"]
        assert dist.keys() == {"C", "P"}
        assert dist["C"] == pytest.approx(0, abs=1e-6) and dist["P"] == pytest.approx(20, abs=1e-6)


# Session 41 new-user trial: a 45 deg squinted Ku-band spotlight at a steep depression (800 m over 1.2 km) turns
# its lines of sight' ground-range component by 2.3 % over the aperture, more than its 1.26 % fractional
# bandwidth: the first and last pulses' bands share no rectangle in the ground plane. Two-step PFA ended in
# "internal error: ValueError: two-step PFA: a sub-image centre has no inscribed polar support" (exit 1), plain
# PFA in a bare "supports do not overlap"; both now say why and what changes it, exit 2, no output.
# (the scene of tests/quality/test_ground_plane_ridges.py, whose backprojection evaluate measures)
NO_COMMON_SUPPORT = GROUND_PLANE_SCENE


@pytest.mark.parametrize("method", ["two_step", "plain"])
def test_supports_without_a_common_rectangle_are_refused_saying_why(tmp_path, method):
    scene = tmp_path / "scene.yaml"
    scene.write_text(yaml.safe_dump(NO_COMMON_SUPPORT))
    assert run("simulate", scene, "-o", tmp_path / "raw.h5").exit_code == 0
    config = tmp_path / "c.yaml"
    config.write_text(yaml.safe_dump({"pfa2": {"method": method}}))
    result = run("pfa2", tmp_path / "raw.h5", "-o", tmp_path / "img.h5", "--config", config)
    assert result.exit_code == 2, result.output
    assert "internal error" not in result.output
    assert "raw.h5: polar format: the pulses' polar supports share no rectangle" in result.output
    assert "2.27 % spread, wider than the 1.26 % fractional bandwidth" in result.output
    assert "radar.bandwidth" in result.output and "backproject" in result.output
    assert not (tmp_path / "img.h5").exists()
    # --dry-run checks everything: it refuses the same way from the header, before reading the data
    dry = run("pfa2", tmp_path / "raw.h5", "-o", tmp_path / "img.h5", "--config", config, "--dry-run")
    assert dry.exit_code == 2, dry.output
    assert "2.27 % spread, wider than the 1.26 % fractional bandwidth" in dry.output


# Session 41 new-user trial, scene 2 (docs/cli.md rows 2-2c): Ka-band, squint -35 deg, PRF 2 kHz; SW and E near the
# azimuth edges have their +-1 PRF aliases 129-131 m beyond the others
KA_ALIAS_SCENE = {
    "radar": {
        "carrier_frequency": "35 GHz",
        "bandwidth": "60 MHz",
        "pulse_duration": "4 us",
        "range_sampling_rate": "72 MHz",
        "prf": "2000 Hz",
    },
    "platform": {"velocity": "7 km/s", "altitude": "0 m"},
    "geometry": {"reference_range": "250 km", "squint": "-35 deg"},
    "acquisition": {"mode": "spotlight", "aperture_time": "0.05 s"},
    "targets": {
        "frame": "squint",
        "points": [
            {"name": "C"},
            {"name": "E", "azimuth": "100 m"},
            {"name": "SW", "azimuth": "-100 m", "range": "300 m", "amplitude": 0.5},
        ],
    },
    "pfa2": {},
}


def test_pfa2_warns_of_target_aliases_entering_from_beyond_its_azimuth_edges(tmp_path):
    """Session 41 new-user trial: Ka-band, squint -35 deg, PRF 2 kHz; SW and E near the azimuth edges have
    aliases just beyond the others. fine-focus and backproject warned of their side lobes entering the image and
    evaluate listed them (-45.6 and -48.8 dB in pfa2's image); pfa2 said nothing. It now warns and records them."""
    scene = KA_ALIAS_SCENE
    path = tmp_path / "scene.yaml"
    path.write_text(yaml.safe_dump(scene))
    assert run("simulate", path, "-o", tmp_path / "raw.h5").exit_code == 0
    res = run("pfa2", tmp_path / "raw.h5", "-o", tmp_path / "image.h5", "--config", path)
    assert res.exit_code == 0, res.output
    (line,) = _warnings(res.output, "pfa2: the PRF (2000 Hz) folds targets' echoes onto aliases")
    assert "target SW's alias (+1 PRF)" in line and "target E's alias (-1 PRF)" in line
    found = read_product(tmp_path / "image.h5").history[-1]["parameters"]["azimuth_edge_aliases"]
    assert {(a["target"], a["order"]) for a in found} == {("SW", 1), ("E", -1)}


def test_two_step_does_not_fold_aliases_beyond_the_edges_into_the_image(tmp_path):
    """Session 41 new-user trial, row 2c: the two-step's step-1 image repeated along azimuth at the data's own
    period plus a few pixels (442.4 m), so E's and SW's +-1 PRF aliases, 129-131 m beyond the image's edges (where
    evaluate and the warning place them), came back inside it at the opposite edges: points at E's and SW's ranges,
    azimuth +-152 m, -42.4 and -48.6 dB against N, listed by evaluate as false targets (plain PFA and backprojection
    of the same raw have none there). Step 1 now repeats at the data's period plus its grid's extent."""
    path = tmp_path / "scene.yaml"
    path.write_text(yaml.safe_dump(KA_ALIAS_SCENE))
    assert run("simulate", path, "-o", tmp_path / "raw.h5").exit_code == 0
    res = run("pfa2", tmp_path / "raw.h5", "-o", tmp_path / "image.h5", "--config", path)
    assert res.exit_code == 0, res.output
    assert run("evaluate", tmp_path / "image.h5", "-o", tmp_path / "r.json").exit_code == 0
    report = json.loads((tmp_path / "r.json").read_text())
    assert report["false_targets"]["entries"] == []
    assert report["false_target"]["level_db"] < -45.0
