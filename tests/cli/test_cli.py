"""The command line: exit codes, messages naming file and key, atomic outputs."""

import hashlib
import subprocess
import sys

import h5py
import numpy as np
import pytest
import yaml
from click.testing import CliRunner

from sarproc.cli.main import COMMANDS, cli

SCENE = {
    "radar": {
        "carrier_frequency": "10 GHz",
        "bandwidth": "100 MHz",
        "pulse_duration": "1 us",
        "range_sampling_rate": "120 MHz",
        "prf": "400 Hz",
    },
    "platform": {"velocity": "100 m/s", "altitude": "0 m"},
    "geometry": {"reference_range": "2 km", "squint": "10 deg"},
    "acquisition": {"mode": "spotlight", "aperture_time": "0.3 s"},
    "targets": {"frame": "squint", "points": [{"name": "A"}, {"name": "B", "range": "20 m", "azimuth": "5 m"}]},
    "backproject": {"azimuth_extent": "30 m", "range_extent": "40 m"},
}


def run(*args):
    return CliRunner().invoke(cli, [str(a) for a in args], catch_exceptions=False)


def write_scene(path, scene=SCENE):
    path.write_text(yaml.safe_dump(scene))
    return path


def digest(path):
    return hashlib.sha256(path.read_bytes()).hexdigest()


@pytest.fixture
def raw_file(tmp_path):
    scene = write_scene(tmp_path / "scene.yaml")
    res = run("simulate", scene, "-o", tmp_path / "raw.h5")
    assert res.exit_code == 0, res.output
    return tmp_path / "raw.h5"


def test_help_and_version():
    res = run("--help")
    assert res.exit_code == 0 and "simulate" in res.output and "backproject" in res.output
    assert run("--version").output.strip().startswith("sarproc, version")
    for name in cli.list_commands(None):
        assert name in COMMANDS
        assert run(name, "--help").exit_code == 0


def test_simulate_backproject_chain(tmp_path, raw_file):
    scene = tmp_path / "scene.yaml"
    res = run("backproject", raw_file, "--config", scene, "-o", tmp_path / "img.h5")
    assert res.exit_code == 0, res.output
    assert "backproject:" in res.output
    with h5py.File(tmp_path / "img.h5") as f:
        assert f.attrs["product"] == "image"
        hist = [h["command"] for h in __import__("json").loads(f.attrs["history"])]
        assert hist[0].startswith("sarproc simulate") and hist[1].startswith("sarproc backproject")
        assert f["image"].shape == (len(f["azimuth"]), len(f["range"]))


def test_backproject_summary_names_the_frame_asked_for(tmp_path, raw_file):
    """Session 41 new-user trial, row 1: `frame: zero_doppler` was summed as "image in frame squint" (it is a squint
    frame at 0 deg); the summary names what the user asked for, then what it is."""
    scene = write_scene(
        tmp_path / "zd.yaml", dict(SCENE, backproject={**SCENE["backproject"], "frame": "zero_doppler"})
    )
    res = run("backproject", raw_file, "--config", scene, "-o", tmp_path / "img.h5")
    assert res.exit_code == 0, res.output
    assert "image in frame zero_doppler (a squint frame at 0 deg) -> " in res.output
    res = run("backproject", raw_file, "--config", tmp_path / "scene.yaml", "-o", tmp_path / "sq.h5")
    assert "image in frame squint -> " in res.output  # the frame asked for, said once


