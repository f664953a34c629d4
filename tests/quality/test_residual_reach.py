"""The residual image evaluated only where each model can matter (issue 20 item 1, speed).

Each response model is subtracted only on the image blocks where an upper bound of its modulus (its
envelope: sinc side lobes along its ridges, a keystoned support's range ridge fanning out) reaches a
level; elsewhere it is below that level. Checked here against the whole-image reference
(:func:`residual_image`) on models built directly: skewed, chirped, keystoned, tapered.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from sarproc.quality import residual as R
from sarproc.quality.residual import (
    ResponseModel,
    envelope_bound,
    residual_image,
    spectral_orders,
    subtract_models,
)

SHAPE = (700, 760)


def _models(keystone: float) -> list[ResponseModel]:
    rng = np.random.default_rng(7)
    orders = spectral_orders(2, 1, 2)
    out = []
    for pos, skew in [((120.3, 200.7), 0.03), ((400.1, 390.4), -0.02), ((610.6, 650.2), 0.0)]:
        coef = np.zeros(len(orders), dtype=complex)
        coef[np.all(orders == 0, axis=1)] = 1.0
        coef += 0.05 * (rng.normal(size=len(orders)) + 1j * rng.normal(size=len(orders)))  # a taper and phase
        out.append(
            ResponseModel(
                position=np.array(pos),
                ridges=np.array([[1.0, skew], [-0.5 * skew, 1.0]]),
                nulls=np.array([2.2, 2.4]),
                band_centre=np.array([0.1, -0.2]),
                orders=orders,
                coef=coef,
                chirp=np.array([[2e-4, 0.0], [0.0, 0.0]]),
                kappa=np.array([keystone]),
            )
        )
    return out


@pytest.mark.parametrize("keystone", [0.0, 0.003, 0.02])
def test_envelope_bounds_each_model_everywhere(keystone):
    """|model| <= its envelope bound at every pixel (over a box the bound only grows)."""
    grid = np.stack([g.ravel() for g in np.meshgrid(*[np.arange(n) for n in SHAPE], indexing="ij")], axis=1)
    for model in _models(keystone):
        value = np.abs(residual_image(np.zeros(SHAPE), [model])).ravel()
        bound = envelope_bound(model, grid.astype(float))
        assert np.all(value <= bound * (1 + 1e-9) + 1e-14)


def _counted_samples(monkeypatch) -> list[int]:
    """The samples of each box :func:`R._model_on_box` evaluates from now on, appended to the list returned."""
    evaluated: list[int] = []
    box = R._model_on_box

    def counted(slices, model):
        evaluated.append(math.prod(s.stop - s.start for s in slices))
        return box(slices, model)

    monkeypatch.setattr(R, "_model_on_box", counted)
    return evaluated


@pytest.mark.parametrize("keystone", [0.0, 0.003, 0.02])
def test_subtraction_above_a_level_is_the_whole_image_to_that_level(keystone, monkeypatch):
    models = _models(keystone)
    whole = residual_image(np.zeros(SHAPE), models)
    evaluated = _counted_samples(monkeypatch)
    for level_db in (-60.0, -80.0):
        level = 10 ** (level_db / 20)
        evaluated.clear()
        out = np.zeros(SHAPE, dtype=complex)
        subtract_models(out, models, level)
        assert np.abs(out - whole).max() <= len(models) * level
        # the ridges and a box: a fraction of the three models' whole-image evaluations (a strong keystone's
        # strips add ridges of their own across the image, about -90 dB here: evaluated where they reach)
        if keystone < 0.01 or level_db > -70:
            assert sum(evaluated) < 0.5 * len(models) * math.prod(SHAPE)
        # and what is left below the level, in a second call, completes it
        subtract_models(out, models, 1e-12, above=level)
        assert np.abs(out - whole).max() <= len(models) * 1e-12


@pytest.mark.parametrize("ndim", [2, 3])
def test_compiled_keystone_columns_are_the_numpy_reference(ndim):
    """The kernel's strip sums, singular points included, equal the numpy angle-addition reference."""
    from sarproc.quality.residual import _keystone_columns, _strip_count
    from sarproc.quality.residual_kernels import keystone_columns

    rng = np.random.default_rng(3)
    orders = spectral_orders(ndim, 1, 1 if ndim == 3 else 2)
    c = rng.uniform(-150, 150, size=(ndim, 4000))
    c[0, :20] = 0.5  # on a removable singularity of an order (c + n / 2 = 0)
    c[0, 20:40] = 1e-9
    c[-1, 40:60] = 0.0
    for kappa in (np.full(ndim - 1, 0.003), np.linspace(0.02, -0.01, ndim - 1)):
        want = np.stack(_keystone_columns(list(c), orders, kappa))
        got = keystone_columns(c, orders.astype(np.int64), kappa, _strip_count(kappa))
        # to rounding; at the singular points both take the limit at a 1e-7 offset, which cancels to ~1e-6
        # of the (small) value there
        np.testing.assert_allclose(got[:, 60:], want[:, 60:], rtol=0, atol=1e-13 * np.abs(want).max())
        np.testing.assert_allclose(got[:, :60], want[:, :60], rtol=0, atol=1e-8 * np.abs(want).max())


