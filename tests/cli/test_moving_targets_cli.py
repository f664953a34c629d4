"""Moving targets through the command line alone (issue 19, items 3): backproject's default grid covers
where movers appear, evaluate measures them there and reports velocity and relocation errors, for
multichannel (reconstruct) and single-channel scenes; evaluate --targets measures a subset.

Reduced scene: configs/xu_small.yaml with A static, B (v_r 10 m/s) and C (v_r 10, v_a 10 m/s), placed
like xu_scene.yaml's (each in its own window after the walk correction: 0, +273, -279 m) but inside the
shorter aperture, so their illumination is not cut by the data window.
"""

from __future__ import annotations

import json
from pathlib import Path

import h5py
import pytest
import yaml
from click.testing import CliRunner

from sarproc.cli.main import cli

CONFIG = Path(__file__).resolve().parents[2] / "configs" / "xu_small.yaml"
EXPECT = {
    "irw_ratio_min": 0.95,
    "irw_ratio_max": 1.05,
    "pslr_db": [-13.76, -12.76],
    "islr_db": [-10.66, -9.66],
    "position_cells_max": 0.1,
    "false_target_db_max": -30,
    "v_r_error_max": 0.1,
    "v_a_error_max": 0.2,
}


def run(*args):
    r = CliRunner().invoke(cli, [str(a) for a in args])
    return r


def scene_file(tmp_path, points, single_channel=False) -> Path:
    m = yaml.safe_load(CONFIG.read_text())
    m["targets"]["points"] = points
    m["effects"]["target_motion"] = {}
    if single_channel:
        m["effects"].pop("azimuth_channels")
        m["radar"]["prf"] = "3000 Hz"
        m["acquisition"]["aperture_time"] = "0.4 s"
    path = tmp_path / "scene.yaml"
    path.write_text(yaml.safe_dump(m))
    return path


@pytest.fixture(scope="module")
def chain(tmp_path_factory):
    """simulate -> reconstruct -> backproject of A, B, C."""
    d = tmp_path_factory.mktemp("movers")
    cfg = scene_file(
        d,
        [
            {"name": "A"},
            {"name": "B", "azimuth": "300 m", "range": "170 m", "velocity": ["0 m/s", "10 m/s", "0 m/s"]},
            {"name": "C", "azimuth": "500 m", "range": "-450 m", "velocity": ["10 m/s", "10 m/s", "0 m/s"]},
        ],
    )
    for args in (
        ["simulate", cfg, "-o", d / "raw_mc.h5"],
        ["reconstruct", d / "raw_mc.h5", "-o", d / "raw.h5", "--config", cfg],
        ["backproject", d / "raw.h5", "-o", d / "image.h5", "--config", cfg],
    ):
        r = run(*args, "--no-progress")
        assert r.exit_code == 0, r.output
    return d, cfg


def test_default_grid_covers_where_movers_appear_not_where_they_are(chain):
    d, _ = chain
    with h5py.File(d / "image.h5") as f:
        az = f["azimuth"][()]
        names = [n.decode() for n in f["targets"]["name"]]
        true_az = f["targets"]["azimuth"][names.index("B")]
    assert not az[0] <= true_az <= az[-1]  # B's true position (300 m) holds no response, and is off the grid
    assert az[0] < -540 and az[-1] > 0  # B appears near -551 m, C near -661 m, A at 0
    assert az[0] < -650


def test_the_plan_sizes_the_grid_the_run_writes(chain, tmp_path):
    """--dry-run's pixels are those of the image written: moving targets where they appear (the plan sized the
    targets table's true positions before: 3.6x too few pixels on xu_traffic), and a --targets subset."""
    d, cfg = chain
    with h5py.File(d / "image.h5") as f:
        shape = f["image"].shape
    res = run("backproject", d / "raw.h5", "-o", tmp_path / "x.h5", "--config", cfg, "--dry-run")
    assert res.exit_code == 0, res.output
    assert f"~{shape[0]} x {shape[1]} pixels" in res.output
    sub = run("backproject", d / "raw.h5", "-o", tmp_path / "b.h5", "--config", cfg, "--targets", "B", "--no-progress")
    assert sub.exit_code == 0, sub.output
    with h5py.File(tmp_path / "b.h5") as f:
        b_shape = f["image"].shape
    assert b_shape[0] < shape[0]
    res = run("backproject", d / "raw.h5", "-o", tmp_path / "y.h5", "--config", cfg, "--targets", "B", "--dry-run")
    assert f"~{b_shape[0]} x {b_shape[1]} pixels" in res.output


