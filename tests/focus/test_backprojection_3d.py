"""sarproc backproject onto a 3D (elevation, azimuth, range) grid: the exact time-domain reference for
array3d's cubes (paper 004). Scenes: the reduced du2010 of test_array3d (8 receivers, 65 pulses)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from click.testing import CliRunner
from test_array3d import REDUCED, reduced

from sarproc.cli.main import cli
from sarproc.focus.array3d.linear_array import Array3DParams, array3d_product
from sarproc.focus.backprojection import row_blocks
from sarproc.product.io import read_product, write_product
from sarproc.quality.metrics import EvaluateParams, evaluate_product
from sarproc.simulation.scene import scene_from_mapping
from sarproc.simulation.simulate import simulate

POINTS = [
    {"name": "A", "azimuth": "0 m", "range": "490 m", "elevation": "0 deg"},
    {"name": "B", "azimuth": "1.5 m", "range": "492 m", "elevation": "1.5 deg"},
]
# the cube's unambiguous sector is +-asin(lambda / 2d) = +-3 deg with d = 0.0764 m: the grid stays inside it
GRID = (
    "backproject:\n  range_filter: matched\n  elevation_center: 0.5 deg\n  elevation_extent: 5 deg\n"
    "  azimuth_extent: 8 m\n  range_extent: 8 m\n  azimuth_center: 0.75 m\n  range_center: 491 m\n"
)


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    d = tmp_path_factory.mktemp("bp3d")
    raw = simulate(scene_from_mapping(reduced(targets={"points": POINTS})))
    write_product(d / "raw.h5", raw)
    cube, _ = array3d_product(raw, Array3DParams())
    cfg = d / "bp.yaml"
    cfg.write_text(GRID)
    res = CliRunner().invoke(
        cli, ["backproject", str(d / "raw.h5"), "-o", str(d / "bp.h5"), "--config", str(cfg), "--no-progress"]
    )
    assert res.exit_code == 0, res.output
    return d, cube, read_product(d / "bp.h5", kinds=("image3d",))


def test_3d_backprojection_writes_an_elevation_cube(scene):
    _, cube, bp = scene
    assert bp.kind == "image3d" and bp.dims == ("elevation", "azimuth", "range")
    assert bp.attrs["frame"] == cube.attrs["frame"] == {"name": "elevation", "altitude": 500.0}
    assert bp.attrs["axis_units"] == ["rad", "m", "m"]
    el = bp.coords["elevation"]
    step = el[1] - el[0]
    assert el[-1] - el[0] == pytest.approx(math.radians(5), abs=step)
    assert el[len(el) // 2] == pytest.approx(math.radians(0.5), abs=1e-12)
    assert bp.history[-1]["parameters"]["range_filter"] == "matched"
    # the image's theory: the array factor's elevation IRW and the pulses' azimuth and range IRWs, as the cube's
    np.testing.assert_allclose(bp.attrs["theoretical_irw"], cube.attrs["theoretical_irw"], rtol=0.03)
    for d in bp.dims:
        np.testing.assert_allclose(bp.targets[f"irw_{d}"], cube.targets[f"irw_{d}"], rtol=0.03)


def test_3d_backprojection_agrees_with_the_array3d_cube(scene):
    """Same peaks (to a tenth of a cell), IRWs at theory (within 5 %) and within 3 % of the cube's, PSLRs within
    0.5 dB of the cube's. Ideal neighbour models: the response-model refit that evaluate tries by default on the
    backprojected cube's pair (~25 s on 2 cores) leaves every figure of both cubes as it is, to the last bit."""
    _, cube, bp = scene
    ideal = EvaluateParams(neighbour_orders=0)
    rc, rb = evaluate_product(cube, ideal), evaluate_product(bp, ideal)
    for name in ("A", "B"):
        for m1, m2 in zip(rc.target(name).axes, rb.target(name).axes):
            assert m1.axis == m2.axis
            assert abs(m1.position - m2.position) < 0.1 * m1.irw_theory, (name, m1, m2)
            assert abs(m2.position_error_cells) < 0.1, (name, m2)
            assert m2.irw_ratio == pytest.approx(1.0, abs=0.05), (name, m2)
            assert m2.irw / m1.irw == pytest.approx(1.0, abs=0.03), (name, m1, m2)
            assert m2.pslr_db == pytest.approx(m1.pslr_db, abs=0.5), (name, m1, m2)


def test_row_blocks_of_a_3d_grid_are_whole_elevation_planes():
    blocks = row_blocks((7, 10, 12), 250)
    assert blocks == [slice(0, 2), slice(2, 4), slice(4, 6), slice(6, 7)]
    assert row_blocks((7, 10, 12), 1) == [slice(i, i + 1) for i in range(7)]


