"""The residual's response-model fits converge: the floor and the false target they report do not depend on
the support-shape derivatives (analytic, or central differences and their step) nor on the stopping
tolerance (issue 20).

Before the fits ran to convergence (a capped Gauss-Newton with forward differences and a keystone strip
count that jumped with the keystone), halving the step moved an2012_exp1_small's floor by 0.33 dB.
"""

from __future__ import annotations

import numpy as np
import pytest

import sarproc.quality.residual as residual
from sarproc.quality.metrics import evaluate_image
from tests.quality.test_residual import AMPS, GHOST, PARAMS, RES, TRUTH, _keystoned_scene, _scene

STABLE_DB = 0.05


def _figures(img, coords, truth):
    rep = evaluate_image(img, ("azimuth", "range"), coords, RES, truth, params=PARAMS)
    return rep.residual.floor_db, rep.false_target.level_db


def _scenes():
    yield "tapered, skewed, chirped, ghost at -45 dB", *_scene(TRUTH + [GHOST], AMPS + [10 ** (-45 / 20)]), TRUTH
    truth = [(-15.0, -10.0), (12.3, 14.1)]
    yield "keystoned", *_keystoned_scene(truth, [1.0, 0.6j]), truth


@pytest.mark.parametrize("scene", list(_scenes()), ids=lambda s: s[0])
def test_floor_and_false_target_do_not_depend_on_where_the_fit_stops(scene, monkeypatch):
    _, img, coords, truth = scene
    base = _figures(img, coords, truth)
    for changes in (
        {"FIT_TOLERANCE": residual.FIT_TOLERANCE / 1000},
        # the support shape's central differences (the numpy reference's) instead of the analytic derivatives
        {"ANALYTIC_SHAPE": False},
        {"ANALYTIC_SHAPE": False, "FD_STEP": residual.FD_STEP / 2},
        {"ANALYTIC_SHAPE": False, "FD_STEP": residual.FD_STEP * 2},
    ):
        with monkeypatch.context() as m:
            for name, value in changes.items():
                m.setattr(residual, name, value)
            moved = _figures(img, coords, truth)
        np.testing.assert_allclose(moved, base, atol=STABLE_DB, err_msg=str(changes))


@pytest.mark.parametrize("scene", list(_scenes()), ids=lambda s: s[0])
def test_analytic_shape_derivatives_end_where_central_differences_do(scene, monkeypatch):
    """The fits with the analytic width and keystone derivatives reach the figures of the central
    differences' fits to a thousandth of a dB (a faster Jacobian, the same minimum)."""
    _, img, coords, truth = scene
    analytic = _figures(img, coords, truth)
    monkeypatch.setattr(residual, "ANALYTIC_SHAPE", False)
    np.testing.assert_allclose(analytic, _figures(img, coords, truth), atol=1e-3)


def test_the_strip_count_does_not_jump_with_the_keystone():
    """A keystoned support's strip count is one constant: the model is smooth in the keystone, so that the
    fit's derivatives with respect to it exist."""
    counts = {residual._strip_count(np.array([k])) for k in (1e-6, 1e-4, 3e-3, 0.01, 0.2)}
    assert counts == {residual.KEYSTONE_STRIPS}


def test_a_fit_its_model_cannot_describe_stops_where_longer_fits_end(monkeypatch):
    """Targets drowned in noise (their fits' misfit above HOPELESS_MISFIT): the fits stop once they stop
    moving instead of running to FIT_MAX_STEPS, and their figures are those of fits allowed twice the steps
    (measured 0.0075 dB apart), as close as the capped fits of the code before are (0.05 dB)."""
    img, coords = _scene(TRUTH, AMPS)
    rng = np.random.default_rng(1)
    img = img + (0.05 * (rng.standard_normal(img.shape) + 1j * rng.standard_normal(img.shape))).astype(np.complex64)
    steps = [0]
    step = residual._gauss_newton_step

    def counted(*args):
        steps[0] += 1
        return step(*args)

    monkeypatch.setattr(residual, "_gauss_newton_step", counted)

    def run():
        steps[0] = 0
        return _figures(img, coords, TRUTH), steps[0]

    stopped, n_stopped = run()
    with monkeypatch.context() as m:
        m.setattr(residual, "HOPELESS_MISFIT", np.inf)  # the code before: on to FIT_MAX_STEPS
        capped, n_capped = run()
        m.setattr(residual, "FIT_MAX_STEPS", 2 * residual.FIT_MAX_STEPS)
        longer, _ = run()
    assert n_stopped < 0.6 * n_capped  # 240 against 450
    np.testing.assert_allclose(stopped, longer, atol=0.02)
    # nearer than where the cap stopped them (0.0075 against 0.05 dB)
    assert np.abs(np.subtract(stopped, longer)).max() < np.abs(np.subtract(capped, longer)).max()


