"""False targets under the side-lobe floor: the residual image (every target's fitted response subtracted).

Scenes are analytic band-limited images built here, independently of sarproc: tapered (10 % tilt over
the band) and skewed responses with a spatial chirp (as backprojected images have), three truth targets,
and one weak scatterer left out of the truth table. A quadratic spectral phase (PHASE) is not yet fitted
well enough for a -50 dB floor.
"""

from __future__ import annotations

import numpy as np
import pytest

from sarproc.quality.metrics import EvaluateParams, check_report, evaluate_image, expectations_from_mapping

RES = (1.0, 0.8)  # theoretical IRW per axis (azimuth, range)
STEP = (0.4, 0.35)
N = (300, 320)
DOPPLER = (0.2 / STEP[0], -0.35 / STEP[1])  # band centres, cycles per unit
SKEW = 0.12  # the range ridge leans on azimuth (a squinted image's skew)
CHIRP = 0.004  # spatial chirp along azimuth, cycles per unit^2 (backprojection's exp(j 2 pi x^2 / lambda R))
TRUTH = [(-22.0, -14.0), (9.3, 11.7), (25.1, -20.4)]
AMPS = [1.0, 0.7 * np.exp(1j), 0.5j]
GHOST = (-30.3, 22.6)  # off-grid, > 20 cells from every target, off their ridges
TILT = 0.1  # azimuth spectrum: amplitude tilt over the band (10 % at its edges)
PHASE = 0.0  # and a quadratic phase, rad at its edges
PARAMS = EvaluateParams(residual=True)


def _azimuth_psf(x):
    """Azimuth response: band 0.886/RES[0] with an amplitude tilt and a quadratic phase over it, as a dense
    midpoint sum of the band's Fourier integral."""
    bw = 0.886 / RES[0]
    f = (np.arange(801) + 0.5) / 801 - 0.5
    spec = (1 + TILT * 2 * f) * np.exp(1j * PHASE * (2 * f) ** 2)
    return (np.exp(2j * np.pi * np.multiply.outer(np.asarray(x) * bw, f)) @ spec) / f.size


