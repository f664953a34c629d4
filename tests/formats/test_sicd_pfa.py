"""SICD export of pfa2 images (ImageFormAlgo OTHER by default, the PFA block on request) and polarisation."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

sarkit = pytest.importorskip("sarkit", reason="SICD needs NGA's sarkit: pip install 'sarproc[formats]'")

import numpy.polynomial.polynomial as npp  # noqa: E402

from sarproc.focus.backprojection import BackprojectParams, backproject  # noqa: E402
from sarproc.focus.pfa.chain import Pfa2Params, pfa2  # noqa: E402
from sarproc.formats.geolocation import GeolocationParams, ecf_to_geodetic, placement  # noqa: E402
from sarproc.formats.sicd import check_sicd, local_support_offsets, read_sicd, sarpy_check, write_sicd  # noqa: E402
from sarproc.product.config import build, load_yaml  # noqa: E402
from sarproc.product.errors import InputError  # noqa: E402
from sarproc.product.io import read_product, write_product  # noqa: E402
from sarproc.simulation.scene import scene_from_mapping  # noqa: E402
from sarproc.simulation.simulate import simulate  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
GEO = {
    "time": "2024-05-01T10:00:00Z",
    "latitude": "45 deg",
    "longitude": "7 deg",
    "height": "300 m",
    "heading": "45 deg",
}
OSR_WARNINGS = {"check_iprbw_to_ss_osr_row", "check_iprbw_to_ss_osr_col"}


@pytest.fixture(scope="module")
def small_raw():
    mapping = load_yaml(ROOT / "configs" / "nie2016_small.yaml")
    return mapping, simulate(scene_from_mapping(mapping, "nie2016_small.yaml"))


def _pfa2(small_raw, **over):
    mapping, raw = small_raw
    params = build(Pfa2Params, {**(mapping.get("pfa2") or {}), **over}, "nie2016_small.yaml", "pfa2")
    image = pfa2(raw, params)
    return image, placement(image.radar, build(GeolocationParams, GEO, "test", "geolocation"))


@pytest.fixture(scope="module")
def pfa_image(small_raw):
    """pfa2 (two-step, the defaults of configs/nie2016_small.yaml) image of the reduced Table 1 scene."""
    return _pfa2(small_raw)


@pytest.fixture(scope="module")
def plain_image(small_raw):
    """pfa2 plain (polar-format geometry: planar-wavefront distortion left in) of the same scene."""
    return _pfa2(small_raw, method="plain")


def _peak_pixels(image, window=150):
    """Each target's brightest pixel within +-window cells of its truth, parabola-refined; and its level."""
    az, rg = image.coords["azimuth"], image.coords["range"]
    mag = np.abs(image.data)
    out = []
    for t in image.targets:
        i0 = int(round((t["azimuth"] - az[0]) / (az[1] - az[0])))
        j0 = int(round((t["range"] - rg[0]) / (rg[1] - rg[0])))
        a, b = max(i0 - window, 1), max(j0 - window, 1)
        sub = mag[a : min(i0 + window, mag.shape[0] - 1), b : min(j0 + window, mag.shape[1] - 1)]
        i, j = np.unravel_index(np.argmax(sub), sub.shape)
        i, j = i + a, j + b

        def vertex(lo, mid, hi):
            return 0.5 * (lo - hi) / (lo - 2 * mid + hi)

        out.append((i + vertex(*mag[i - 1 : i + 2, j]), j + vertex(*mag[i, j - 1 : j + 2]), mag[i, j] / mag.max()))
    return np.array(out)


def _load(tree, path):
    import sarkit.sicd as sksicd

    return sksicd.XmlHelper(tree).load(path)


def _target_projection_errors(tree, grid, image, place, pixels=None) -> np.ndarray:
    """Distance (m) from each target to its pixel (default: the pixel of its truth; else ``pixels``, (i, j)
    per target) projected by the file's own R/Rdot model."""
    import sarkit.sicd as sksicd

    az, rg = image.coords["azimuth"], image.coords["range"]
    errors = []
    for n, t in enumerate(image.targets):
        i = (t["azimuth"] - az[0]) / (az[1] - az[0])
        j = (t["range"] - rg[0]) / (rg[1] - rg[0])
        if pixels is not None:
            i, j = pixels[n]
        col = len(az) - 1 - i if grid.flip_cols else i
        truth = place.to_ecf(np.array([t["x"], t["y"], t["z"]]))
        xy = sksicd.rowcol_to_xrowycol(tree, np.array([[j, col]]))
        spot, _, ok = sksicd.image_to_constant_hae_surface(tree, xy, ecf_to_geodetic(truth)[2], delta_hae_max=1e-4)
        assert ok
        errors.append(float(np.linalg.norm(spot[0] - truth)))
    return np.array(errors)