@pytest.mark.parametrize(
    ("config", "message"),
    [
        ("backproject:\n  elevation_extent: 5 m\n", "backproject.elevation_extent"),
        ("backproject:\n  frame: squint\n  elevation_extent: 5 deg\n", "backproject.elevation_extent"),
        ("backproject:\n  engine: ffbp\n", "ffbp"),
        ("backproject:\n  elevation_spacing: 0.001 deg\n  max_pixels: 1000\n", "max_pixels"),
    ],
)
def test_bad_3d_grids_exit_2(scene, tmp_path, config, message):
    d, _, _ = scene
    cfg = tmp_path / "bad.yaml"
    cfg.write_text(config)
    out = tmp_path / "x.h5"
    res = CliRunner().invoke(cli, ["backproject", str(d / "raw.h5"), "-o", str(out), "--config", str(cfg)])
    assert res.exit_code == 2 and message in res.output, res.output
    assert not out.exists()


def test_a_3d_grid_needs_a_receiver_array(tmp_path):
    """A single-channel raw product has no elevation aperture: frame elevation is refused (exit 2)."""
    m = reduced(effects={"cross_track_array": {"n_receivers": 1}})
    raw = simulate(scene_from_mapping(m))
    write_product(tmp_path / "raw.h5", raw)
    cfg = tmp_path / "c.yaml"
    cfg.write_text("backproject:\n  frame: elevation\n")
    res = CliRunner().invoke(
        cli, ["backproject", str(tmp_path / "raw.h5"), "-o", str(tmp_path / "x.h5"), "--config", str(cfg)]
    )
    assert res.exit_code == 2 and ("raw_array" in res.output or "rx_offset" in res.output), res.output


def test_crowded_azimuth_line_of_a_backprojected_cube_measured_in_place(tmp_path):
    """Paper 004's azimuth line, reduced (8 receivers, 0.2 us pulse): three targets 12.4 azimuth nulls apart,
    each lit by 39 pulses. Backprojected, a target's azimuth response is their Dirichlet kernel (times the
    aperture chirp), nulls every 1 / (39 dk); its own theory measured the band between the end pulses (38 dk),
    so evaluate's neighbour models put the side lobes of 4 and 5 a third of a lobe off at 3 and target 3 read
    IRW/theory 1.06 in place (the full du2010 cube: 1.057, PSLR -12.3 dB). With each pulse a cell of the band, 3
    reads what it reads alone (before: 1.056 and PSLR -12.3 dB in place against 0.999 and -13.3 dB alone; after:
    1.005 and -13.5 dB). Ideal neighbour models only (the response-model refit would cost the test ~30 s)."""
    points = [
        {"name": n, "azimuth": f"{x} m", "range": "490 m", "elevation": "0 deg"}
        for n, x in (("3", 0.0), ("4", 5.0), ("5", -5.0))
    ]
    acquisition = {"mode": "stripmap", "n_pulses": 161, "range_margin": "8 m"}
    grid = (  # one grid for both scenes, the target alone's ISLR window inside it
        "backproject:\n  range_filter: matched\n  elevation_extent: 6 deg\n  azimuth_spacing: 0.125 m\n"
        "  azimuth_extent: 14.5 m\n  azimuth_center: 0 m\n  range_extent: 8 m\n"
    )
    cfg = tmp_path / "bp.yaml"
    cfg.write_text(grid)
    ratios = {}
    for label, pts in (("crowded", points), ("alone", points[:1])):
        targets = {**REDUCED["targets"], "points": pts}
        raw = simulate(scene_from_mapping(reduced(acquisition=acquisition, targets=targets)))
        write_product(tmp_path / f"{label}.h5", raw)
        out = tmp_path / f"{label}_bp.h5"
        res = CliRunner().invoke(
            cli, ["backproject", str(tmp_path / f"{label}.h5"), "-o", str(out), "--config", str(cfg), "--no-progress"]
        )
        assert res.exit_code == 0, res.output
        bp = read_product(out, kinds=("image3d",))
        # the band counts every lit pulse: its null is the Dirichlet kernel's, 1 / (39 pulses x 0.125 m x K_a)
        k_a = 2 / (bp.radar.wavelength * 490.0)
        assert bp.targets["null_azimuth"][0] == pytest.approx(1 / (39 * 0.125 * k_a), rel=0.005)
        rep = evaluate_product(bp, EvaluateParams(neighbour_orders=0))
        ratios[label] = rep.target("3").axis("azimuth")
    crowded, alone = ratios["crowded"], ratios["alone"]
    assert alone.irw_ratio == pytest.approx(1.0, abs=0.01)
    assert crowded.irw_ratio == pytest.approx(alone.irw_ratio, abs=0.015), (crowded, alone)
    assert crowded.pslr_db == pytest.approx(alone.pslr_db, abs=0.5), (crowded, alone)
