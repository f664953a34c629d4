"""CPHD in and out, SICD out through sarkit: round trips exact, sarkit's consistency checkers satisfied."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import yaml

sarkit = pytest.importorskip("sarkit", reason="CPHD/SICD need NGA's sarkit: pip install 'sarproc[formats]'")

from sarproc.focus.backprojection import BackprojectParams, backproject  # noqa: E402
from sarproc.formats.cphd import check_cphd, read_cphd, write_cphd  # noqa: E402
from sarproc.formats.geolocation import (  # noqa: E402
    GeolocationParams,
    ecf_to_geodetic,
    geodetic_to_ecf,
    placement,
)
from sarproc.formats.sicd import (  # noqa: E402
    check_sicd,
    image_from_sicd,
    local_support_offsets,
    read_sicd,
    sarpy_check,
    sicd_pixels,
    write_sicd,
)
from sarproc.product.config import build, load_yaml  # noqa: E402
from sarproc.product.errors import InputError  # noqa: E402
from sarproc.simulation.scene import scene_from_mapping  # noqa: E402
from sarproc.simulation.simulate import simulate  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
# somewhere real: 45 deg N, 7 deg E, 300 m, flying north-east
GEO = {
    "time": "2024-05-01T10:00:00Z",
    "latitude": "45 deg",
    "longitude": "7 deg",
    "height": "300 m",
    "heading": "45 deg",
}


def db(x):
    return 20 * math.log10(max(float(x), 1e-300))


@pytest.fixture(scope="module")
def demo():
    """The demo scene (configs/demo.yaml): raw product, its backprojected image and the stage parameters."""
    mapping = load_yaml(ROOT / "configs" / "demo.yaml")
    params = build(BackprojectParams, mapping.get("backproject"), "demo.yaml", "backproject")
    raw = simulate(scene_from_mapping(mapping, "demo.yaml"))
    return raw, backproject(raw, params), params


@pytest.fixture(scope="module")
def place(demo):
    return placement(demo[0].radar, build(GeolocationParams, GEO, "test", "geolocation"))


def test_geodetic_round_trip_and_placement_is_rigid(demo, place):
    for lat, lon, h in (
        (0.0, 0.0, 0.0),
        (math.radians(45), math.radians(7), 300.0),
        (math.radians(-89.9), math.radians(-179), 8000.0),
    ):
        back = ecf_to_geodetic(geodetic_to_ecf(lat, lon, h))
        assert np.allclose(back, (lat, lon, h), atol=1e-9)
    assert np.allclose(ecf_to_geodetic(place.origin_ecf), place.lat_lon_height, atol=1e-9)
    pos = demo[0].aux["platform_position"]
    ecf = place.to_ecf(pos)
    # distances and the scene frame survive the map (round trip to a nanometre)
    assert np.allclose(
        np.linalg.norm(np.diff(ecf, axis=0), axis=1), np.linalg.norm(np.diff(pos, axis=0), axis=1), rtol=1e-12
    )
    assert np.abs(place.from_ecf(ecf) - pos).max() < 1e-6
    # +x flies at the heading: 45 deg from north towards east
    from sarproc.formats.geolocation import enu_axes

    east, north, up = enu_axes(*place.lat_lon_height[:2])
    x = place.rotation[:, 0]
    assert math.degrees(math.atan2(x @ east, x @ north)) == pytest.approx(45.0, abs=1e-9)


def test_cphd_round_trip_focuses_identically(demo, place, tmp_path):
    raw, image, params = demo
    path = tmp_path / "raw.cphd"
    write_cphd(path, raw, place)
    result = check_cphd(path)
    assert result["passed"] and result["errors"] == [] and result["warnings"] == [], result["report"]
    back = read_cphd(path)
    assert back.data.shape == raw.data.shape and back.radar == raw.radar
    assert np.array_equal(back.targets, raw.targets) and back.attrs["frame"] == raw.attrs["frame"]
    assert np.abs(back.aux["platform_position"] - raw.aux["platform_position"]).max() < 1e-6
    assert db(np.abs(back.data - raw.data).max() / np.abs(raw.data).max()) < -120
    refocused = backproject(back, params)
    assert db(np.abs(refocused.data - image.data).max() / np.abs(image.data).max()) < -100


def test_checks_are_sarkits_own_with_arrays_summarised_in_messages(demo, place, tmp_path):
    """run_checks runs every check of sarkit's checker with the same outcome; only the values its messages
    print are summarised (the "Skip" records of preconditions formatted 600-record PVP arrays in full)."""
    from sarproc.formats.sicd import consistency_checker, consistency_summary, run_checks

    path = tmp_path / "raw.cphd"
    write_cphd(path, demo[0], place)
    with open(path, "rb") as fh:
        full = consistency_checker("CPHD").from_file(fh, thorough=True)
        full.check()
        lean = consistency_checker("CPHD").from_file(fh, thorough=True)
        run_checks(lean)
    assert consistency_summary(lean) == consistency_summary(full)  # report text included
    for kind in ("passes", "failures", "skips"):
        assert getattr(lean, kind)().keys() == getattr(full, kind)().keys(), kind
    details = [
        [(d["severity"], d["passed"], d["details"], d["message"]) for r in con.all().values() for d in r["details"]]
        for con in (full, lean)
    ]
    assert [d[:3] for d in details[0]] == [d[:3] for d in details[1]]
    assert [d[3].split("\n")[0] for d in details[0]] == [d[3].split("\n")[0] for d in details[1]]
    size = [sum(len(d[3]) for d in x) for x in details]
    assert size[1] < size[0] / 20, size  # demo CPHD: 1.84 MB of message text -> 41 kB
    assert any("..." in d[3] and "..." not in f[3] for f, d in zip(*details))


def test_cphd_of_another_program_is_imported_from_its_standard_fields(demo, place, tmp_path):
    """Without sarproc's parameters the file is read as SRP-compensated phase history (gotcha.py's model):
    the scene centre becomes the origin, and the response on a 3 x 3 cell patch around every target
    matches the original's to -40 dB (measured -50 dB: the comparator's linear interpolation on two
    different sample grids, -75 dB at 32 x upsampling; tests/formats/test_cphd_import.py)."""
    from sarproc.dsp.rangecomp import range_compress
    from sarproc.focus.backprojection import backproject_points

    raw = demo[0]
    write_cphd(tmp_path / "other.cphd", raw, place, sarproc_metadata=False)
    other = read_cphd(tmp_path / "other.cphd")
    assert other.kind == "raw" and len(other.targets) == 0
    assert other.radar.bandwidth == pytest.approx(raw.radar.bandwidth, rel=0.01)
    cell = 0.3
    offsets = np.stack(np.meshgrid([-cell, 0, cell], [-cell, 0, cell], [0.0]), -1).reshape(-1, 3)
    pts = np.concatenate([[t["x"], t["y"], t["z"]] + offsets for t in raw.targets])

    def focus(p, points):
        rc = range_compress(p.data, p.radar)
        pos = p.aux["platform_position"]
        return backproject_points(
            rc,
            p.coords["range_time"],
            pos,
            pos,
            points,
            p.radar.carrier_frequency,
            gate_offset=p.aux.get("range_gate_offset"),
        )

    a = focus(raw, pts)
    b = focus(other, place.from_ecf(place.to_ecf(pts)) - np.asarray(raw.radar.scene_center))
    assert db(np.abs(a - b).max() / np.abs(a).max()) < -40  # measured -50.6 dB


def test_cphd_signal_is_the_compensated_phase_history(scene_mapping, tmp_path):
    """FX domain, compensated to the SRP: a scatterer there has one phase at every frequency of every
    vector; one 3 m further in range has a phase ramp of -2 pi f dTOA, dTOA = 2 x 3 m / c."""
    import sarkit.cphd as skcphd

    from sarproc.product.metadata import C

    points = [{"name": "SRP", "azimuth": "0 m", "range": "0 m", "phase": "40 deg"}]
    raw = simulate(
        scene_from_mapping(scene_mapping(targets={"frame": "squint", "origin": "scene_center", "points": points}), "t")
    )
    raw_far = simulate(
        scene_from_mapping(
            scene_mapping(
                targets={"frame": "squint", "origin": "scene_center", "points": [{**points[0], "range": "3 m"}]}
            ),
            "t",
        )
    )
    place = placement(raw.radar, build(GeolocationParams, GEO, "test", "geolocation"))
    phases = []
    for product, name in ((raw, "a.cphd"), (raw_far, "b.cphd")):
        write_cphd(tmp_path / name, product, place)
        with open(tmp_path / name, "rb") as fh, skcphd.Reader(fh) as reader:
            fx, pvps = reader.read_channel("sarproc-channel-1")
        f = pvps["SC0"][0] + pvps["SCSS"][0] * np.arange(fx.shape[1])
        band = np.abs(f - pvps["FX1"][0] / 2 - pvps["FX2"][0] / 2) < 0.4 * (pvps["FX2"][0] - pvps["FX1"][0])
        phases.append(np.unwrap(np.angle(fx[:, band]), axis=1))
    flat = phases[0] - 2 * np.pi * np.round((phases[0] - math.radians(40)) / (2 * np.pi))
    # the SRP's range migration (tens of cycles over the aperture) is compensated vector by vector: every
    # vector holds the target's own phase, up to the ripple of a sampled finite chirp (TBP 100)
    assert np.abs(flat.mean(axis=1) - math.radians(40)).max() < 0.01
    assert np.abs(flat - math.radians(40)).max() < 0.15
    slope = np.polyfit(f[band], (phases[1] - phases[0]).mean(axis=0), 1)[0]  # rad / Hz
    assert slope == pytest.approx(-2 * np.pi * 2 * 3.0 / C, rel=0.02)
    assert np.all(pvps["RcvTime"] > pvps["TxTime"])


def test_sicd_of_the_demo_image_passes_checks_and_reopens(demo, place, tmp_path):
    import sarkit.sicd as sksicd

    raw, image, _ = demo
    path = tmp_path / "image.nitf"
    grid = write_sicd(path, image, place)
    result = check_sicd(path)
    assert result["passed"] and result["errors"] == [], result["report"]
    # the demo image has 2.5 pixels per IRW: sampling finer than SICD's recommended 1.1-2.2 is its only remark
    assert set(result["warnings"]) <= {"check_iprbw_to_ss_osr_row", "check_iprbw_to_ss_osr_col"}
    tree, pixels = read_sicd(path)
    assert pixels.shape == (image.data.shape[1], image.data.shape[0])
    # what was written is read back bit for bit; the product is that times the SCP's carrier (complex64 rounding)
    assert np.array_equal(pixels, sicd_pixels(image.data, grid))
    assert np.abs(image_from_sicd(pixels, grid) - image.data).max() < 1e-6 * np.abs(image.data).max()
    # geometry: each target's pixel, projected by SICD's own R/Rdot model, lands on the target
    az, rg = image.coords["azimuth"], image.coords["range"]
    for t in image.targets:
        i = (t["azimuth"] - az[0]) / (az[1] - az[0])
        j = (t["range"] - rg[0]) / (rg[1] - rg[0])
        col = len(az) - 1 - i if grid.flip_cols else i
        truth = place.to_ecf(np.array([t["x"], t["y"], t["z"]]))
        hae = ecf_to_geodetic(truth)[2]
        xy = sksicd.rowcol_to_xrowycol(tree, np.array([[j, col]]))
        spot, _, ok = sksicd.image_to_constant_hae_surface(tree, xy, hae, delta_hae_max=1e-4)
        assert ok and np.linalg.norm(spot[0] - truth) < 0.02


def _target_pixels(image, grid):
    """SICD (row, col) of each target's truth."""
    az, rg = image.coords["azimuth"], image.coords["range"]
    i = np.round((image.targets["azimuth"] - az[0]) / (az[1] - az[0])).astype(int)
    j = np.round((image.targets["range"] - rg[0]) / (rg[1] - rg[0])).astype(int)
    return np.column_stack([j, len(az) - 1 - i if grid.flip_cols else i])