def test_pfa2_image_exports_as_other_plane_and_geolocates(pfa_image, tmp_path):
    image, place = pfa_image
    path = tmp_path / "pfa2.nitf"
    grid = write_sicd(path, image, place)
    result = check_sicd(path)
    assert result["passed"] and result["errors"] == [], result["report"]
    assert set(result["warnings"]) <= OSR_WARNINGS
    tree, _ = read_sicd(path)
    assert _load(tree, "./{*}ImageFormation/{*}ImageFormAlgo") == "OTHER"
    assert _load(tree, "./{*}Grid/{*}Type") == "PLANE"
    assert tree.find("./{*}PFA") is None
    # pfa2's two-step mosaic is on the true ground grid: the PLANE model puts every target on its pixel
    assert _target_projection_errors(tree, grid, image, place).max() < 0.02


def test_plain_pfa2_image_exports_a_consistent_pfa_block(plain_image, tmp_path):
    image, place = plain_image
    path = tmp_path / "plain.nitf"
    grid = write_sicd(path, image, place)  # auto: polar-format geometry -> PFA
    result = check_sicd(path)
    assert result["passed"] and result["errors"] == [], result["report"]
    # the PFA checks ran (grid type, IPN, polar angle, IPR bandwidth, processed band)
    assert result["n_passed"] > 55
    # check_image_corners compares the corners projected through the PFA model with a straight step along
    # the grid vectors: they differ by the polar-format distortion the PFA model describes (> 5 % of the
    # image diagonal at the corners of this 1.5 km range scene)
    assert set(result["warnings"]) <= OSR_WARNINGS | {"check_image_corners"}
    tree, _ = read_sicd(path)
    assert _load(tree, "./{*}ImageFormation/{*}ImageFormAlgo") == "PFA"
    assert _load(tree, "./{*}Grid/{*}Type") == "RGAZIM"
    u_row, u_col = _load(tree, "./{*}Grid/{*}Row/{*}UVectECF"), _load(tree, "./{*}Grid/{*}Col/{*}UVectECF")
    ipn, fpn = _load(tree, "./{*}PFA/{*}IPN"), _load(tree, "./{*}PFA/{*}FPN")
    normal = np.cross(u_row, u_col)
    assert abs(ipn @ normal - 1) < 1e-9 and abs(fpn @ normal - 1) < 1e-9  # pfa2 formats in the image plane
    # polar angle and scale factor against the track, recomputed here from the file's ARPPoly and SCP
    ref = _load(tree, "./{*}PFA/{*}PolarAngRefTime")
    ang = _load(tree, "./{*}PFA/{*}PolarAngPoly")
    ksf = _load(tree, "./{*}PFA/{*}SpatialFreqSFPoly")
    arp_poly = _load(tree, "./{*}Position/{*}ARPPoly")
    scp = _load(tree, "./{*}GeoData/{*}SCP/{*}ECF")
    duration = _load(tree, "./{*}Timeline/{*}CollectDuration")
    assert abs(npp.polyval(ref, ang)) < 1e-12
    assert 0 <= ref <= duration
    t = np.linspace(0, duration, 41)
    los = scp - npp.polyval(t, arp_poly).T
    los /= np.linalg.norm(los, axis=1, keepdims=True)
    theta = np.arctan2(los @ u_col, los @ u_row)
    assert np.abs(npp.polyval(t, ang) - theta).max() < 1e-6
    assert np.abs(npp.polyval(theta, ksf) - np.hypot(los @ u_row, los @ u_col)).max() < 1e-6
    # k-space bounds: the processed rectangle of pfa2, holding the grid's bandwidths and centres
    krg1, krg2, kaz1, kaz2 = (_load(tree, f"./{{*}}PFA/{{*}}{k}") for k in ("Krg1", "Krg2", "Kaz1", "Kaz2"))
    ka0, dka, n_ka, kr0, dkr, n_kr = image.attrs["support_rectangle"]
    assert krg2 - krg1 == pytest.approx(n_kr * dkr / (2 * np.pi), rel=1e-12)
    assert kaz2 - kaz1 == pytest.approx(n_ka * dka / (2 * np.pi), rel=1e-12)
    assert _load(tree, "./{*}Grid/{*}Row/{*}ImpRespBW") <= krg2 - krg1
    assert _load(tree, "./{*}Grid/{*}Col/{*}ImpRespBW") <= kaz2 - kaz1
    # the band centre: (2 f_c / c) x scale factor at the reference angle, within the rectangle's range extent
    fc = image.radar.carrier_frequency
    assert krg1 < 2 * fc / 299792458.0 * npp.polyval(0.0, ksf) < krg2
    # the SCP is the point pfa2 formatted about
    frame_origin = place.to_ecf(np.asarray(image.attrs["frame"]["origin"], float))
    assert np.linalg.norm(scp - frame_origin) < 1e-6
    # what PFA is for: the peaks sit where the planar-wavefront model put them (metres off their truth at
    # this 1.5 km range); SICD's PFA projection of the peaks lands on the truth, the PLANE grid's would not
    peaks = _peak_pixels(image)
    clear = peaks[:, 2] > 0.3  # a corner target pushed off its focus is left out
    assert clear.sum() >= 20
    az, rg = image.coords["azimuth"], image.coords["range"]
    shift = np.hypot(
        (peaks[:, 0] - (image.targets["azimuth"] - az[0]) / (az[1] - az[0])) * (az[1] - az[0]),
        (peaks[:, 1] - (image.targets["range"] - rg[0]) / (rg[1] - rg[0])) * (rg[1] - rg[0]),
    )
    assert shift[clear].max() > 5.0
    errors = _target_projection_errors(tree, grid, image, place, pixels=peaks[:, :2])
    assert errors[clear].max() < 0.1  # < half a pixel (0.24 m)
    # one common k-space centre: KCtr is the rectangle's centre (what SICD readers expect of PFA),
    # DeltaKCOAPoly 0, and so the pixels' local spectrum about every peak is centred at the DFT's zero
    # (measured 0.8 % of the bandwidth at worst)
    assert _load(tree, "./{*}Grid/{*}Row/{*}KCtr") == pytest.approx((krg1 + krg2) / 2, rel=1e-12)
    assert _load(tree, "./{*}Grid/{*}Col/{*}KCtr") == pytest.approx((kaz1 + kaz2) / 2, abs=1e-12)
    for axis in ("Row", "Col"):
        assert np.array_equal(_load(tree, f"./{{*}}Grid/{{*}}{axis}/{{*}}DeltaKCOAPoly"), [[0.0]])
    _, pixels = read_sicd(path)
    rows = np.round(peaks[clear, 1]).astype(int)
    cols = np.round(peaks[clear, 0]).astype(int)
    cols = image.data.shape[0] - 1 - cols if grid.flip_cols else cols
    inside = (rows >= 16) & (rows < pixels.shape[0] - 16) & (cols >= 16) & (cols < pixels.shape[1] - 16)
    assert inside.sum() >= 15
    points = np.column_stack([rows, cols])[inside]
    assert np.abs(local_support_offsets(tree, pixels, points)).max() < 0.02


