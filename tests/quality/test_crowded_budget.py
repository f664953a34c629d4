"""evaluate on crowded targets: no joint response-model fit over residual.RESIDUAL_BUDGET (docs/cli.md, row 9b).

The Session 41 new-user trial's L-band scene (1.4 GHz, 150 MHz, 5 deg squint, 3 s at 3 km, ground_los, pfa2
plain with a Hamming range window) with a 6 x 6 grid of targets 12 m apart at 0 dB SNR: every target's fit box
overlaps its neighbours', so the residual fitted all 36 jointly, one least squares of 26 379 rows x 900 columns
at each of its Gauss-Newton steps; evaluate ran 16 CPU-minutes without finishing. Over the budget the residual
is not taken: the false target is the guard-window figure and the report says why.
"""

from __future__ import annotations

import numpy as np
import pytest

from sarproc.quality import metrics, residual
from sarproc.quality.metrics import EvaluateParams, evaluate_image
from sarproc.quality.residual import CrowdedGroup, FitStart, fit_response_models

BUDGET = 1e9  # rows x columns^2, as residual.RESIDUAL_BUDGET


def _pair() -> tuple[np.ndarray, list[FitStart], np.ndarray]:
    """Two unit sinc responses 4 nulls apart in azimuth (2 samples a null): their fit boxes overlap, one group."""
    n = np.arange(64) - 32.0
    a, r = np.meshgrid(n, n, indexing="ij")
    img = np.zeros(a.shape, dtype=complex)
    found = []
    for pa, amp in ((-4.0, 1.0), (4.0, 0.8j)):
        img += amp * np.sinc((a - pa) / 2) * np.sinc(r / 2)
        found.append(FitStart(position=np.array([pa + 32, 32.0]), ridges=np.eye(2), band_centre=np.zeros(2), value=amp))
    return img, found, np.array([2.0, 2.0])


def test_a_group_over_the_budget_is_refused_before_any_fit(monkeypatch):
    img, found, nulls = _pair()
    calls = []
    original = residual._fit_group
    monkeypatch.setattr(residual, "_fit_group", lambda *a, **k: calls.append(1) or original(*a, **k))
    with pytest.raises(CrowdedGroup) as refused:
        fit_response_models(img, found, nulls, EvaluateParams(), support_shape=True, budget=1.0)
    assert refused.value.members == [0, 1]
    assert refused.value.rows * refused.value.columns**2 > 1.0
    assert not calls  # refused from the groups' sizes alone
    # within the budget the models are those fitted without one, to the bit
    within = fit_response_models(img, found, nulls, EvaluateParams(), support_shape=True, budget=BUDGET)
    free = fit_response_models(img, found, nulls, EvaluateParams(), support_shape=True)
    for m, f in zip(within, free):
        assert m is not None and f is not None
        assert m.coef.tobytes() == f.coef.tobytes() and m.nulls.tobytes() == f.nulls.tobytes()


def test_evaluate_notes_a_crowded_residual_and_reports_the_guard_window_figure(monkeypatch):
    from tests.quality.test_evaluate_pinned import _crowded_2d

    img, coords, res, targets = _crowded_2d()
    monkeypatch.setattr(metrics, "RESIDUAL_BUDGET", 1e6)  # its three targets' joint fit, 3 x 25 columns, is over
    shaped = []
    original = residual._fit_group
    monkeypatch.setattr(
        residual,
        "_fit_group",
        lambda *a, **k: shaped.append(a[7] if len(a) > 7 else k.get("shape0")) or original(*a, **k),
    )
    report = evaluate_image(img, ("azimuth", "range"), coords, res, targets, params=EvaluateParams(residual=True))
    assert not [s for s in shaped if s is not None]  # no residual model fitted (the cuts' refits have no shape)
    assert report.residual is None and report.false_targets is None
    assert report.residual_note is not None and "not taken: 3 targets" in report.residual_note
    assert "guard-window figure" in report.residual_note
    assert report.false_target == report.false_target_guard


def test_the_trial_scene_of_crowded_hamming_targets_runs_no_fit_over_the_budget(monkeypatch):
    """docs/cli.md row 9b's scene, 4 x 4 targets (16 x 25 columns jointly, over the budget): every fit evaluate
    runs stays within it (main: the residual's first fit, all 16 targets, 1.9e9), and the residual is noted."""
    from sarproc.focus.pfa.chain import Pfa2Params, pfa2
    from sarproc.quality.metrics import evaluate_product
    from sarproc.simulation.scene import scene_from_mapping
    from sarproc.simulation.simulate import simulate

    scene = {
        "radar": {
            "carrier_frequency": "1.4 GHz",
            "bandwidth": "150 MHz",
            "pulse_duration": "2 us",
            "range_sampling_rate": "180 MHz",
            "prf": "600 Hz",
        },
        "platform": {"velocity": "120 m/s", "altitude": "1 km"},
        "geometry": {"reference_range": "3 km", "squint": "5 deg"},
        "acquisition": {"mode": "spotlight", "aperture_time": "3 s"},
        "targets": {
            "frame": "ground_los",
            "grid": {"azimuth_count": 4, "range_count": 4, "azimuth_spacing": "12 m", "range_spacing": "12 m"},
        },
    }
    image = pfa2(simulate(scene_from_mapping(scene)), Pfa2Params(method="plain", range_window="hamming"))
    sizes = []
    original = residual._fit_group

    def counted(members, points, y, found, nulls, orders, *rest, **kw):
        sizes.append(points.shape[1] * (len(members) * len(orders)) ** 2)
        assert sizes[-1] <= BUDGET, f"a joint fit of {len(members)} targets, {sizes[-1]:.2g} rows x columns^2"
        return original(members, points, y, found, nulls, orders, *rest, **kw)

    monkeypatch.setattr(residual, "_fit_group", counted)
    report = evaluate_product(image)
    assert report.residual is None
    assert report.residual_note is not None and "16 targets" in report.residual_note
    assert report.false_target == report.false_target_guard


def test_a_costly_group_fit_stops_at_its_looser_tolerance(monkeypatch):
    """The pinned crowded skewed 2D scene's cuts refit its three targets jointly (3 x 21 columns on 2680-3986 rows,
    1.6e7 at most: under COSTLY_FIT, so its pinned figures stand); its fits crawl to FIT_MAX_STEPS (60 steps each,
    the predicted decreases never under FIT_TOLERANCE). Counted as costly, they stop at COSTLY_TOLERANCE: 57 steps
    in all instead of 180."""
    from tests.quality.test_evaluate_pinned import _crowded_2d

    img, coords, res, targets = _crowded_2d()
    steps = []
    original = residual._gauss_newton_step

    def counted(*a, **k):
        steps.append(1)
        return original(*a, **k)

    def run() -> list[int]:
        per_fit = []
        fit = residual._fit_group

        def counting(*a, **k):
            steps.clear()
            out = fit(*a, **k)
            per_fit.append(len(steps))
            return out

        with monkeypatch.context() as m:
            m.setattr(residual, "_gauss_newton_step", counted)
            m.setattr(residual, "_fit_group", counting)
            evaluate_image(img, ("azimuth", "range"), coords, res, targets, params=EvaluateParams(residual=False))
        return per_fit

    default = run()
    assert min(default) >= residual.FIT_MAX_STEPS  # as pinned: the crawl, every sweep
    monkeypatch.setattr(residual, "COSTLY_FIT", 1e6)
    costly = run()  # sweep 0 still 52 steps, sweeps 1 and 2 then 4 and 1
    assert sum(costly) < sum(default) / 2