def test_sicd_spatial_frequency_is_the_geometry_and_describes_the_pixels(demo, place, tmp_path):
    import numpy.polynomial.polynomial as npp
    import sarkit.sicd as sksicd

    raw, image, _ = demo
    path = tmp_path / "image.nitf"
    grid = write_sicd(path, image, place)
    tree, pixels = read_sicd(path)
    xml = sksicd.XmlHelper(tree)
    # spotlight: one centre of aperture (the aperture centre) for every pixel, a scalar TimeCOAPoly
    time_coa = xml.load("./{*}Grid/{*}TimeCOAPoly")
    assert time_coa.shape == (1, 1)
    assert time_coa[0, 0] == pytest.approx(xml.load("./{*}Timeline/{*}CollectDuration") / 2, abs=2 / image.radar.prf)
    # KCtr is the centre of support at the SCP: (2 f_c / c) u_los . u_axis at the centre of aperture,
    # recomputed here from the file's own ARPPoly and SCP; DeltaKCOAPoly is 0 there
    scp = xml.load("./{*}GeoData/{*}SCP/{*}ECF")
    los = scp - npp.polyval(time_coa[0, 0], xml.load("./{*}Position/{*}ARPPoly"))
    los /= np.linalg.norm(los)
    bw = {}
    for axis in ("Row", "Col"):
        u = xml.load(f"./{{*}}Grid/{{*}}{axis}/{{*}}UVectECF")
        k = 2 * image.radar.carrier_frequency / 299792458.0 * float(los @ u)
        bw[axis] = xml.load(f"./{{*}}Grid/{{*}}{axis}/{{*}}ImpRespBW")
        assert xml.load(f"./{{*}}Grid/{{*}}{axis}/{{*}}KCtr") == pytest.approx(k, abs=1e-6 * bw[axis])
        assert abs(npp.polyval2d(0.0, 0.0, xml.load(f"./{{*}}Grid/{{*}}{axis}/{{*}}DeltaKCOAPoly"))) < 1e-6 * bw[axis]
    # the pixels' local spectrum about every target is centred where DeltaKCOAPoly says (measured 0.7 %
    # of the bandwidth at worst); the old constant (the image's power-weighted mean) was 5.6 % off at the
    # SCP and 38 % at target E, 50 m across the line of sight, where the line of sight has turned
    points = _target_pixels(image, grid)
    offsets = local_support_offsets(tree, pixels, points)
    assert np.abs(offsets).max() < 0.02, offsets
    poly_col = xml.load("./{*}Grid/{*}Col/{*}DeltaKCOAPoly")
    xy = sksicd.rowcol_to_xrowycol(tree, points.astype(float))
    names = [n.decode() if isinstance(n, bytes) else n for n in image.targets["name"]]
    e, w = xy[names.index("E")], xy[names.index("W")]
    assert abs(npp.polyval2d(*e, poly_col) - npp.polyval2d(*w, poly_col)) > 0.3 * bw["Col"]


