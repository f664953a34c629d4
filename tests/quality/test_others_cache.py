"""The other groups' models on a fit's samples (residual._others_subtracted) are evaluated once per model object and
sample array while the fits run: the same right-hand sides, bit for bit, as evaluating them every time."""

from __future__ import annotations

import numpy as np

from helpers import warped_model
from sarproc.quality import residual
from sarproc.quality.residual import _others_subtracted


def _model(position, seed):
    return warped_model(np.random.default_rng(seed), position, cross_warp=False)


def test_the_other_groups_models_are_evaluated_once_with_the_same_bits(monkeypatch):
    models = [_model((40.0, 50.0), 1), _model((70.0, 45.0), 2), _model((55.0, 90.0), 3)]
    rng = np.random.default_rng(4)
    points = np.unique(rng.integers(20, 110, size=(2, 3000)), axis=1)
    y = rng.normal(size=points.shape[1]) + 1j * rng.normal(size=points.shape[1])
    want = _others_subtracted(y, points, [0], [0, 1, 2], models, 1e-3)
    calls = []
    real = residual.model_values

    def counted(pts, model):
        calls.append(model)
        return real(pts, model)

    monkeypatch.setattr(residual, "model_values", counted)
    monkeypatch.setattr(residual._OTHERS, "cache", {})
    first = _others_subtracted(y, points, [0], [0, 1, 2], models, 1e-3)
    again = _others_subtracted(y, points, [0], [0, 1, 2], models, 1e-3)
    assert len(calls) == 2  # models 1 and 2, once
    models[1] = _model((70.0, 45.0), 5)  # a refitted model: a new object, evaluated again
    other = _others_subtracted(y, points, [0], [0, 1, 2], models, 1e-3)
    assert len(calls) == 3
    for got in (first, again):
        assert np.array_equal(got.view(np.uint64), want.view(np.uint64))
    assert not np.array_equal(other, want)


def test_each_thread_has_its_own_cache(monkeypatch):
    """Evaluations side by side on a Dask worker's threads: one's fit does not see (or replace) another's cache."""
    import threading

    mine: dict = {}
    monkeypatch.setattr(residual._OTHERS, "cache", mine)
    seen = []
    worker = threading.Thread(target=lambda: seen.append(residual._OTHERS.cache))
    worker.start()
    worker.join()
    assert seen == [None] and residual._OTHERS.cache is mine
