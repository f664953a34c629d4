"""Seams of the two-step PFA (paper 002): a point on the border of two sub-images gets one response.

configs/nie2016_row3.yaml: three targets 40 m apart on one azimuth line near the scene centre, inside
plain PFA's valid radius; its default grid cuts two sub-images with the seam through the middle target
C. Each sub-image's support is the rectangle inscribed in its centre's polar support; aligned with the
image axes (the old code), the same rectangle seen from C is turned by C's line-of-sight angle minus the
sub-image centre's, opposite on the two sides of the seam: C's two halves had different band centres
and edges and the mosaic left -31 dB beside C (plain PFA on the same raw: -47 dB). Aligned with each
centre's own line of sight (two_step.own_support) both sub-images hold the same pulses and frequencies.
"""

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest
from conftest import merge

from sarproc.focus.backprojection import BackprojectParams, backproject
from sarproc.focus.pfa import two_step
from sarproc.focus.pfa.chain import Pfa2Params, _ramp_half, pfa2
from sarproc.focus.pfa.polar import Grid
from sarproc.product.config import load_yaml
from sarproc.quality.metrics import EvaluateParams, evaluate_product
from sarproc.simulation.scene import scene_from_mapping
from sarproc.simulation.simulate import simulate

ROW3 = load_yaml(Path(__file__).resolve().parents[2] / "configs" / "nie2016_row3.yaml")


@pytest.fixture(scope="module")
def raw_row3():
    return simulate(scene_from_mapping(ROW3))


def _tasks(raw, params):
    seen = []

    def mapper(func, tasks):
        seen.extend(tasks)
        return map(func, seen)

    image = pfa2(raw, params, mapper=mapper)
    return image, seen


def test_a_target_on_a_seam_gets_the_same_response_from_both_subimages():
    """C alone, on the seam: both sub-images focus the same +-5 m around C (inside both their windows)."""
    raw = simulate(scene_from_mapping(merge(ROW3, {"targets": {"points": [{"name": "C"}]}})))
    a = ROW3["targets"]["points"]
    assert [p.get("azimuth") for p in a] == ["-40 m", None, "40 m"]
    # the row's grid (its targets' span plus margins), so that the seam runs through C as in the row; whole
    # windows (subimage_reach 0): with the seams blended each window holds its piece of C only
    image, tasks = _tasks(
        raw, Pfa2Params(method="two_step", azimuth_extent=107.0, azimuth_center=0.0, subimage_reach=0.0)
    )
    assert len(tasks) == 2 and abs(tasks[0].core.a0 + tasks[0].core.n_a * tasks[0].core.da) < tasks[0].core.da
    c = tasks[0].core
    n = int(round(5 / c.da))
    around = Grid(-n * c.da, c.da, 2 * n + 1, c.r0, c.dr, c.n_r)
    left, right = (two_step.focus_subimage(dataclasses.replace(t, core=around)) for t in tasks)
    peak = np.abs(left).max()
    # axis-aligned supports (the old code) differed by -27 dB here; the same samples leave -46 dB
    assert 20 * np.log10(np.abs(left - right).max() / peak) < -40


def test_a_lone_target_on_a_seam_leaves_no_copy_of_itself_one_sub_image_period_away():
    """C alone on the row's seam, on the row's grid. Each sub-image's second PFA repeats with the period its k
    grid samples, along its own axes; C's ridges run turned from them by theta_C - theta_s (own_support), so C's
    copy one period away has ridges beside C's own, off them by period x sin(theta_C - theta_s). Sampled for
    1.5 windows they left -46.2 dB beside C's range ridge; for 2 x 1.5 windows (chain.SUBIMAGE_PERIOD) C floors
    at -57.9 dB (W alone: -51.5 -> -61.1 dB, plain PFA's -61.1), continuous echoes; the band-limited echoes of
    the config since session 36: C -56.7 dB, W -58.3 dB (this test's image and report; W alone in its place)."""
    raw = simulate(scene_from_mapping(merge(ROW3, {"targets": {"points": [{"name": "C"}]}})))
    image = pfa2(raw, Pfa2Params(method="two_step", azimuth_extent=107.0, azimuth_center=0.0))
    assert image.attrs["subimages"] == 2
    report = evaluate_product(image, EvaluateParams(residual=True))
    assert report.residual.floor_db < -54