def test_stripmap_sicd_centre_of_aperture_follows_the_scp(tmp_path):
    """Beam-limited: TimeCOAPoly is linear in the along-track position and its constant is the SCP's own
    beam-centre time, so the support centre (azimuth: zero Doppler, broadside) is where the pixels have it."""
    import sarkit.sicd as sksicd

    mapping = load_yaml(ROOT / "configs" / "bp_stripmap.yaml")
    raw = simulate(scene_from_mapping(mapping, "bp_stripmap.yaml"))
    image = backproject(raw, build(BackprojectParams, {"frame": "ground_los", "margin_cells": 28}, "t", "backproject"))
    place = placement(image.radar, build(GeolocationParams, GEO, "test", "geolocation"))
    path = tmp_path / "strip.nitf"
    grid = write_sicd(path, image, place)
    assert check_sicd(path)["passed"]
    tree, pixels = read_sicd(path)
    time_coa = sksicd.XmlHelper(tree).load("./{*}Grid/{*}TimeCOAPoly")
    assert time_coa.shape == (2, 2) and abs(time_coa[0, 1]) == pytest.approx(1 / image.radar.velocity, rel=1e-3)
    # measured 0.6 % of the bandwidth at worst (with the aperture centre as the constant: 2.2 % in azimuth)
    assert np.abs(local_support_offsets(tree, pixels, _target_pixels(image, grid))).max() < 0.01


