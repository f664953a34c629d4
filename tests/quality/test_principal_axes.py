"""Principal-axis metrics (issue 9): ideal responses whose side-lobe ridges are not the image axes.

Images are sampled directly from closed-form band-limited responses: a separable sinc in
physical (orthogonal) coordinates seen on a skewed grid (the squint frame's geometry), and a
rotated rectangular support on an orthogonal grid (polar-format geometry). Expected values are
the textbook ones (0.886/B, -13.26 dB, -10.16 dB) or this suite's independent Fourier-integral
reference (tests/quality/test_metrics.py), never sarproc's own numbers.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from sarproc.quality.metrics import EvaluateParams, check_report, evaluate_image, expectations_from_mapping
from tests.quality.test_metrics import SINC_ISLR, SINC_PSLR, axis_coords, reference_metrics

DIMS = ("azimuth", "range")


def assert_theory(m, irw, rel=0.01):
    assert m.irw == pytest.approx(irw, rel=rel), m
    assert abs(m.irw_ratio - 1) < rel, m
    assert abs(m.pslr_db - SINC_PSLR) < 0.1, m
    assert abs(m.islr_db - SINC_ISLR) < 0.1, m
    assert abs(m.position_error_cells) < 0.02, m
    assert not m.truncated


def skewed_image(shear, bx, by, targets, n=(200, 200), step=(0.5, 0.5), carrier=(0.3, -0.2), amps=None):
    """sinc(bx X) sinc(by Y) (physical X, Y) sampled at P = a (1, 0) + r (s, c), s = shear."""
    s = shear
    c = math.sqrt(1 - s * s)
    a, r = axis_coords(n[0], step[0]), axis_coords(n[1], step[1])
    A, R = np.meshgrid(a, r, indexing="ij")
    img = np.zeros(A.shape, complex)
    for k, (a0, r0) in enumerate(targets):
        da, dr = A - a0, R - r0
        X, Y = da + s * dr, c * dr
        amp = 1.0 if amps is None else amps[k]
        img += amp * np.sinc(bx * X) * np.sinc(by * Y) * np.exp(2j * np.pi * (carrier[0] * X + carrier[1] * Y))
    metric = np.array([[1.0, 0.0], [s, c]])
    # theory per axis: the ridge's -3 dB extent along its own axis (range ridge: Y = c r)
    theory = (0.886 / bx, 0.886 / (by * c))
    return img.astype(np.complex64), [a, r], metric, theory


def rotated_image(phi_deg, bu, bv, targets, n=(200, 200), step=(0.45, 0.45), weight="none"):
    """Rectangular support bu x bv rotated by phi on an orthogonal grid (unweighted or Hamming)."""
    phi = math.radians(phi_deg)
    cp, sp = math.cos(phi), math.sin(phi)
    x, y = axis_coords(n[0], step[0]), axis_coords(n[1], step[1])
    X, Y = np.meshgrid(x, y, indexing="ij")
    shape = np.sinc if weight == "none" else (lambda q: 0.54 * np.sinc(q) + 0.23 * (np.sinc(q - 1) + np.sinc(q + 1)))
    img = np.zeros(X.shape, complex)
    for x0, y0 in targets:
        U, W = (X - x0) * cp + (Y - y0) * sp, -(X - x0) * sp + (Y - y0) * cp
        img += shape(bu * U) * shape(bv * W) * np.exp(2j * np.pi * 0.25 * U / step[0])
    theory = (0.886 * cp / bu, 0.886 * cp / bv)  # each ridge's extent along its own axis
    return img.astype(np.complex64), [x, y], theory


@pytest.mark.parametrize("shear", [0.3, 0.58])
def test_skewed_grid_reads_the_physical_response(shear):
    bx, by = 0.886 / 1.0, 0.886 / 0.8
    targets = [(0.21, -0.33), (-25.4, 24.6)]
    img, coords, metric, theory = skewed_image(shear, bx, by, targets)
    rep = evaluate_image(img, DIMS, coords, theory, targets, metric=metric)
    for t in rep.targets:
        az, rg = t.axes
        assert_theory(az, 0.886 / bx)
        assert_theory(rg, 0.886 / by)
        # the range ridge leans by asin(shear) from the range axis (physical angle)
        assert rg.angle_deg == pytest.approx(math.degrees(math.asin(shear)), abs=0.3)
        assert rg.direction[0] == pytest.approx(-shear, abs=0.01) and rg.direction[1] == 1.0
        assert az.angle_deg < 0.3
        # the image-axis cut along range crosses the azimuth ridge obliquely: cleaner than it is
        assert t.image_axes[1].pslr_db < SINC_PSLR - 1.5


@pytest.mark.parametrize("phi", [10.0, 30.0, 45.0])
def test_rotated_support(phi):
    bu, bv = (0.886, 0.886) if phi == 45.0 else (0.886 / 1.0, 0.886 / 1.25)
    targets = [(0.13, -0.41), (22.3, -18.9)]
    img, coords, theory = rotated_image(phi, bu, bv, targets)
    rep = evaluate_image(img, DIMS, coords, theory, targets, metric=np.eye(2))
    for t in rep.targets:
        assert_theory(t.axes[0], 0.886 / bu)
        assert_theory(t.axes[1], 0.886 / bv)
        for m in t.axes:
            assert m.angle_deg == pytest.approx(phi, abs=0.3)
    if phi >= 30:  # axis cuts misread the response by far more than the tolerance
        assert t.image_axes[0].pslr_db < SINC_PSLR - 2


def test_hamming_rotated_matches_fourier_integral():
    b = 0.886
    targets = [(0.31, 0.17)]
    img, coords, theory = rotated_image(30.0, b, b, targets, weight="hamming")
    rep = evaluate_image(img, DIMS, coords, theory, targets, metric=np.eye(2))
    ref = reference_metrics(b, lambda f: 0.54 + 0.46 * np.cos(2 * np.pi * f))
    for m in rep.targets[0].axes:
        assert ref["irw"] * b == pytest.approx(1.30, abs=0.01)
        assert m.irw == pytest.approx(ref["irw"], rel=0.01)
        assert m.pslr_db == pytest.approx(ref["pslr_db"], abs=0.1)
        assert m.islr_db == pytest.approx(ref["islr_db"], abs=0.1)


@pytest.mark.parametrize("shear, along", [(0.0, "range"), (0.58, "range"), (0.58, "azimuth")])
def test_two_sincs_ten_nulls_apart(shear, along):
    bx, by = 0.886 / 1.0, 0.886 / 0.8
    c = math.sqrt(1 - shear**2)
    if along == "range":  # 10 nulls along the range ridge: X fixed, Y = 10 / by
        d_r = 10 / (by * c)
        targets = [(0.1, -0.2), (0.1 - shear * d_r, -0.2 + d_r)]
    else:
        targets = [(0.1, -0.2), (0.1 + 10 / bx, -0.2)]
    img, coords, metric, theory = skewed_image(shear, bx, by, targets, amps=[1.0, 0.7 * np.exp(1j)])
    rep = evaluate_image(img, DIMS, coords, theory, targets, names=["A", "B"], metric=metric)
    for t in rep.targets:
        assert t.neighbours_removed == ({"A": "B", "B": "A"}[t.name],)
        assert_theory(t.axes[0], 0.886 / bx)
        assert_theory(t.axes[1], 0.886 / by)
    # without the neighbour model the cut along the pair reads the other target's main lobe
    raw = evaluate_image(
        img,
        DIMS,
        coords,
        theory,
        targets,
        names=["A", "B"],
        metric=metric,
        params=EvaluateParams(remove_neighbours=False),
    )
    a = 0 if along == "azimuth" else 1
    assert raw.target("A").axes[a].pslr_db > SINC_PSLR + 1


def test_cut_reaching_the_edge_is_truncated_and_unverified():
    bx, by = 0.886 / 1.0, 0.886 / 0.8
    coords_r_edge = axis_coords(200, 0.5)[-1] - 3.0  # 3 m (about 3 nulls) from the range edge
    targets = [(0.0, 0.0), (10.0, coords_r_edge)]
    img, coords, metric, theory = skewed_image(0.3, bx, by, targets)
    rep = evaluate_image(img, DIMS, coords, theory, targets, names=["A", "B"], metric=metric)
    assert not rep.target("A").truncated
    assert rep.target("B").axes[1].truncated and not rep.target("B").axes[0].truncated
    exp = expectations_from_mapping({"pslr_db": [-20, 0]})  # B's figures would pass this bound
    fails = check_report(rep, exp)
    assert [(f.target, f.axis, f.metric) for f in fails] == [("B", "range", "truncated")]
    assert "unverified" in str(fails[0])


def test_poorly_modelled_neighbour_is_flagged_contaminated():
    # Both responses carry a quadratic phase along azimuth (pi q x^2, 0.9 rad two nulls out) that the
    # flat-spectrum neighbour model lacks: the subtraction cannot be trusted, the cut says so.
    bx, by = 0.886 / 1.0, 0.886 / 0.8
    targets = [(0.1, -0.2), (0.1 + 10 / bx, -0.2)]
    img, coords, metric, theory = skewed_image(0.0, bx, by, targets)
    a = axis_coords(200, 0.5)
    chirp = np.exp(
        1j
        * 0.9
        / (2 / bx) ** 2
        * np.add.outer(np.minimum((a - targets[0][0]) ** 2, (a - targets[1][0]) ** 2), np.zeros(200))
    )
    img = (img * chirp).astype(np.complex64)
    rep = evaluate_image(img, DIMS, coords, theory, targets, names=["A", "B"], metric=metric)
    for t in rep.targets:
        assert t.axes[0].contaminated_db is not None and t.axes[0].contaminated_db > -20
        assert t.axes[1].contaminated_db is None  # nothing of the neighbour along range
    fails = check_report(rep, expectations_from_mapping({"pslr_db": [-30, 0]}))
    assert {(f.target, f.axis, f.metric) for f in fails} == {
        ("A", "azimuth", "contaminated"),
        ("B", "azimuth", "contaminated"),
    }
    assert all("unverified" in str(f) for f in fails)


def test_sinc_islr_over_shortened_windows():
    # independent of sarproc: a dense midpoint sum of sinc^2 over the main lobe and the side lobes
    from sarproc.quality.metrics import sinc_islr_db

    x = (np.arange(2_000_000) + 0.5) / 100_000  # 0 .. 20 nulls, 1e5 points per null
    p = np.sinc(x) ** 2
    for w in (2, 3, 6, 10):
        ref = 10 * np.log10(p[100_000 : w * 100_000].sum() / p[:100_000].sum())
        assert sinc_islr_db(w) == pytest.approx(ref, abs=1e-3)
    assert sinc_islr_db(10) == pytest.approx(SINC_ISLR, abs=0.01)


def test_contaminated_cut_is_also_measured_on_a_shortened_window():
    # A is an ideal sinc; B, 6 nulls away along azimuth, carries a quadratic spectral phase (1 rad at the
    # band edges) that the ideal neighbour model lacks, so its subtraction leaves a residual in A's window.
    # The shortened window stops half-way to B (3 nulls, before B's main lobe at 5 nulls) and reads A's
    # own side lobes: PSLR -13.26 dB and the sinc's ISLR over +-3 nulls.
    from sarproc.quality.metrics import sinc_islr_db
    from tests.quality.test_metrics import spectrum_psf

    bx, by = 0.886 / 1.0, 0.886 / 0.8
    targets = [(0.1, -0.2), (0.1 + 6 / bx, -0.2)]
    a, r = axis_coords(200, 0.5), axis_coords(200, 0.5)
    defocused = spectrum_psf(bx, np.ones_like, phase=lambda f: 1.0 * (2 * f) ** 2)
    az_b = 0.8 * defocused(a - targets[1][0]) / defocused(np.zeros(1))[0]
    img = np.outer(np.sinc(bx * (a - targets[0][0])) + az_b, np.sinc(by * (r - targets[0][1]))).astype(np.complex64)
    # ideal neighbour models only (neighbour_orders: 0); the default fits B's phase: see the next test
    rep = evaluate_image(
        img,
        DIMS,
        [a, r],
        (0.886 / bx, 0.886 / by),
        targets,
        names=["A", "B"],
        params=EvaluateParams(neighbour_orders=0),
    )
    m = rep.target("A").axes[0]
    assert m.contaminated_db is not None
    assert m.islr_db > SINC_ISLR + 1  # the full window still holds B's residual
    assert m.shortened_nulls == 3
    assert m.shortened_islr_theory_db == pytest.approx(sinc_islr_db(3))
    assert abs(m.shortened_pslr_db - SINC_PSLR) < 0.2, m
    assert abs(m.shortened_islr_db - sinc_islr_db(3)) < 0.3, m
    assert abs(m.irw_ratio - 1) < 0.01 and abs(m.position_error_cells) < 0.02
    assert rep.target("A").axes[1].shortened_nulls is None  # range: nothing of B, nothing shortened
    # --expect: a shortened window is not the contract's; the cut stays unverified
    fails = check_report(rep, expectations_from_mapping({"pslr_db": [-30, 0], "islr_db": [-30, 0]}))
    assert ("A", "azimuth", "contaminated") in {(f.target, f.axis, f.metric) for f in fails}
    assert any("shortened" in str(f) and "unverified" in str(f) for f in fails if f.target == "A")


def test_neighbour_with_spectral_phase_is_fitted_and_both_are_measured_in_place():
    # The scene above: B, 6 nulls from A along azimuth, carries a quadratic spectral phase (1 rad at the band
    # edges). By default the crowded group, poorly fitted by ideal responses, is fitted again as response
    # models with their own spectral weight and phase: A reads an ideal sinc, B its own defocused response
    # (the Fourier integral of its spectrum, evaluated independently of sarproc), neither contaminated.
    from tests.quality.test_metrics import spectrum_psf

    bx, by = 0.886 / 1.0, 0.886 / 0.8
    targets = [(0.1, -0.2), (0.1 + 6 / bx, -0.2)]
    a, r = axis_coords(200, 0.5), axis_coords(200, 0.5)

    def phase(f):
        return 1.0 * (2 * f) ** 2

    defocused = spectrum_psf(bx, np.ones_like, phase=phase)
    az_b = 0.8 * defocused(a - targets[1][0]) / defocused(np.zeros(1))[0]
    img = np.outer(np.sinc(bx * (a - targets[0][0])) + az_b, np.sinc(by * (r - targets[0][1]))).astype(np.complex64)
    rep = evaluate_image(img, DIMS, [a, r], (0.886 / bx, 0.886 / by), targets, names=["A", "B"])
    ma, mb = rep.target("A").axes[0], rep.target("B").axes[0]
    assert ma.contaminated_db is None and mb.contaminated_db is None
    assert abs(ma.irw_ratio - 1) < 0.005 and abs(ma.pslr_db - SINC_PSLR) < 0.1 and abs(ma.islr_db - SINC_ISLR) < 0.1
    ref = reference_metrics(bx, np.ones_like, phase)
    assert mb.irw == pytest.approx(ref["irw"], rel=0.003)
    assert mb.pslr_db == pytest.approx(ref["pslr_db"], abs=0.1)
    assert mb.islr_db == pytest.approx(ref["islr_db"], abs=0.1)
    assert check_report(rep, expectations_from_mapping({"pslr_db": [-30, 0]})) == []


# A narrowband, wide-angle aperture: fractional bandwidth 1/67 (30 MHz at 2 GHz), +-3.9 deg of look angles
# (paper 002's reduced scene). Its support is an annular sector whose range edges are arcs, so the range side
# lobes fan out over the look angles instead of lying on one ridge.
FAN_CARRIER, FAN_HALF_ANGLE = 67.0, 0.0685  # carrier over bandwidth; half the aperture, rad


def fan_response(x, y, centre_deg, n_angles=400):
    """The annular sector's response at (x, y) (range nulls: bandwidth 1): the sum over look angles phi of
    sinc(rho) exp(j 2 pi f_c rho), rho = x cos(phi) + y sin(phi), phi spread evenly over the aperture."""
    phi = math.radians(centre_deg) + FAN_HALF_ANGLE * ((np.arange(n_angles) + 0.5) / n_angles * 2 - 1)
    out = np.zeros(np.broadcast(x, y).shape, complex)
    for c, s in zip(np.cos(phi), np.sin(phi)):
        rho = x * c + y * s
        out += np.sinc(rho) * np.exp(2j * np.pi * FAN_CARRIER * rho)
    return out / n_angles


def fan_cut_reference(centre_deg, window_nulls=10.0, step=1 / 256):
    """IRW, PSLR and ISLR of the closed form sampled densely along the fan's centre (independent of sarproc)."""
    t = np.arange(-(window_nulls + 2), window_nulls + 2 + step, step)
    a = math.radians(centre_deg)
    p = np.abs(fan_response(t * math.cos(a), t * math.sin(a), centre_deg)) ** 2
    k = int(np.argmax(p))
    left = k - int(np.argmax(np.diff(p[k::-1]) > 0))  # first nulls: where the power stops falling
    right = k + int(np.argmax(np.diff(p[k:]) > 0))
    half = np.flatnonzero(p >= p[k] / 2)
    inside = np.abs(t) <= window_nulls
    main = p[left : right + 1].sum()
    return {
        "irw": (half[-1] - half[0]) * step,
        "pslr_db": 10 * np.log10(max(p[: left + 1].max(), p[right:].max()) / p[k]),
        "islr_db": 10 * np.log10((p[inside].sum() - main) / main),
    }


