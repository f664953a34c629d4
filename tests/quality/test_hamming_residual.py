"""The residual image of a Hamming-weighted response (issue 20 item 1: clean scenes floor at -50 dB or below).

configs/bp_hamming.yaml (backproject with Hamming windows in range and azimuth) floored at -48.67 dB, 3 m from O,
while every other backprojected clean config reached -50 dB. A Hamming window on both axes has the outer product
of the axes' cosine series as its spectrum: orders (0, +-2) on each axis, so (+-2, +-2) at the corners with
0.23^2 = 0.053 of weight against 0.54^2 = 0.29 at the centre. The response models' orders were capped at
sum |n_a| <= 3 and left those corners out: the model's own error, measured on O alone (-49.26 dB on the
diagonal, 3 m from O). With the corners in (residual.residual_model_orders: 25 orders, not 21) O alone floors
at -68.55 dB and the scene at -67.75 dB. The bound -60 dB: the model is exact for the analytic response (the
first test); what is left on the backprojected one is its departure from a rectangular support, 8.5 dB under
the bound; the capped basis' -49.3 dB is 10.7 dB over it.
"""

from __future__ import annotations

import copy
import itertools
from pathlib import Path

import numpy as np
import pytest
import yaml

from sarproc.focus.backprojection import BackprojectParams, backproject
from sarproc.quality import metrics
from sarproc.quality.metrics import EvaluateParams, evaluate_product
from sarproc.quality.residual import residual_false_target, residual_model_orders, response_basis, spectral_orders
from sarproc.simulation.scene import scene_from_mapping
from sarproc.simulation.simulate import simulate

CONFIG = yaml.safe_load((Path(__file__).resolve().parents[2] / "configs" / "bp_hamming.yaml").read_text())


def _hamming_response(c: np.ndarray) -> np.ndarray:
    """A Hamming-weighted band's response at c nulls (peak 0.54): 0.54 sinc(c) + 0.23 (sinc(c + 1) + sinc(c - 1))."""
    return 0.54 * np.sinc(c) + 0.23 * (np.sinc(c + 1) + np.sinc(c - 1))


def _fit_db(orders: np.ndarray) -> float:
    """Strongest residual (dB of the peak) of the least-squares fit of the separable 2D Hamming response by the
    basis of ``orders``, on +-6 nulls (the fit box) sampled 0.45 nulls apart."""
    x = np.arange(-6.0, 6.0 + 1e-9, 0.45)
    X, Y = np.meshgrid(x, x, indexing="ij")
    y = (_hamming_response(X) * _hamming_response(Y)).ravel()
    points = np.stack([X.ravel(), Y.ravel()])
    basis = response_basis(points, [0.0, 0.0], np.eye(2), [1.0, 1.0], [0.0, 0.0], orders)
    coef = np.linalg.lstsq(basis, y, rcond=None)[0]
    return float(20 * np.log10(np.abs(y - basis @ coef).max() / np.abs(y).max()))


def test_two_orders_hold_the_corners_of_a_window_on_both_axes():
    orders = residual_model_orders(2, 2)
    corners = set(itertools.product((-2, 2), repeat=2))
    assert corners <= {tuple(n) for n in orders}
    assert len(orders) == 25
    assert _fit_db(orders) < -150.0  # exact: the response is in the basis' span
    capped = spectral_orders(2, 2, 3)  # the cap before: the corners left out
    assert _fit_db(capped) > -45.0  # measured -42.7 dB at (2, 2) nulls
    # one order and 3D cubes keep their cap; four orders already hold the corners (cap 5)
    assert len(residual_model_orders(2, 1)) == len(spectral_orders(2, 1, 2))
    assert len(residual_model_orders(2, 4)) == len(spectral_orders(2, 4, 5))
    assert len(residual_model_orders(3, 1)) == len(spectral_orders(3, 1, 1))


def _report(names: list[str]):
    """evaluate's report of configs/bp_hamming.yaml with only ``names``, and the residual's response models."""
    config = copy.deepcopy(CONFIG)
    params = BackprojectParams(**config.pop("backproject"))
    config["targets"]["points"] = [p for p in config["targets"]["points"] if p["name"] in names]
    image = backproject(simulate(scene_from_mapping(config)), params)
    fitted = []

    def spy(data, models, *args, **kwargs):
        fitted.extend(models)
        return residual_false_target(data, models, *args, **kwargs)

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(metrics, "residual_false_target", spy)
        return evaluate_product(image, EvaluateParams()), fitted


@pytest.mark.parametrize(("names", "bound_db"), [(["O"], -60.0), (["O", "P", "Q"], -60.0)])
def test_the_hamming_scene_floors_under_the_bound(names, bound_db):
    """O alone (the model's own error: -49.26 dB with the corners capped, -68.55 dB with them) and the whole of
    configs/bp_hamming.yaml (-48.67 -> -67.75 dB floor, residual false target -48.65 -> -66.17 dB)."""
    report, _ = _report(names)
    assert report.residual.orders == 25
    assert report.residual.misfit_targets == ()
    assert report.residual.floor_db <= bound_db
    assert report.false_target.level_db <= bound_db
    assert report.false_targets is not None and report.false_targets.entries == ()


def test_the_fit_finds_the_window_itself():
    """For the right reason: O's fitted orders are Hamming x Hamming's, relative to the centre (0, 0) 0.23 / 0.54 =
    0.426 at (0, +-2) and (+-2, 0), 0.181 at the corners, measured 0.4257..0.4269 and 0.1816..0.1822 (phases within
    0.04 rad), every other order under 2 %. Without the corners the fit made up for them with odd orders 0.7 to 2.2
    times the centre's, alternating in sign."""
    _, models = _report(["O"])
    (model,) = models
    by_order = {tuple(int(k) for k in n): c for n, c in zip(model.orders, model.coef)}
    centre = by_order[(0, 0)]
    edge, corner = 0.23 / 0.54, (0.23 / 0.54) ** 2
    for n, c in by_order.items():
        expected = {0: 1.0, 2: edge, 4: corner}[abs(n[0]) + abs(n[1])] if all(k in (0, 2, -2) for k in n) else 0.0
        assert abs(c / centre - expected) < 0.02, (n, c / centre, expected)