def test_evaluate_measures_movers_where_they_appear_with_velocity_and_relocation_errors(chain, tmp_path):
    d, cfg = chain
    expect = tmp_path / "expect.yaml"
    expect.write_text(yaml.safe_dump(EXPECT))
    r = run("evaluate", d / "image.h5", "--config", cfg, "--expect", expect, "-o", tmp_path / "r.json")
    assert r.exit_code == 0, r.output
    assert "Moving targets" in r.output
    rep = json.loads((tmp_path / "r.json").read_text())
    movers = {m["name"]: m for m in rep["movers"]}
    assert set(movers) == {"B", "C"}
    for name, v_a in (("B", 0.0), ("C", 10.0)):
        m = movers[name]
        assert m["v_r"] == pytest.approx(10.0) and m["v_a"] == pytest.approx(v_a)
        assert m["estimate"] == "moving_targets" and m["relocation"] == "table"  # reconstruct's aux table
        assert m["shift"] > 800  # measured hundreds of metres from the truth
        assert abs(m["v_r_error"]) < 0.1
        # relocation: the table's relocated position lies where the velocity error says (first order),
        # within two metres (its apparent position is reconstruct's, not the measured peak)
        assert m["relocation_error"] == pytest.approx(m["relocation_error_from_velocity"], abs=2.0)
        assert m["relocation_error"] < 10.0
    # a relocation bound tighter than the velocity error allows fails, naming the mover
    expect.write_text(yaml.safe_dump({**EXPECT, "relocation_error_max": 1e-3}))
    r = run("evaluate", d / "image.h5", "--config", cfg, "--expect", expect)
    assert r.exit_code == 1 and "moving target B: relocation_error" in r.output


def test_evaluate_targets_subset(chain, tmp_path):
    d, cfg = chain
    r = run("evaluate", d / "image.h5", "--config", cfg, "--targets", "C", "-o", tmp_path / "c.json")
    assert r.exit_code == 0, r.output
    rep = json.loads((tmp_path / "c.json").read_text())
    assert [t["name"] for t in rep["targets"]] == ["C"] and [m["name"] for m in rep["movers"]] == ["C"]
    # A and B are not measured, and are no false targets either
    assert rep["false_target"] is None or rep["false_target"]["level_db"] < -30
    r = run("evaluate", d / "image.h5", "--targets", "C,Z")
    assert r.exit_code == 2 and "'Z'" in r.output and "A, B, C" in r.output


def test_single_channel_mover_is_measured_where_it_appears(tmp_path):
    """The issue's case: one channel, a target moving 5 m/s across track (PSLR +7.4 dB at its true position)."""
    cfg = scene_file(tmp_path, [{"name": "T", "velocity": ["0 m/s", "5 m/s", "0 m/s"]}], single_channel=True)
    for args in (
        ["simulate", cfg, "-o", tmp_path / "raw.h5"],
        ["backproject", tmp_path / "raw.h5", "-o", tmp_path / "image.h5"],
    ):
        r = run(*args, "--no-progress")
        assert r.exit_code == 0, r.output
    expect = tmp_path / "expect.yaml"
    expect.write_text(yaml.safe_dump({k: v for k, v in EXPECT.items() if not k.startswith("v_")}))
    r = run("evaluate", tmp_path / "image.h5", "--expect", expect, "-o", tmp_path / "r.json")
    assert r.exit_code == 0, r.output
    rep = json.loads((tmp_path / "r.json").read_text())
    (m,) = rep["movers"]
    assert m["estimate"] == "none" and m["v_r_error"] is None and m["relocation_error"] is None
    assert m["shift"] > 350
    # asking for a velocity check on a product without estimates fails, saying why
    expect.write_text(yaml.safe_dump(EXPECT))
    r = run("evaluate", tmp_path / "image.h5", "--expect", expect)
    assert r.exit_code == 1 and "holds no estimate" in r.output


def test_a_moving_targets_table_is_used_first_and_matched_by_name_or_position(chain):
    """The detector's table (issue 19 item 2) when the product holds one: its velocities and relocated
    positions are judged against the truth; a row without a truth name is matched by where it appears."""
    from sarproc.product.io import read_product
    from sarproc.quality.metrics import evaluate_product

    d, _ = chain
    image = read_product(d / "image.h5")
    assert len(image.aux["moving_targets"]) == 2  # reconstruct's own table, carried by backproject
    image.aux.pop("moving_targets")  # the mapping form below stands in for it
    base = {m.name: m for m in evaluate_product(image).movers}
    b, c = base["B"], base["C"]
    image.attrs["moving_targets"] = [
        {
            "id": 0,
            "v_r": 10.05,
            "v_a": 0.0,
            "truth": "B",
            **{f"relocated_{k}": v + 2.0 for k, v in zip("xyz", b.true_position)},
        },
        {
            "id": 1,
            "v_r": 9.9,
            "v_a": 10.2,
            "truth": "",
            **{f"apparent_{k}": v + 0.5 for k, v in zip("xyz", c.apparent_position)},
        },
    ]
    movers = {m.name: m for m in evaluate_product(image).movers}
    assert movers["B"].estimate == "moving_targets" and movers["B"].relocation == "table"
    assert movers["B"].v_r_error == pytest.approx(0.05) and movers["B"].relocation_error == pytest.approx(2 * 3**0.5)
    assert movers["C"].v_r_error == pytest.approx(-0.1) and movers["C"].v_a_error == pytest.approx(0.2)
    assert movers["C"].relocation == "measured peak + estimated velocity"
    # -0.1 m/s of v_los from v_r and +0.2 * sin(20 deg) from v_a nearly cancel: a small relocation error
    assert movers["C"].relocation_error == pytest.approx(movers["C"].relocation_error_from_velocity, abs=1.0)


