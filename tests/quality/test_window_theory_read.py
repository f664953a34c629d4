"""The image's weighting-window theory (side lobes) is computed only where a cut reads it: an image whose targets
all record their own theory (every processor's products) does not pay for it (14-18 ms of an evaluate process)."""

from __future__ import annotations

import numpy as np

from sarproc.product.theory import window_theory
from sarproc.quality import metrics
from sarproc.quality.metrics import EvaluateParams, evaluate_image

RES = (0.58, 0.46)
DIMS = ("azimuth", "range")


def _scene() -> tuple:
    coords = [(np.arange(64) - 32) * 0.2, (np.arange(64) - 32) * 0.15]
    a, r = np.meshgrid(*coords, indexing="ij")
    img = np.sinc(0.886 / RES[0] * (a - 0.1)) * np.sinc(0.886 / RES[1] * (r + 0.05))
    return img.astype(np.complex64), coords


def _counted(monkeypatch) -> list:
    calls: list = []
    real = metrics.window_theory

    def counting(*args, **kwargs):
        calls.append(args)
        return real(*args, **kwargs)

    monkeypatch.setattr(metrics, "window_theory", counting)
    return calls


def test_targets_with_their_own_side_lobes_compute_no_window_theory(monkeypatch):
    calls = _counted(monkeypatch)
    img, coords = _scene()
    own = [(-13.0, -9.5), (-13.1, -9.8)]
    report = evaluate_image(
        img,
        DIMS,
        coords,
        RES,
        [(0.1, -0.05)],
        params=EvaluateParams(residual=False),
        target_irw=[RES],
        target_sidelobes=[own],
    )
    assert calls == []  # the code before: one call per axis, in the image's axes
    assert [(m.pslr_theory_db, m.islr_theory_db) for m in report.targets[0].axes] == own


def test_without_them_the_cuts_read_the_windows_theory(monkeypatch):
    calls = _counted(monkeypatch)
    img, coords = _scene()
    report = evaluate_image(img, DIMS, coords, RES, [(0.1, -0.05)], params=EvaluateParams(residual=False))
    flat = window_theory("none")
    assert calls and {c[0] for c in calls} == {"none"}
    assert all((m.pslr_theory_db, m.islr_theory_db) == (flat.pslr_db, flat.islr_db) for m in report.targets[0].axes)