def test_weighted_targets_are_fitted_with_the_window_orders(monkeypatch):
    """Hamming-weighted responses (their theory says so: PSLR -42.7 dB) are modelled with two spectral
    orders, which follow the window's cosine; one order leaves the window's misfit."""
    from sarproc.quality import metrics, residual
    from sarproc.quality.metrics import EvaluateParams, evaluate_image

    step, n, bw = 0.4, (240, 256), 1.0  # band 1 cycle/m, 2.5 samples per null
    f = (np.arange(801) + 0.5) / 801 - 0.5
    window = 0.54 + 0.46 * np.cos(2 * np.pi * f)

    def psf(x):
        return (np.exp(2j * np.pi * np.multiply.outer(x * bw, f)) @ window) / window.sum()

    axes = [(np.arange(k) - k // 2) * step for k in n]
    truth = [(-10.3, -12.1), (9.7, 14.6)]
    img = sum(a * np.outer(psf(axes[0] - t[0]), psf(axes[1] - t[1])) for t, a in zip(truth, [1.0, 0.6j]))
    params = EvaluateParams(residual=True, irw_factor=1.30)  # Hamming IRW 1.30 / B: its theory PSLR -42.7 dB

    def run():
        return evaluate_image(img, ("azimuth", "range"), axes, (1.30 / bw,) * 2, truth, params=params)

    two = run()
    monkeypatch.setattr(metrics, "WEIGHTED_PSLR_DB", -np.inf)  # the rule off: residual_orders 1
    # a lone target's misfit then still raises its own orders (residual.WIDTH_SEARCH_MISFIT): same floor
    repaired = run()
    assert two.residual.orders > repaired.residual.orders
    assert two.residual.floor_db < -45.0 and two.false_target.level_db < -45.0  # bp_hamming's gate
    assert repaired.residual.floor_db < -45.0 and repaired.false_target.level_db < -45.0
    monkeypatch.setattr(residual, "WIDTH_SEARCH_MISFIT", np.inf)  # and that repair off: one order
    one = run()
    # one order leaves the window's misfit beside each target (over residual.MISFIT_DB of its peak): both are
    # named as responses the model does not fit, their guard windows out of the search
    assert one.residual.misfit_targets == ("T0", "T1") and two.residual.misfit_targets == ()
    monkeypatch.setattr(residual, "MISFIT_DB", np.inf)  # and that rule off: the misfit is the floor
    assert run().residual.floor_db > two.residual.floor_db + 10.0


def test_targets_left_out_of_a_subset_are_no_residual_false_targets():
    """--targets A: B is not measured, so not modelled; its guard window stays out of the residual search
    (its side lobes are still there), as the guard-window figure keeps it out."""
    from sarproc.quality.metrics import EvaluateParams, evaluate_image

    axes = [(np.arange(k) - k // 2) * 0.4 for k in (200, 220)]
    a, b = (-12.3, -10.1), (13.7, 15.2)
    img = sum(
        amp * np.outer(np.sinc(0.886 * (axes[0] - t[0])), np.sinc(0.886 * (axes[1] - t[1])))
        for t, amp in zip((a, b), (1.0, 0.8j))
    )
    params = EvaluateParams(residual=True)
    rep = evaluate_image(img, ("azimuth", "range"), axes, (1.0, 1.0), [a], names=["A"], params=params, other_truth=[b])
    # without its guard window the residual read B's first side lobe, -19.8 dB; now what is left of B is
    # its ridges beyond that window, which the guard-window figure sees as well
    assert rep.false_target.level_db < -30.0 and rep.residual.floor_db < -45.0
    assert rep.false_target.level_db <= rep.false_target_guard.level_db + 0.5
    assert any(abs(rep.false_target.position[d] - x) > params.guard_cells for d, x in zip(("azimuth", "range"), b))


@pytest.mark.parametrize("kappa", [0.003, 0.015, 0.08])
def test_compiled_box_sum_is_the_columns_summed(kappa):
    """The box kernel (rotations along each row, the orders summed inside) gives the coefficient-weighted
    sum of the per-point kernel's strip sums over a skewed box, singular points included."""
    from sarproc.quality.residual import _strip_count, spectral_orders
    from sarproc.quality.residual_kernels import keystone_box_sum, keystone_columns

    orders = spectral_orders(2, 2, 3).astype(np.int64)
    coef = np.random.default_rng(3).normal(size=(len(orders), 2)) @ np.array([1.0, 1j])
    k, strips = np.array([kappa]), _strip_count(np.array([kappa]))
    c0, d_row, d_col = np.array([-20.0, -31.5]), np.array([0.5, 0.04]), np.array([0.0, 0.41])  # rows hit c_az = -n/2
    rows, cols = 90, 150
    got = keystone_box_sum(c0, d_row, d_col, rows, cols, orders, coef, k, strips)
    ii, jj = np.meshgrid(np.arange(rows), np.arange(cols), indexing="ij")
    pts = np.stack([c0[a] + ii.ravel() * d_row[a] + jj.ravel() * d_col[a] for a in range(2)])
    want = (coef @ keystone_columns(pts, orders, k, strips)).reshape(rows, cols)
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-11 * np.abs(want).max())


@pytest.mark.parametrize("kappa", [0.003, 0.015, 0.08])
def test_compiled_warped_box_sum_is_the_columns_summed(kappa):
    """The warped box kernel (ridge coordinates quadratic in the box's indices; rotations whose steps turn along
    each row) gives the coefficient-weighted sum of the per-point kernel's strip sums over a skewed box, singular
    points included, times the carrier whose phase is quadratic in the box's indices."""
    from sarproc.quality.residual import _strip_count, spectral_orders
    from sarproc.quality.residual_kernels import keystone_columns, keystone_warped_box_sum

    orders = spectral_orders(2, 2, 3).astype(np.int64)
    coef = np.random.default_rng(3).normal(size=(len(orders), 2)) @ np.array([1.0, 1j])
    k, strips = np.array([kappa]), _strip_count(np.array([kappa]))
    c0, d_row, d_col = np.array([-20.0, -31.5]), np.array([0.5, 0.04]), np.array([0.0, 0.41])  # rows hit c_az = -n/2
    w_rr, w_rc, w_cc = np.array([0.0, 2e-4]), np.array([3e-4, -1e-4]), np.array([0.0, 5e-4])
    rows, cols = 90, 150
    carrier = np.array([0.3, 0.2, -0.7, 1e-4, -2e-4, 3e-4])  # the carrier's phase in 1, i, j, i^2, i j, j^2
    got = keystone_warped_box_sum(c0, d_row, d_col, w_rr, w_rc, w_cc, rows, cols, orders, coef, k, strips, carrier)
    i, j = (x.ravel().astype(float) for x in np.meshgrid(np.arange(rows), np.arange(cols), indexing="ij"))
    pts = np.stack(
        [c0[a] + i * d_row[a] + j * d_col[a] + i * i * w_rr[a] + i * j * w_rc[a] + j * j * w_cc[a] for a in range(2)]
    )
    phase = carrier @ np.stack([np.ones_like(i), i, j, i * i, i * j, j * j])
    want = (coef @ keystone_columns(pts, orders, k, strips) * np.exp(1j * phase)).reshape(rows, cols)
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-11 * np.abs(want).max())


def test_a_warped_keystoned_model_on_a_box_is_its_values_at_every_sample(monkeypatch):
    """A warped, keystoned 2D model (what evaluate subtracts from pfa2's images) on an image box through the
    warped box kernel equals :func:`model_values` at every sample of the box to rounding, range-edge bow included,
    without the per-sample kernel's columns (samples x orders)."""
    from helpers import model_on_every_sample, warped_model
    from sarproc.quality import residual_aot
    from sarproc.quality.residual import _model_on_box

    rng = np.random.default_rng(7)
    for curvature in (0.0, -0.04):
        model = warped_model(rng, curvature=curvature)
        box = (slice(3, 140), slice(20, 230))
        want = model_on_every_sample(box, model)
        with monkeypatch.context() as m:
            m.setattr(residual_aot, "keystone_columns", None)  # not called on the box
            got = _model_on_box(box, model)
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-12 * np.abs(model.coef).sum())


def _richardson(f, h: float) -> np.ndarray:
    """f'(0) from f(+-h), f(+-2h), f(+-3h): sixth order, for the reference of the analytic derivatives."""
    return (45 * (f(h) - f(-h)) - 9 * (f(2 * h) - f(-2 * h)) + (f(3 * h) - f(-3 * h))) / (60 * h)


@pytest.mark.parametrize("ndim", [2, 3])
@pytest.mark.parametrize("keystone", [0.0, 0.03, -0.15])
def test_analytic_shape_derivatives_are_the_strip_sums_derivatives(ndim, keystone):
    """The compiled derivatives of a coefficient-weighted strip sum with respect to the ridge coordinates and
    the keystone (what the group fits' Jacobian uses instead of central differences) equal high-order
    differences of the strip sums: at ordinary points, near a Dirichlet pole and the last axis' zero
    (Taylor series), and within 1e-3 of a keystoned axis' zero, on it included (interpolated)."""
    from sarproc.quality.residual import _strip_count
    from sarproc.quality.residual_kernels import keystone_columns, keystone_derivatives

    rng = np.random.default_rng(5)
    orders = spectral_orders(ndim, 1, 2).astype(np.int64)
    coef = rng.normal(size=len(orders)) + 1j * rng.normal(size=len(orders))
    kappa = np.linspace(keystone, 0.5 * keystone, ndim - 1)
    strips = _strip_count(kappa)
    far = rng.uniform(-40, 40, size=(ndim, 2000))
    far[:, :200] = rng.uniform(-3, 3, size=(ndim, 200))
    far[-1, 200:230] = rng.uniform(-1e-4, 1e-4, 30)  # the last axis' sinc at its centre
    far[-1, 230:250] = 0.5 * strips + rng.uniform(-1e-3, 1e-3, 20)  # near a pole of the Dirichlet kernel
    near = rng.uniform(-3, 3, size=(ndim, 60))
    near[0] = 0.5 + rng.uniform(-1e-3, 1e-3, 60)  # order -1's keystoned factor within 1e-3 of its zero
    near[0, :10] = 0.5
    # the references' steps: small where the strip sums are accurate, larger near the zeros (where they cancel)
    for c, h in ((far, 1e-5), (near, 2e-2)):
        got = keystone_derivatives(c, orders, coef, kappa, strips)

        def value(cc, k=kappa):
            return coef @ keystone_columns(cc, orders, k, strips)

        want = [_richardson(lambda t, a=a, c=c: value(c + t * np.eye(ndim)[:, a : a + 1]), h) for a in range(ndim)]
        want += [_richardson(lambda t, a=a, c=c: value(c, kappa + t * np.eye(ndim - 1)[a]), h) for a in range(ndim - 1)]
        for row, ref in zip(got, want):
            np.testing.assert_allclose(row, ref, rtol=0, atol=1e-6 * np.abs(ref).max())


def test_the_search_leaves_out_each_main_lobe_in_its_own_cells():
    """A weighted target's main lobe spans more of the image's cells (Hamming: IRW 1.30 / B against the image's
    0.886 / B, first nulls at 2 / B): the false-target search leaves out +-exclusion_cells of its own IRW, so the
    skirt of its main lobe (where a model's misfit of the lobe itself shows) is not searched. Bp_hamming's cubic
    x32 image read -42.8 dB there before, inside the main lobe's first nulls."""
    from types import SimpleNamespace

    from sarproc.quality.metrics import EvaluateParams, _make_axes

    step, irw = 0.25, 0.886
    axes = _make_axes((81, 81), ("azimuth", "range"), [np.arange(81) * step] * 2, (irw, irw), 0.886)
    centre = np.array([40, 40])

    def report(own_irw):
        cut = [SimpleNamespace(axis=a, irw_theory=own_irw, irw_ratio=1.0) for a in ("azimuth", "range")]
        return SimpleNamespace(axes=cut, peak_amplitude=1.0)

    def searched(own_irw, cells):
        truth = np.array([[10.0, 10.0]])
        search, _ = R._search_masks((81, 81), axes, truth, [centre], [report(own_irw)], EvaluateParams())
        k = int(round(cells * irw / step))
        return bool(search[40 + k, 40 + k])

    hamming = 1.30 / 0.886 * irw
    assert R.own_cell_broadening(report(hamming), axes) == pytest.approx(1.30 / 0.886)
    assert searched(irw, 2.6) and not searched(hamming, 2.6)  # inside the Hamming lobe's +-2 own cells
    assert searched(hamming, 3.5)  # beyond them
    assert R.own_cell_broadening(report(0.8 * irw), axes) == 1.0  # a finer own theory never narrows the box


@pytest.mark.parametrize(
    ("pslr_db", "requested", "orders"),
    [
        (-13.26, 1, 1),
        (-31.5, 1, 2),
        (-42.7, 1, 2),
        (-46.0, 1, 2),
        (-48.2, 1, 4),
        (-55.3, 1, 4),
        (-300.0, 1, 4),
        (-42.7, 4, 4),
    ],
)
def test_the_theory_s_side_lobe_depth_picks_the_orders(pslr_db, requested, orders):
    """One more order per 16.7 dB under the sinc's side lobes (unweighted 1, Hann and Hamming 2), and four for
    anything deeper than two such steps (a Gaussian beam under Hamming: three leave -46..-48 dB on the
    campaign's scenes 1, 4 and 15): the deepest axis of any target decides."""
    from sarproc.quality.metrics import AxisMetrics, TargetReport, theory_residual_orders

    def axis(name: str, pslr: float | None) -> AxisMetrics:
        return AxisMetrics(name, 1.0, 1.0, 1.0, -13.0, -10.0, 2.0, 0.0, 0.0, 0.0, 0.0, 0.0, pslr_theory_db=pslr)

    sinc = TargetReport("A", 1.0, 0.0, (0, 0), False, (axis("azimuth", None), axis("range", -13.26)))
    weighted = TargetReport("B", 0.5, 0.0, (9, 9), False, (axis("azimuth", pslr_db), axis("range", -13.26)))
    assert theory_residual_orders([sinc, weighted], requested) == orders
    assert theory_residual_orders([sinc], requested) == requested


def _warped_models() -> list[ResponseModel]:
    """:func:`_models` with a small keystone and a warp of the size pfa2's two-step images need (002 small's fits:
    |W| ~ 5e-5 per sample^2, i.e. a ridge bent by a null 140 samples from the peak)."""
    import dataclasses

    warp = np.array([[[3e-6, -5e-5], [-5e-5, -2e-5]], [[5.6e-5, -1e-6], [-1e-6, 3e-6]]])
    return [dataclasses.replace(m, warp=warp * s) for m, s in zip(_models(3e-4), (1.0, -0.7, 0.5))]


def test_warped_envelope_bound_holds_over_each_block():
    """Over each block of the grid :func:`subtract_models` uses, a warped model's modulus stays under its bound,
    now taken from its exact coordinate range over the block (:func:`R._warped_box_range`)."""
    edges, lo, hi = R._block_grid(SHAPE)
    grid = tuple(len(e) - 1 for e in edges)
    for model in _warped_models():
        value = np.abs(residual_image(np.zeros(SHAPE), [model]))
        bound = envelope_bound(model, lo.astype(float), hi.astype(float)).reshape(grid)
        for i, j in np.ndindex(*grid):
            block = value[edges[0][i] : edges[0][i + 1], edges[1][j] : edges[1][j + 1]]
            assert block.max() <= bound[i, j] * (1 + 1e-9) + 1e-14


def test_warped_models_are_subtracted_where_they_reach(monkeypatch):
    """Warped models are evaluated on the blocks their ridges reach, not on every block their warp could bend
    them to (|W| times the block's farthest |x|^2 from the peak, the bound before session 37, took in most
    of the image), :data:`R.WARPED_REACH_DB` deeper: against the whole image fewer samples leave less."""
    models = _warped_models()
    whole = residual_image(np.zeros(SHAPE), models)
    evaluated = _counted_samples(monkeypatch)
    level = 10 ** (-60.0 / 20)
    out = np.zeros(SHAPE, dtype=complex)
    subtract_models(out, models, level)
    error = np.abs(out - whole).max()
    assert error <= len(models) * level * 10 ** (R.WARPED_REACH_DB / 20)  # what the bound guarantees
    # what it gives here: 0.18 of the level on 0.180 of the three models' whole-image evaluations; with the
    # bound before, at the level itself, 0.43 on 0.200
    assert error < 0.3 * level
    assert sum(evaluated) < 0.19 * len(models) * math.prod(SHAPE)