def test_relocation_error_bound_and_verdict_in_reconstruct_and_evaluate(chain, tmp_path):
    """A found mover's relocation against the truth (issue 19; scripts/traffic_003.py computed the error itself
    and judged it against evaluate's first-order figure + 2 m): reconstruct's truth.relocation and evaluate's
    moving-target entries give |relocated - truth|, the apparent position's error |apparent - S|, the velocity
    error's own relocation error (S relocated with the estimated velocity), the bound and the verdict."""
    import numpy as np

    from sarproc.product import moving
    from sarproc.product.io import read_product
    from sarproc.product.model import moving_target_rows
    from sarproc.quality.metrics import evaluate_product

    d, cfg = chain
    raw = read_product(d / "raw.h5", load=False)
    checks = {c["name"]: c for c in raw.attrs["reconstruct"]["truth"]["relocation"]}
    assert set(checks) == {"B", "C"}
    rows = moving_target_rows(raw.aux)
    times, centres = moving.pulse_times(raw), moving.phase_centres(raw)
    for name, c in checks.items():
        k = [n.decode() for n in raw.targets["name"]].index(name)
        r = rows[c["row"]]
        assert int(r["truth_index"]) == k
        truth = np.array([raw.targets[a][k] for a in "xyz"], float)
        vel = np.array([raw.targets[f"v{a}"][k] for a in "xyz"], float)
        s, _ = moving.apparent_position(raw.radar, times, truth, vel, centres)
        relocated = np.array([r[f"relocated_{a}"] for a in "xyz"])
        apparent = np.array([r[f"apparent_{a}"] for a in "xyz"])
        assert c["relocation_error"] == pytest.approx(np.linalg.norm(relocated - truth), rel=1e-12)
        assert c["apparent_position_error"] == pytest.approx(np.linalg.norm(apparent - s), abs=1e-6)
        at_s = moving.relocate(raw.radar, times, s, moving.scene_velocity(s, r["v_a"], r["v_r"], 0.0), centres)
        assert c["velocity_relocation_error"] == pytest.approx(np.linalg.norm(at_s - truth), abs=1e-6)
        speed = np.hypot(r["v_a"], r["v_r"])
        expected = c["velocity_relocation_error"] + c["apparent_position_error"] * (1 + speed / raw.radar.velocity)
        assert c["relocation_bound"] == pytest.approx(expected + 2 * moving.RELOCATE_TOLERANCE, rel=1e-12)
        assert c["relocation_within_bound"] is True
        # the velocity term is what the velocity error implies (first order, evaluate's figure) within a few %
        assert 1.0 < c["velocity_relocation_error"] < 5.0
    r = run("evaluate", d / "image.h5", "--config", cfg, "-o", tmp_path / "r.json")
    assert r.exit_code == 0, r.output
    for m in json.loads((tmp_path / "r.json").read_text())["movers"]:
        c = checks[m["name"]]
        for key in ("relocation_error", "apparent_position_error", "velocity_relocation_error", "relocation_bound"):
            assert m[key] == pytest.approx(c[key], abs=1e-6), key
        assert m["relocation_within_bound"] is True
        assert m["velocity_relocation_error"] == pytest.approx(m["relocation_error_from_velocity"], rel=0.05)
    # a relocated position 5 m off the table's, not explained by its velocity or apparent position: outside
    image = read_product(d / "image.h5")
    image.aux.pop("moving_targets")
    table = [dict(r, truth="B" if int(r["truth_index"]) == 1 else "C") for r in rows]
    table[checks["B"]["row"]]["relocated_y"] += 5.0
    image.attrs["moving_targets"] = table
    movers = {m.name: m for m in evaluate_product(image).movers}
    assert movers["B"].relocation_error > movers["B"].relocation_bound and movers["B"].relocation_within_bound is False
    assert movers["C"].relocation_within_bound is True