def test_sicd_for_older_readers_passes_sarpy(demo, place, tmp_path):
    pytest.importorskip("sarpy", reason="the older reader's check needs pip install sarpy (test extra)")
    raw, image, _ = demo
    for version in ("1.3.0", "1.4.0"):
        path = tmp_path / f"image_{version}.nitf"
        grid = write_sicd(path, image, place, version=version)
        result = check_sicd(path)  # sarkit checks against the version's own schema
        assert result["passed"] and result["errors"] == [], result["report"]
        tree, pixels = read_sicd(path)
        assert tree.getroot().tag == f"{{urn:SICD:{version}}}SICD"
        assert np.array_equal(pixels, sicd_pixels(image.data, grid))
        sarpy = sarpy_check(path)
        if version == "1.3.0":
            assert sarpy["valid"] and sarpy["errors"] == [], sarpy
        else:  # sarpy (2.1.1) knows SICD up to 1.3.0: its only complaints are the namespace it does not know
            assert len(sarpy["errors"]) == 2, sarpy["errors"]
            assert all("namespace" in e or "urn" in e for e in sarpy["errors"]), sarpy["errors"]
    with pytest.raises(InputError, match="version"):
        write_sicd(tmp_path / "x.nitf", image, place, version="1.2.1")


def test_sicd_refuses_skewed_or_non_image_products(demo, place, scene_mapping):
    raw, image, params = demo
    with pytest.raises(InputError, match="2D image"):
        write_sicd("/nonexistent.nitf", raw, place)
    squint = backproject(raw, build(BackprojectParams, {"frame": "squint", "margin_cells": 4}, "t", "backproject"))
    with pytest.raises(InputError, match="skewed axes|not a plane grid"):
        write_sicd("/nonexistent.nitf", squint, place)