def _ridge_db(image, lo: float, hi: float) -> float:
    """Mean over the azimuth columns in [lo, hi] m of the strongest pixel within +-2 m of the peak's range, dB
    from the peak: the level of the azimuth ridge there (bowed by the distortion correction, < 1 m)."""
    x = np.abs(image.data)
    i, j = np.unravel_index(np.argmax(x), x.shape)
    a, r = image.coords["azimuth"], image.coords["range"]
    ridge = x[:, np.abs(r - r[j]) < 2.0].max(axis=1) / x[i, j]
    return float(np.mean(20 * np.log10(ridge[(a >= lo) & (a <= hi)])))


def test_a_lone_targets_azimuth_ridge_crosses_the_seam():
    """W alone (40 m left of the seam, on the row's grid): its azimuth ridge runs on past the seam as plain PFA's
    does (no seam there). Each sub-image returning its core alone cut it at the seam: -51.0 dB 2-8 m before the
    seam, -75.4 dB 2-8 m beyond it (plain PFA -51.8 / -52.0; the right sub-image's rectangle passes none of W's
    step-1 side lobes). The partition of unity (subimage_reach 0.5) focuses W's piece past its core: -51.0 / -52.0."""
    raw = simulate(scene_from_mapping(merge(ROW3, {"targets": {"points": [{"name": "W", "azimuth": "-40 m"}]}})))
    grid = {"azimuth_extent": 107.0, "azimuth_center": 0.0}
    two = pfa2(raw, Pfa2Params(method="two_step", subimage_reach=0.5, **grid))
    assert two.attrs["subimages"] == 2
    plain = pfa2(raw, Pfa2Params(method="plain", **grid))
    for lo, hi in ((-8.0, -2.0), (2.0, 8.0)):
        assert abs(_ridge_db(two, lo, hi) - _ridge_db(plain, lo, hi)) < 2, (lo, hi)


def test_the_seam_partition_adds_up_to_one_and_vanishes_at_each_window_edge():
    """The step-1 image's pieces (two_step.partition_weights) sum to one everywhere, and each piece is zero on
    its window's border: every step-1 pixel is focused once, by the sub-images whose cores hold it. Three by
    two tiles whose step-1 boxes miss or overlap their neighbours' by a little (the distortion along a seam)."""
    inf = math.inf
    edges_a, edges_r = [-inf, -20.0, 21.0, inf], [-inf, 0.4, inf]
    tiles = []
    for i in range(3):
        for j in range(2):
            lo_a, hi_a = edges_a[i] + 0.3 * (i == 2), edges_a[i + 1]
            lo_r, hi_r = edges_r[j] - 0.2 * j, edges_r[j + 1]
            box = (lo_a, hi_a, lo_r, hi_r)
            grow = (-6.0 - i, 6.0 + j, -5.0 - j, 5.0 + i)  # rooms differ from tile to tile
            win = tuple(max(-60.0, min(60.0, x)) + d for x, d in zip(box, grow))
            tiles.append(two_step.Tile(slice(0), slice(0), (0.0, 0.0), win, (0.0, 0.0), box))
    grid = Grid(-64.0, 0.25, 513, -64.0, 0.25, 513)  # inside the outer windows (the step-1 grid)
    total = np.zeros((grid.n_a, grid.n_r))
    half = _ramp_half(tiles)
    for k, t in enumerate(tiles):
        w = two_step.partition_weights(tiles, k, grid, half)
        ia = (grid.a < t.window[0]) | (grid.a > t.window[1])
        ir = (grid.r < t.window[2]) | (grid.r > t.window[3])
        assert np.all(w[ia] == 0) and np.all(w[:, ir] == 0), k
        total += w
    assert np.allclose(total, 1, atol=1e-6)


@pytest.fixture(scope="module")
def row3_reports(raw_row3):
    """Residual reports of the row's two-step, plain PFA and exact backprojected images."""
    params = EvaluateParams(residual=True)
    two = pfa2(raw_row3, Pfa2Params(method="two_step"))
    assert two.attrs["subimages"] == 2  # the seam runs through C
    plain = pfa2(raw_row3, Pfa2Params(method="plain"))
    exact = backproject(raw_row3, BackprojectParams())
    return tuple(evaluate_product(x, params) for x in (two, plain, exact))