@pytest.mark.parametrize("centre_deg", [0.0, 3.0])
def test_a_fan_of_range_side_lobes_is_cut_through_its_centre(centre_deg):
    """The range ridge of a narrowband, wide-angle aperture is the centre of its fan of side lobes, where they are
    highest: one end of the fan (where the arcs' normals crowd) reads the side lobes 2 dB too low."""
    az, rg = axis_coords(150, 0.04), axis_coords(160, 0.4)
    A, R = np.meshgrid(az, rg, indexing="ij")
    img = fan_response(R, A, centre_deg).astype(np.complex64)  # range along x, azimuth along y
    ref = fan_cut_reference(centre_deg)
    assert ref["pslr_db"] > SINC_PSLR - 1.0  # the fan's centre: close to a sinc's side lobes
    azimuth_irw = 0.886 / (2 * FAN_CARRIER * math.sin(FAN_HALF_ANGLE))
    rep = evaluate_image(img, DIMS, [az, rg], (azimuth_irw, ref["irw"]), [(0.0, 0.0)], metric=np.eye(2))
    cut = rep.targets[0].axes[1]
    assert cut.angle_deg == pytest.approx(centre_deg, abs=0.5), cut
    assert cut.irw == pytest.approx(ref["irw"], rel=0.01), cut
    assert cut.pslr_db == pytest.approx(ref["pslr_db"], abs=0.15), cut
    assert cut.islr_db == pytest.approx(ref["islr_db"], abs=0.2), cut
    # said, and the residual's point-target model (which does not describe a fan) not trusted there
    assert len(rep.targets[0].notes) == 1 and "range side lobes fan out" in rep.targets[0].notes[0]
    assert rep.residual is not None and rep.residual.misfit_targets == (rep.targets[0].name,)
    assert rep.targets[0].axes[0].angle_deg == pytest.approx(centre_deg, abs=0.5)  # the azimuth ridge: no fan