def test_format_commands(demo, tmp_path):
    from click.testing import CliRunner

    from sarproc.cli.main import cli
    from sarproc.product.io import read_product, write_product

    raw, image, _ = demo
    write_product(tmp_path / "raw.h5", raw)
    write_product(tmp_path / "image.h5", image)
    (tmp_path / "geo.yaml").write_text(yaml.safe_dump({"geolocation": GEO}))
    run = CliRunner().invoke
    res = run(
        cli,
        [
            "export-sicd",
            str(tmp_path / "image.h5"),
            "-o",
            str(tmp_path / "image.nitf"),
            "--config",
            str(tmp_path / "geo.yaml"),
            "--check-report",
            str(tmp_path / "sicd.json"),
        ],
    )
    assert res.exit_code == 0, res.output
    assert "SICD consistency: PASS" in res.output and "pixels read back identical" in res.output
    res = run(
        cli,
        [
            "export-sicd",
            str(tmp_path / "image.h5"),
            "-o",
            str(tmp_path / "image13.nitf"),
            "--config",
            str(tmp_path / "geo.yaml"),
            "--sicd-version",
            "1.3.0",
        ],
    )
    assert res.exit_code == 0 and "SICD 1.3.0" in res.output and "SICD consistency: PASS" in res.output, res.output
    assert read_sicd(tmp_path / "image13.nitf")[0].getroot().tag == "{urn:SICD:1.3.0}SICD"
    res = run(
        cli,
        [
            "export-cphd",
            str(tmp_path / "raw.h5"),
            "-o",
            str(tmp_path / "raw.cphd"),
            "--config",
            str(tmp_path / "geo.yaml"),
        ],
    )
    assert res.exit_code == 0 and "CPHD consistency: PASS (" in res.output, res.output
    res = run(cli, ["import-cphd", str(tmp_path / "raw.cphd"), "-o", str(tmp_path / "back.h5")])
    assert res.exit_code == 0, res.output
    back = read_product(tmp_path / "back.h5")
    assert back.kind == "raw" and back.history[-1]["command"].startswith("sarproc import-cphd")
    res = run(cli, ["export-sicd", str(tmp_path / "raw.h5"), "-o", str(tmp_path / "x.nitf")])
    assert res.exit_code == 2 and "image" in res.output
    (tmp_path / "bad.yaml").write_text(yaml.safe_dump({"geolocation": {"latitude": "95 deg", "longitude": 0}}))
    res = run(
        cli,
        [
            "export-cphd",
            str(tmp_path / "raw.h5"),
            "-o",
            str(tmp_path / "y.cphd"),
            "--config",
            str(tmp_path / "bad.yaml"),
        ],
    )
    assert res.exit_code == 2 and "geolocation.latitude" in res.output


CHECKER_RUN = """
import json, sys
from sarproc.formats.sicd import consistency_checker
checker = consistency_checker({kind!r})
alone = sorted(m for m in sys.modules if m.startswith("sarkit.verification."))
deferred = "__getattr__" in vars(sys.modules["numpy.testing"]) and "unittest" not in sys.modules
import sarkit.xmlhelp._core as xml_core
xml_core.npt.assert_equal([1.0, 2.0], [1.0, 2.0])  # sarkit's use of it loads it whole
from numpy.testing import assert_allclose
import sarkit.verification as skver
from sarkit.verification import CrsdConsistency
print(json.dumps({{"alone": alone, "deferred": deferred, "same": getattr(skver, {name!r}) is checker,
                  "all": all(hasattr(skver, n) for n in skver.__all__) and len(skver.__all__) == 4}}))
"""


@pytest.mark.parametrize(
    ("kind", "name", "module"),
    [("SICD", "SicdConsistency", "_sicd_consistency"), ("CPHD", "CphdConsistency", "_cphd_consistency")],
)
def test_an_export_imports_its_own_consistency_checker_alone(kind, name, module):
    """`import sarkit.verification` loads all four checkers (~50 ms more than one, docs/performance.md eighth
    round); an export loads its own, and a later import of the package still gets every checker, the same.
    numpy.testing, which sarkit imports for one rarely used search, loads on its first use."""
    import json
    import subprocess
    import sys

    done = subprocess.run(
        [sys.executable, "-c", CHECKER_RUN.format(kind=kind, name=name)], capture_output=True, text=True, check=True
    )
    out = json.loads(done.stdout.strip().splitlines()[-1])
    assert out["alone"] == sorted(["sarkit.verification._consistency", f"sarkit.verification.{module}"])
    assert out["deferred"] and out["same"] and out["all"]