def test_plain_pfa_of_the_row_is_within_its_residual_model(row3_reports):
    """Plain PFA's rectangle is exactly the residual model's support: since the fits converge it reaches
    -57.8 / -57.5 dB (-46.7 / -46.4 dB when they stopped after a fixed count of steps); band-limited echoes
    (session 36): -58.7 / -57.7 dB."""
    _, rp, _ = row3_reports
    assert rp.residual.floor_db < -45 and rp.false_target.level_db < -45


@pytest.mark.xfail(
    strict=True,
    reason="two-step -43.50 / -43.03 dB (floor / false target) against backprojection -46.39 / -46.36 + 3 with "
    "the seams blended (subimage_reach 0.5; -42.31 / -42.03 dB cut at the seams): W's far ridge now crosses the "
    "seam, but the row's strongest residue is the ridges' bow from step 2's warp_to_truth, which the residual "
    "model's per-target warps do not follow in the row (docs/product.md, 'Why the ridge stops at the seam'; "
    "docs/pfa.md, 'Session 45: seams blended')",
)
def test_a_line_of_targets_through_a_seam_leaves_no_more_residual_than_backprojection(row3_reports):
    """Residual floor and residual false target of the two-step image within 3 dB of the exact backprojection
    of the same raw (its support a polar sector, as each sub-image's is). With the straight-edged residual
    model: backprojection -40.4 / -40.4 dB, the two-step -41.1 / -40.0 dB; before the seam fix -30.9 / -30.8 dB.
    With the bowed edges (session 31) backprojection -46.41 dB and the two-step -42.43 (its sub-image period
    doubled; -41.74 before): each lone target's far azimuth ridge stops at the seam (W alone -46.38 dB across
    it; the right sub-image's inscribed rectangle passes none of W's step-1 side lobes), and the row's floor
    pixel is W's ridge bowed by step 2's warp_to_truth, which the per-target warps of the model do not follow
    in the row. Band-limited echoes (the config since session 36) leave the same: two-step -42.31 / -42.03 dB,
    backprojection -46.39 / -46.36 dB (the structure is the two-step's, not the chirp's pedestal). Session 45
    blends the seams (a partition of unity of the step-1 image, each piece focused past its core:
    subimage_reach): W's ridge crosses the seam (test_a_lone_targets_azimuth_ridge_crosses_the_seam), and the row
    reads -43.50 / -43.03 dB at reach 0.5, -41.91 / -41.78 at 0.25, -41.30 / -41.30 on the whole grid (1.0): the
    strongest residue stays on the bowed ridges. Kept strict: it fails until the model follows the row's bows
    jointly."""
    r2, _, rb = row3_reports
    assert r2.residual.floor_db < rb.residual.floor_db + 3
    assert r2.false_target.level_db < rb.false_target.level_db + 3


def test_the_backprojected_row_keeps_its_ridges_on_its_lines_of_sight(raw_row3):
    """The exact backprojection's support is a polar sector, unweighted: its side lobes spread over the look
    angles (radial edges, arcs), so no line through a peak holds them. W, C and E (40 m apart) see the aperture
    turned by their lines of sight, and their ridges turn with them, in equal steps (1.6 deg in azimuth). The
    oblique-ridge search (metrics._ridges_in_space) once turned E's, whose edge normals are 2.4 deg from
    perpendicular, to the flat maximum of its line energy 1.5 deg away (the energy fell 3.7 / 7.3 % over 3 / 5
    deg where a straight ridge's falls 6.7 / 21 %); the floor rose -40.4 -> -32.3 dB. Such a maximum is refused
    now, and the spectral ridges kept."""
    rep = evaluate_product(backproject(raw_row3, BackprojectParams()), EvaluateParams(residual=True))
    for name in ("azimuth", "range"):
        turn = []
        for t in ("W", "C", "E"):
            d = rep.target(t).axis(name).direction
            i = rep.dims.index(name)
            turn.append(math.degrees(math.atan2(d[1 - i], d[i])))
        assert abs((turn[1] - turn[0]) - (turn[2] - turn[1])) < 0.1, (name, turn)
    assert rep.residual.floor_db < -39.5