@pytest.mark.parametrize("which", ["plain", "two_step"])
def test_pfa2_sicd_passes_sarpy(which, plain_image, pfa_image, tmp_path):
    pytest.importorskip("sarpy", reason="the older reader's check needs pip install sarpy (test extra)")
    image, place = plain_image if which == "plain" else pfa_image
    path = tmp_path / f"{which}.nitf"
    write_sicd(path, image, place, version="1.3.0")
    result = sarpy_check(path)
    assert result["valid"] and result["errors"] == [], result


def test_two_step_image_as_pfa_carries_the_planar_wavefront_error(pfa_image, tmp_path):
    image, place = pfa_image
    path = tmp_path / "two_step_pfa.nitf"
    grid = write_sicd(path, image, place, image_formation="PFA")
    result = check_sicd(path)
    assert result["passed"] and result["errors"] == [], result["report"]
    tree, _ = read_sicd(path)
    # why OTHER is the default for the two-step mosaic: it is on the true ground grid, so the PFA
    # projection (planar wavefront about the SCP) misses its targets by the wavefront curvature
    assert _target_projection_errors(tree, grid, image, place).max() > 5.0


def test_pfa_is_refused_for_backprojected_images(tmp_path):
    mapping = load_yaml(ROOT / "configs" / "demo.yaml")
    raw = simulate(scene_from_mapping(mapping, "demo.yaml"))
    image = backproject(raw, build(BackprojectParams, {"margin_cells": 4}, "t", "backproject"))
    place = placement(image.radar, build(GeolocationParams, GEO, "test", "geolocation"))
    with pytest.raises(InputError, match="PFA needs an image of pfa2"):
        write_sicd(tmp_path / "x.nitf", image, place, image_formation="PFA")