def test_a_steady_step_ratio_is_taken_in_one_stretched_step():
    """Along a step, the misfit's parabola through its value before and after (the slope being the
    Gauss-Newton prediction's) has its minimum where :func:`residual._stretch` says: twice the step where the
    misfit fell by 1.5 times the predicted decrease (the curvature half the Gauss-Newton one: each step goes
    half the way, as the demo's fits did), the step itself where it fell as predicted."""
    cost, predicted = 10.0, 1.0
    assert residual._stretch(cost, cost - 1.5 * predicted, predicted, 1.0) == pytest.approx(2.0)
    assert residual._stretch(cost, cost - predicted, predicted, 1.0) == pytest.approx(1.0)
    # measured on a step already twice as long, the same parabola
    assert residual._stretch(cost, cost - 4 * predicted + 4 * 0.5 * predicted, predicted, 2.0) == pytest.approx(2.0)
    assert residual._stretch(cost, cost - 2.5 * predicted, predicted, 1.0) == np.inf  # no minimum: never stretched


def test_linearly_converging_fits_take_fewer_steps_to_the_same_parameters(monkeypatch):
    """A simulated, backprojected scene with the continuous chirp's pedestal (the demo's waveform): its fits
    leave a residual the model cannot remove, and Gauss-Newton's steps fall short of the minimum by a steady
    fraction (the misfit's curvature along them below the Gauss-Newton one), so the fits converged linearly:
    the slowest took 12 steps (the code before). Stretched by the parabola along the previous steps once two of
    them agree, it takes 8; every fit's parameters stay within 1e-7 of those of the same fit run to
    1e-14 of its misfit (1.7e-8 before, 1.1e-8 now for the slowest fit), its amplitudes within 5e-7 (2.2e-7 before,
    2.2e-8 now)."""
    from sarproc.focus.backprojection import backproject
    from sarproc.quality.metrics import EvaluateParams, evaluate_product
    from sarproc.simulation.scene import scene_from_mapping
    from sarproc.simulation.simulate import simulate
    from tests.quality.test_residual_simulated import PARAMS as BP_PARAMS, TARGETS, _scene as bp_scene

    image = backproject(simulate(scene_from_mapping(bp_scene(TARGETS, "continuous"))), BP_PARAMS)
    calls, steps = [], [0]
    fit, step = residual._fit_group, residual._gauss_newton_step

    def counted(*args):
        steps[0] += 1
        return step(*args)

    def recorded(*args, **kwargs):
        calls.append((args, kwargs))
        return fit(*args, **kwargs)

    monkeypatch.setattr(residual, "_gauss_newton_step", counted)
    with monkeypatch.context() as m:
        m.setattr(residual, "_fit_group", recorded)
        evaluate_product(image, EvaluateParams(residual=True))
    assert len(calls) >= 6

    def run(args, kwargs):
        steps[0] = 0
        coef, f_c, K, shape = fit(*args, **kwargs)
        theta = np.concatenate([np.ravel(f_c), np.ravel(K)] + [np.ravel(x) for s in shape for x in s])
        return steps[0], theta, coef

    slowest = 0
    for args, kwargs in calls:
        n, theta, coef = run(args, kwargs)
        with monkeypatch.context() as m:
            m.setattr(residual, "FIT_TOLERANCE", 1e-14)
            m.setattr(residual, "FIT_CRAWL", 1e-13)
            m.setattr(residual, "FIT_MAX_STEPS", 400)
            _, theta_ref, coef_ref = run(args, kwargs)
        slowest = max(slowest, n)
        np.testing.assert_allclose(theta, theta_ref, rtol=0, atol=1e-7)
        assert np.abs(coef - coef_ref).max() <= 5e-7 * np.abs(coef_ref).max()
    assert slowest <= 9  # 12 before