def _scene(points, amps):
    a = (np.arange(N[0]) - N[0] // 2) * STEP[0]
    r = (np.arange(N[1]) - N[1] // 2) * STEP[1]
    img = np.zeros(N, dtype=complex)
    peak = abs(_azimuth_psf(np.zeros(1))[0])
    for (ta, tr), amp in zip(points, amps):
        da, dr = a - ta, r - tr
        az = _azimuth_psf(da) / peak * np.exp(1j * np.pi * CHIRP * da**2)
        rg = np.sinc(0.886 / RES[1] * (dr[None, :] + SKEW * da[:, None]))
        img += amp * az[:, None] * rg * np.exp(2j * np.pi * (DOPPLER[0] * da[:, None] + DOPPLER[1] * dr[None, :]))
    return img.astype(np.complex64), [a, r]


@pytest.mark.parametrize("level", [-40.0, -45.0, -50.0])
def test_injected_ghost_is_found_at_its_place_and_level(level):
    img, coords = _scene(TRUTH + [GHOST], AMPS + [10 ** (level / 20)])
    rep = evaluate_image(img, ("azimuth", "range"), coords, RES, TRUTH, names=["A", "B", "C"], params=PARAMS)
    ft = rep.false_target
    assert ft.reference_target == "A"
    assert ft.level_db == pytest.approx(level, abs=1.0)
    for a, dim in enumerate(("azimuth", "range")):
        assert abs(ft.position[dim] - GHOST[a]) <= 2 * RES[a]
    # The guard-window figure stays, and cannot see below the targets' own side lobes.
    assert rep.false_target_guard.level_db > -40.0
    assert rep.residual.floor_db < level
    # --expect false_target_db_max gates the residual figure
    assert check_report(rep, expectations_from_mapping({"false_target_db_max": level + 1.5})) == []
    fails = check_report(rep, expectations_from_mapping({"false_target_db_max": level - 1.5}))
    assert [f.metric for f in fails] == ["false_target_db"]


def test_clean_scene_floor_is_below_minus_50_db():
    img, coords = _scene(TRUTH, AMPS)
    rep = evaluate_image(img, ("azimuth", "range"), coords, RES, TRUTH, params=PARAMS)
    assert rep.residual.floor_db <= -50.0
    assert rep.false_target.level_db <= -50.0
    assert rep.false_target_guard.level_db > -40.0  # what the guard window alone reports
    off = evaluate_image(img, ("azimuth", "range"), coords, RES, TRUTH, params=EvaluateParams(residual=False))
    assert off.residual is None and off.false_target == rep.false_target_guard
    assert off.targets == rep.targets  # the residual changes no target's figures


def test_each_fit_step_factorises_its_bases_once(monkeypatch):
    """A Gauss-Newton step projects the Jacobian off the bases whose amplitudes were just solved: it reuses
    that solve's factorised Gram matrix, one factorisation per set of bases rather than one per solve."""
    from sarproc.quality import lstsq, residual

    counts = {"gram": 0, "amplitudes": 0, "steps": 0}

    class Counted(lstsq.NormalEquations):
        def __init__(self, B: np.ndarray) -> None:
            counts["gram"] += 1
            super().__init__(B)

    amplitudes, step = residual._amplitudes, residual._gauss_newton_step

    def counted_amplitudes(*args):
        counts["amplitudes"] += 1
        return amplitudes(*args)

    def counted_step(*args):
        counts["steps"] += 1
        return step(*args)

    monkeypatch.setattr(residual, "NormalEquations", Counted)
    monkeypatch.setattr(residual, "_amplitudes", counted_amplitudes)
    monkeypatch.setattr(residual, "_gauss_newton_step", counted_step)
    img, coords = _scene(TRUTH, AMPS)
    evaluate_image(img, ("azimuth", "range"), coords, RES, TRUTH, params=PARAMS)
    assert counts["steps"] > 10
    assert counts["gram"] == counts["amplitudes"]


KEYSTONE = 0.02  # azimuth band width grows by this fraction across the range band (a 2 % fractional bandwidth)


def _keystoned_scene(points, amps, n=(240, 256)):
    """Targets whose azimuth band width scales with range frequency (1 + KEYSTONE u, u the range band
    coordinate in (-1/2, 1/2)): a dense sum over range frequency of exact azimuth sincs."""
    a = (np.arange(n[0]) - n[0] // 2) * STEP[0]
    r = (np.arange(n[1]) - n[1] // 2) * STEP[1]
    bw_a, bw_r = 0.886 / RES[0], 0.886 / RES[1]
    u = (np.arange(600) + 0.5) / 600 - 0.5
    img = np.zeros(n, dtype=complex)
    for (ta, tr), amp in zip(points, amps):
        da, dr = a - ta, r - tr
        width = bw_a * (1 + KEYSTONE * u)  # per range frequency
        az = width[None, :] * np.sinc(np.multiply.outer(da, width))  # (n_a, n_u)
        rg = np.exp(2j * np.pi * np.multiply.outer(u * bw_r, dr)) / u.size  # (n_u, n_r)
        img += amp / bw_a * (az @ rg) * np.exp(2j * np.pi * (DOPPLER[0] * da[:, None] + DOPPLER[1] * dr[None, :]))
    return img.astype(np.complex64), [a, r]


def test_keystoned_support_is_fitted_to_a_floor_below_minus_50_db():
    truth = [(-15.0, -10.0), (12.3, 14.1)]
    img, coords = _keystoned_scene(truth, [1.0, 0.6j])
    rep = evaluate_image(img, ("azimuth", "range"), coords, RES, truth, params=PARAMS)
    # with a rectangular support (residual.KEYSTONE_STRIPS = 1) the floor is -47.3 dB: the far azimuth ridges
    assert rep.residual.floor_db <= -50.0
    assert rep.false_target.level_db <= -50.0


@pytest.mark.parametrize("shape", [(40, 7), (9, 30, 12)], ids=["2d", "3d"])
def test_unique_columns_are_numpys_unique_columns(shape):
    """The fits' sample sets deduplicated by flat index are numpy's ``unique(axis=1)``: the same columns in the
    same order, the same inverse, dtype and memory layout (so every fit sees the same samples in the same order
    and its products round alike: a C-ordered copy moved the demo's false target by 1e-9), image edges included."""
    from sarproc.quality.residual import unique_columns

    rng = np.random.default_rng(7)
    for size in (1, 50, 2000):
        points = np.stack([rng.integers(0, n, size) for n in shape])
        points[:, 0] = [n - 1 for n in shape]
        want, want_inverse = np.unique(points, axis=1, return_inverse=True)
        got, inverse = unique_columns(points, shape)
        assert got.dtype == want.dtype and got.strides == want.strides and np.array_equal(got, want)
        assert np.array_equal(inverse, want_inverse.ravel()) and np.array_equal(got[:, inverse], points)


def test_strips_tile_the_range_band_exactly():
    """The range strips' responses add up to the whole band's (half-null-shifted sincs), and a zero
    keystone is the rectangle itself."""
    from sarproc.quality.residual import _shifted_sincs, _strip_factors

    c = [np.linspace(-80, 80, 1001), np.linspace(-60, 61, 1001)]
    assert len(_strip_factors(c, 1, np.array([0.0]))) == 1
    strips = _strip_factors(c, 1, np.array([0.02]))
    assert len(strips) > 8
    for n, whole in enumerate(_shifted_sincs(c[1], 1)):
        np.testing.assert_allclose(sum(s[1][n] for s in strips), whole, atol=1e-9)
    # each strip's azimuth factor is the sinc of its own width, w sinc(w c)
    w = 1 + 0.02 * (0.5 / len(strips) - 0.5)
    np.testing.assert_allclose(strips[0][0][1], w * np.sinc(w * c[0]), atol=1e-12)


@pytest.mark.parametrize("kappa", [np.array([0.015]), np.array([0.02, -0.01])], ids=["2d", "3d"])
def test_closed_form_strip_sum_equals_the_strips(kappa):
    """The keystone's strip sum in closed form (Dirichlet kernels) is the sum of the strips' products."""
    from sarproc.quality.residual import _keystone_product, _strip_factors

    rng = np.random.default_rng(3)
    ndim = len(kappa) + 1
    c = [rng.uniform(-300, 300, 5000) for _ in range(ndim)]
    c[0][:4] = [0.0, 0.5, -0.5, 1e-12]  # on the factors' removable singularity
    strips = _strip_factors(c, 1, kappa)
    for order in [(0,) * ndim, (1,) * ndim, (-1,) + (1,) * (ndim - 1)]:
        want = sum(np.prod([s[a][n + 1] for a, n in enumerate(order)], axis=0) for s in strips)
        got = _keystone_product([ca + n / 2 for ca, n in zip(c, order)], kappa)
        assert np.abs(got - want).max() < 1e-7 * np.abs(want).max()


def test_box_sum_over_orders_equals_the_per_order_products():
    """_keystone_sum (angles shifted per order) is the coefficient sum of _keystone_product, singular
    points included."""
    from sarproc.quality.residual import _keystone_product, _keystone_sum, spectral_orders

    rng = np.random.default_rng(5)
    c = [rng.uniform(-200, 200, (60, 70)) for _ in range(2)]
    c[0].flat[:3] = [0.0, 0.5, -0.5]
    orders = spectral_orders(2, 1, 2)
    coef = rng.normal(size=len(orders)) + 1j * rng.normal(size=len(orders))
    kappa = np.array([0.015])
    want = sum(k * _keystone_product([x + n / 2 for x, n in zip(c, o)], kappa) for o, k in zip(orders, coef))
    got = _keystone_sum(c, orders, coef, kappa)
    assert np.abs(got - want).max() < 1e-10 * np.abs(want).max()


def _own_support_scene(spectra, points, amps, n=(300, 200)):
    """Unskewed responses of peak ``amps`` whose azimuth spectra are given (callables of the frequency in units
    of the image's nominal band 0.886 / RES[0]); range a plain sinc. Dense midpoint sums of the Fourier
    integral."""
    a = (np.arange(n[0]) - n[0] // 2) * STEP[0]
    r = (np.arange(n[1]) - n[1] // 2) * STEP[1]
    bw = 0.886 / RES[0]
    f = (np.arange(2001) + 0.5) / 2001 * 4 - 2  # -2 .. 2 nominal bands
    img = np.zeros(n, dtype=complex)
    for spectrum, (ta, tr), amp in zip(spectra, points, amps):
        spec = spectrum(f)
        az = np.exp(2j * np.pi * np.multiply.outer(a - ta, f * bw)) @ spec
        rg = np.sinc(0.886 / RES[1] * (r - tr))
        img += amp * az[:, None] / abs(spec.sum()) * rg[None, :]
    return img.astype(np.complex64), [a, r]


def test_targets_with_their_own_support_are_fitted():
    """A partly lit target (a third of the nominal band: a sliding spotlight's edge target) and one whose
    band is 30 % wider than nominal under a bell-shaped antenna taper (a stripmap target that sees its whole
    beam passage): the image's band widths cannot model them (a -13 / -22 dB residual beside them before),
    so their widths are searched and their spectra fitted with two orders. Left out of the truth, a -40 dB
    ghost is still found at its place and level."""
    partial = lambda f: ((f > 0.1) & (f < 0.1 + 1 / 3)).astype(float)  # noqa: E731
    bell = lambda f: (np.abs(f) < 0.65) * np.sinc(f / 1.3) ** 4  # noqa: E731  # two-way sinc pattern
    flat = lambda f: (np.abs(f) < 0.5).astype(float)  # noqa: E731
    truth = [(-30.0, -10.0), (20.0, 12.0)]
    img, coords = _own_support_scene([partial, bell], truth, [1.0, 0.8j])
    rep = evaluate_image(img, ("azimuth", "range"), coords, RES, truth, names=["P", "W"])
    assert rep.params.residual  # the default
    assert rep.residual.floor_db <= -40.0
    assert rep.false_target.level_db <= -40.0
    ghost = (5.3, -20.4)
    ghosted, _ = _own_support_scene([partial, bell, flat], truth + [ghost], [1.0, 0.8j, 0.01])
    rep = evaluate_image(ghosted, ("azimuth", "range"), coords, RES, truth, names=["P", "W"])
    ft = rep.false_target
    assert ft.reference_target == "P" and ft.level_db == pytest.approx(-40.0, abs=1.0)
    for a, dim in enumerate(("azimuth", "range")):
        assert abs(ft.position[dim] - ghost[a]) <= 2 * RES[a]


def test_cubes_report_the_guard_window_figure_with_a_note():
    """The residual is not taken on 3D cubes (RESIDUAL_3D_NOTE): the false target is the guard-window
    figure, and the report says why."""
    from sarproc.quality.metrics import RESIDUAL_3D_NOTE

    n, step, res = (40, 48, 44), (0.5, 0.5, 0.5), (1.5, 1.5, 1.5)
    axes = [(np.arange(k) - k // 2) * s for k, s in zip(n, step)]
    truth = [(0.0, 1.0, -2.0)]
    img = np.ones((1, 1, 1), dtype=complex)
    for x, t in zip(np.meshgrid(*axes, indexing="ij"), truth[0]):
        img = img * np.sinc(0.886 / res[0] * (x - t))
    rep = evaluate_image(img.astype(np.complex64), ("elevation", "azimuth", "range"), axes, res, truth)
    assert rep.residual is None and rep.residual_note == RESIDUAL_3D_NOTE
    assert rep.false_target == rep.false_target_guard


def test_a_defocused_targets_misfit_is_not_reported_as_a_ghost(monkeypatch):
    """A target focused badly (a quadratic phase of 2.5 rad at its azimuth band's edges: main lobe 1.27x theory)
    is not the response the ideal model fits; its misfit (-28.9 dB, 3 m from it, on the residual with the main-lobe box
    alone) must not be reported as a false target, and a real ghost beyond its guard window still is, at its
    level. (Stronger defocus spreads side lobes beyond the widened guard window: 4 rad leaves -36 dB there.)"""
    import sys

    here = sys.modules[__name__]
    target, ghost, level = (-40.0, 0.0), (35.0, 10.0), -35.0
    monkeypatch.setattr(here, "PHASE", 2.5)
    blurred, coords = _scene([target], [1.0])
    monkeypatch.setattr(here, "PHASE", 0.0)
    img = blurred + _scene([ghost], [10 ** (level / 20)])[0]
    rep = evaluate_image(img, ("azimuth", "range"), coords, RES, [target], names=["A"], params=PARAMS)
    assert rep.targets[0].axis("azimuth").irw_ratio > 1.25  # the precondition: defocused
    assert rep.residual.misfit_targets == ("A",)
    ft = rep.false_target
    assert ft.level_db == pytest.approx(level, abs=1.0)
    for a, dim in enumerate(("azimuth", "range")):
        assert abs(ft.position[dim] - ghost[a]) <= 2 * RES[a]


GHOSTS = [(-30.3, 22.6), (30.1, 30.3), (-5.2, -40.1)]  # off-grid, apart, off every target's ridges
GHOST_DB = [-40.0, -45.0, -50.0]


def test_every_ghost_over_the_floor_is_listed_in_order():
    """Three ghosts in one image: each is listed at its place and level, strongest first, the first being
    the single false-target figure; the clean image lists none."""
    img, coords = _scene(TRUTH + GHOSTS, AMPS + [10 ** (g / 20) for g in GHOST_DB])
    rep = evaluate_image(img, ("azimuth", "range"), coords, RES, TRUTH, names=["A", "B", "C"], params=PARAMS)
    listed = rep.false_targets
    assert len(listed.entries) == 3 and listed.beyond == 0
    assert listed.threshold_db == pytest.approx(rep.residual.floor_db + listed.margin_db)
    for entry, ghost, level in zip(listed.entries, GHOSTS, GHOST_DB):
        assert entry.level_db == pytest.approx(level, abs=1.0)
        for a, dim in enumerate(("azimuth", "range")):
            assert abs(entry.position[dim] - ghost[a]) <= 2 * RES[a]
            assert coords[a][0] + entry.index[dim] * STEP[a] == pytest.approx(entry.position[dim])
        # the nearest target and its distance in cells
        cells = [np.hypot(*((np.subtract(ghost, t)) / RES)) for t in TRUTH]
        assert entry.nearest_target == "ABC"[int(np.argmin(cells))]
        assert entry.nearest_cells == pytest.approx(min(cells), abs=2.0)
    first, ft = listed.entries[0], rep.false_target
    assert (first.level_db, first.pixel_level_db, first.position) == (ft.level_db, ft.pixel_level_db, ft.position)
    clean, coords = _scene(TRUTH, AMPS)
    rep = evaluate_image(clean, ("azimuth", "range"), coords, RES, TRUTH, names=["A", "B", "C"], params=PARAMS)
    assert rep.false_targets is not None and rep.false_targets.entries == ()
    assert rep.false_target.level_db < rep.false_targets.threshold_db  # the single figure is still given


# Ghosts inside the targets' guard windows (+-20 cells), where the floor is taken: 7-9 cells from A or B off
# their ridges, and one on A's azimuth ridge (the range ridge leans by SKEW) 12 cells out, where A's own side
# lobes stand -31.5 dB before the subtraction. (6 cells out, inside A's fit box, the ghost pulls A's fit: the
# floor rises from -52.4 to -50.5 dB, the ghost still listed.)
GUARD_GHOSTS = {"off A's ridges": (-15.1, -8.3), "off B's ridges": (16.2, 5.1), "on A's azimuth ridge": (-10.0, -15.44)}


@pytest.mark.parametrize(
    "ghosts",
    [
        {"off A's ridges": -45.0},
        {"off A's ridges": -44.0, "off B's ridges": -45.5},  # two of like level: each must leave the floor
        {"on A's azimuth ridge": -42.0},
    ],
    ids=["one", "two of like level", "on a ridge"],
)
def test_ghosts_inside_the_guard_windows_are_listed_and_leave_the_floor(ghosts):
    """A ghost near a target is the strongest residual pixel of that target's guard window: taken as the floor
    it could never stand over it and would not be listed. Set aside, the floor stays the clean image's and
    every ghost is listed at its place and level."""
    places = [GUARD_GHOSTS[g] for g in ghosts]
    img, coords = _scene(TRUTH + places, AMPS + [10 ** (v / 20) for v in ghosts.values()])
    rep = evaluate_image(img, ("azimuth", "range"), coords, RES, TRUTH, names=["A", "B", "C"], params=PARAMS)
    clean, _ = _scene(TRUTH, AMPS)
    floor = evaluate_image(clean, ("azimuth", "range"), coords, RES, TRUTH, params=PARAMS).residual.floor_db
    assert floor <= -50.0
    assert rep.residual.floor_db == pytest.approx(floor, abs=1.0)
    entries = rep.false_targets.entries
    assert len(entries) == len(ghosts)
    for entry, place, level in zip(entries, places, sorted(ghosts.values(), reverse=True)):
        assert entry.level_db == pytest.approx(level, abs=1.0)
        for a, dim in enumerate(("azimuth", "range")):
            assert abs(entry.position[dim] - place[a]) <= 2 * RES[a]


def test_local_maxima_equal_scipys_maximum_filter():
    from scipy.ndimage import maximum_filter

    from sarproc.quality.residual import _local_maxima

    x = np.abs(np.random.default_rng(0).standard_normal((41, 37)))
    x[3:9, 30:] = 0.0  # a flat plateau (every sample its own maximum) reaching the edge
    assert np.array_equal(_local_maxima(x), maximum_filter(x, size=3, mode="nearest") == x)