def _small_demo(polarization=None):
    mapping = load_yaml(ROOT / "configs" / "demo.yaml")
    if polarization is not None:
        mapping["radar"]["polarization"] = polarization
    raw = simulate(scene_from_mapping(mapping, "demo.yaml"))
    return backproject(raw, build(BackprojectParams, {"margin_cells": 4}, "t", "backproject"))


@pytest.mark.parametrize("pol, tx, txrcv", [("H:V", "H", "H:V"), (None, "UNKNOWN", "UNKNOWN")])
def test_polarization_round_trips_to_sicd(pol, tx, txrcv, tmp_path):
    image = _small_demo(pol)
    assert image.radar.polarization == pol
    write_product(tmp_path / "image.h5", image)
    back = read_product(tmp_path / "image.h5")
    assert back.radar.polarization == pol
    place = placement(back.radar, build(GeolocationParams, GEO, "test", "geolocation"))
    write_sicd(tmp_path / "image.nitf", back, place)
    result = check_sicd(tmp_path / "image.nitf")
    assert result["passed"], result["report"]
    tree, _ = read_sicd(tmp_path / "image.nitf")
    assert tree.findtext("./{*}RadarCollection/{*}TxPolarization") == tx
    assert tree.findtext("./{*}RadarCollection/{*}RcvChannels/{*}ChanParameters/{*}TxRcvPolarization") == txrcv
    assert tree.findtext("./{*}ImageFormation/{*}TxRcvPolarizationProc") == txrcv


def test_bad_polarization_exits_2_naming_file_and_key(tmp_path):
    text = (
        (ROOT / "configs" / "demo.yaml").read_text().replace("  prf: 500 Hz\n", "  prf: 500 Hz\n  polarization: VV\n")
    )
    assert "polarization: VV" in text
    scene = tmp_path / "bad.yaml"
    scene.write_text(text)
    proc = subprocess.run(
        [sys.executable, "-m", "sarproc", "simulate", str(scene), "-o", str(tmp_path / "r.h5")],
        capture_output=True,
        text=True,
    )
    assert proc.returncode == 2
    assert str(scene) in proc.stderr and "radar.polarization" in proc.stderr


def test_gotcha_polarization_from_the_afrl_file_names():
    from sarproc.formats.gotcha import polarization_from_names

    assert polarization_from_names(["d/data_3dsar_pass1_az001_HH.mat", "data_3dsar_pass1_az002_HH.mat"]) == "H:H"
    assert polarization_from_names(["x_hv.mat"]) == "H:V"
    assert polarization_from_names(["x_HH.mat", "x_VV.mat"]) is None  # mixed: not one polarisation
    assert polarization_from_names(["x.mat"]) is None


@pytest.mark.parametrize("pol", ["H:V", None])
def test_polarization_round_trips_through_cphd(pol, tmp_path):
    from sarproc.formats.cphd import check_cphd, read_cphd, write_cphd

    mapping = load_yaml(ROOT / "configs" / "demo.yaml")
    if pol is not None:
        mapping["radar"]["polarization"] = pol
    raw = simulate(scene_from_mapping(mapping, "demo.yaml"))
    place = placement(raw.radar, build(GeolocationParams, GEO, "test", "geolocation"))
    for own in (True, False):  # lossless (sarproc.* parameters) and standard fields only
        path = tmp_path / f"raw_{own}.cphd"
        write_cphd(path, raw, place, sarproc_metadata=own)
        result = check_cphd(path)
        assert result["passed"], result["report"]
        assert read_cphd(path).radar.polarization == pol
    import sarkit.cphd as skcphd

    with open(tmp_path / "raw_False.cphd", "rb") as fh, skcphd.Reader(fh) as reader:
        tree = reader.metadata.xmltree
    want = pol.split(":") if pol else ["UNSPECIFIED", "UNSPECIFIED"]
    assert [
        tree.findtext(f"./{{*}}Channel/{{*}}Parameters/{{*}}Polarization/{{*}}{k}") for k in ("TxPol", "RcvPol")
    ] == want