def test_real_subprocess_runs(tmp_path):
    scene = write_scene(tmp_path / "scene.yaml")
    out = subprocess.run(
        [sys.executable, "-m", "sarproc", "simulate", str(scene), "-o", str(tmp_path / "r.h5")],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert out.returncode == 0, out.stderr
    out = subprocess.run(
        [
            sys.executable,
            "-m",
            "sarproc",
            "backproject",
            str(tmp_path / "r.h5"),
            "--config",
            str(scene),
            "-o",
            str(tmp_path / "i.h5"),
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert out.returncode == 0, out.stderr
    bad = subprocess.run(
        [sys.executable, "-m", "sarproc", "backproject", str(tmp_path / "nope.h5"), "-o", str(tmp_path / "x.h5")],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert bad.returncode == 2 and "nope.h5: file not found" in bad.stderr


def test_bad_inputs_exit_2_with_named_cause(tmp_path, raw_file):
    (tmp_path / "text.h5").write_text("hello")
    cases = [
        (("backproject", tmp_path / "missing.h5", "-o", tmp_path / "o.h5"), "missing.h5: file not found"),
        (("backproject", tmp_path / "text.h5", "-o", tmp_path / "o.h5"), "text.h5: not an HDF5 file"),
        (("simulate", tmp_path / "none.yaml", "-o", tmp_path / "o.h5"), "none.yaml: file not found"),
        (("backproject", raw_file, "-o", raw_file, "--overwrite"), "output is the input file"),
        (("simulate", tmp_path / "scene.yaml", "-o", raw_file), "output exists; pass --overwrite"),
    ]
    for args, message in cases:
        res = run(*args)
        assert res.exit_code == 2, (args, res.output)
        assert message in res.output, (args, res.output)


@pytest.mark.parametrize(
    "change,message",
    [
        ({"radar": {**SCENE["radar"], "bandwidth": "10 m"}}, "radar.bandwidth: unit 'm' is not a frequency unit"),
        ({"radar": {**SCENE["radar"], "range_sampling_rate": "50 MHz"}}, "is below the bandwidth"),
        ({"radar": {**SCENE["radar"], "bandwidth": "-1 MHz"}}, "radar.bandwidth: '-1 MHz' is out of range"),
        ({"platform": {"velocity": "100 m/s", "hight": "1 m"}}, "platform: unknown key(s) 'hight'"),
        ({"geometry": {"squint": "10 deg"}}, "geometry.reference_range: required key is missing"),
    ],
)
def test_bad_scene_yaml_exit_2(tmp_path, change, message):
    scene = write_scene(tmp_path / "bad.yaml", {**SCENE, **change})
    res = run("simulate", scene, "-o", tmp_path / "o.h5")
    assert res.exit_code == 2 and message in res.output, res.output
    assert "scene" not in res.output or "bad.yaml" in res.output
    assert not (tmp_path / "o.h5").exists()


def test_bad_stage_config_names_key(tmp_path, raw_file):
    cfg = tmp_path / "cfg.yaml"
    cfg.write_text(yaml.safe_dump({"backproject": {"upsample": 0}}))
    res = run("backproject", raw_file, "--config", cfg, "-o", tmp_path / "o.h5")
    assert res.exit_code == 2 and "cfg.yaml: backproject.upsample: 0 is out of range" in res.output


def test_wrong_product_type_and_nan_exit_2(tmp_path, raw_file):
    scene = tmp_path / "scene.yaml"
    assert run("backproject", raw_file, "--config", scene, "-o", tmp_path / "img.h5").exit_code == 0
    res = run("backproject", tmp_path / "img.h5", "-o", tmp_path / "o.h5")
    assert res.exit_code == 2 and "product type is 'image'; this stage needs 'raw'" in res.output
    with h5py.File(raw_file, "a") as f:
        f["signal"][3, 4] = np.nan
    res = run("backproject", raw_file, "-o", tmp_path / "o2.h5")
    assert res.exit_code == 2 and "dataset 'signal' contains 1 NaN" in res.output
    with h5py.File(raw_file, "a") as f:
        del f["radar"].attrs["bandwidth"]
    res = run("backproject", raw_file, "-o", tmp_path / "o3.h5")
    assert res.exit_code == 2 and "radar: missing attribute 'bandwidth'" in res.output


def test_interrupted_run_leaves_nothing_and_input_unchanged(tmp_path, raw_file, monkeypatch):
    import sarproc.focus.backprojection as bp

    before = digest(raw_file)

    def boom(*a, **k):
        raise KeyboardInterrupt

    monkeypatch.setattr(bp, "backproject_points", boom)
    res = CliRunner().invoke(cli, ["backproject", str(raw_file), "-o", str(tmp_path / "img.h5")])
    assert res.exit_code != 0
    assert not (tmp_path / "img.h5").exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["raw.h5", "scene.yaml"]
    assert digest(raw_file) == before


def test_simulate_failure_midway_leaves_no_file(tmp_path, monkeypatch):
    import sarproc.simulation.simulate as sim

    scene = write_scene(tmp_path / "scene.yaml", {**SCENE, "simulation": {"block_pulses": 16}})
    calls = {"n": 0}
    real = sim.echo_block

    def flaky(*a, **k):
        calls["n"] += 1
        if calls["n"] == 3:
            raise MemoryError
        return real(*a, **k)

    monkeypatch.setattr(sim, "echo_block", flaky)
    res = run("simulate", scene, "-o", tmp_path / "raw.h5")
    assert res.exit_code == 1 and "out of memory" in res.output
    assert sorted(p.name for p in tmp_path.iterdir()) == ["scene.yaml"]
