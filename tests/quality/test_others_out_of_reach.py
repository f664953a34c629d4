"""A model whose envelope over the box holding all of a fit's samples lies under the reach reaches none of them, and
one whose least envelope over it lies over the reach reaches all (residual._reach_by_box): its bound at each sample is
not taken, and the right-hand sides and the fitted models are the same bits as when every sample is bounded."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from helpers import warped_model
from sarproc.quality import residual
from sarproc.quality.metrics import EvaluateParams
from sarproc.quality.residual import (
    BOX_MARGIN,
    FitStart,
    _model_on_box,
    _others_subtracted,
    envelope_bound,
    envelope_floor,
    fit_response_models,
    spectral_orders,
)

ORDERS = spectral_orders(2, 1, 2)
CENTRE = int(np.flatnonzero(~ORDERS.any(axis=1))[0])  # order (0, 0)


def _model(rng, position, kappa=0.0, curvature=0.0, warped=False):
    """An unwarped (or warped) residual model whose order (0, 0) dominates, as a fitted point response's does."""
    coef = np.where(np.arange(len(ORDERS)) == CENTRE, 1.0, 0.03) * np.exp(1j * rng.uniform(0, 6, len(ORDERS)))
    model = warped_model(rng, position, kappa=kappa, curvature=curvature)
    return dataclasses.replace(model, coef=coef, warp=model.warp if warped else None)


@pytest.mark.parametrize("kappa, curvature", [(0.0, 0.0), (0.02, 0.0), (-0.05, 0.0), (0.02, 0.1), (0.0, -0.15)])
def test_the_bounds_over_a_box_bound_every_sample_in_it(kappa, curvature):
    rng = np.random.default_rng(7)
    for _ in range(40):
        model = _model(rng, rng.uniform(0, 200, 2), kappa, curvature)
        corner, size = rng.integers(0, 180, 2), rng.integers(1, 60, 2)
        grid = np.meshgrid(*(np.arange(c, c + s) for c, s in zip(corner, size)), indexing="ij")
        points = np.stack([x.ravel() for x in grid])
        at_samples = envelope_bound(model, points.T)
        lo, hi = points.min(axis=1)[None].astype(float), points.max(axis=1)[None].astype(float)
        assert at_samples.max() <= envelope_bound(model, lo, hi)[0] * (1 + BOX_MARGIN)
        assert at_samples.min() * (1 + BOX_MARGIN) >= envelope_floor(model, lo, hi)[0]


def _samples_about(centre, half):
    grid = np.meshgrid(*(np.arange(c - half, c + half + 1) for c in centre), indexing="ij")
    return np.stack([x.ravel() for x in grid])


def test_models_the_box_decides_are_not_bounded_at_each_sample(monkeypatch):
    rng = np.random.default_rng(3)
    # the fit's own target; a neighbour on its range ridge (reaches every sample), one far off both ridges (none),
    # one between (some: bounded at each), and a warped one (its bound at a sample is not its bound over a box)
    own = _model(rng, (100.0, 100.0))
    every = _model(rng, (100.0, 160.0))
    none = _model(rng, (520.0, 530.0))
    some = _model(rng, (300.0, 300.0))
    warped = _model(rng, (530.0, 90.0), warped=True)
    models = [own, every, none, some, warped]
    live = list(range(len(models)))
    points = _samples_about((100, 100), 20)
    y = rng.normal(size=points.shape[1]) + 1j * rng.normal(size=points.shape[1])
    reach = 1.8e-5
    assert envelope_bound(every, points.T).min() >= reach
    assert envelope_bound(none, points.T).max() < reach
    assert envelope_bound(some, points.T).min() < reach <= envelope_bound(some, points.T).max()
    want = _others_subtracted(y, points, [0], live, models, reach)  # outside a fit: every sample bounded
    at_samples = []
    real = residual.envelope_bound

    def counted(model, lo, hi=None):
        if hi is None:
            at_samples.append(model)
        return real(model, lo, hi)

    monkeypatch.setattr(residual, "envelope_bound", counted)
    for name in ("cache", "boxes", "bounds"):
        monkeypatch.setattr(residual._OTHERS, name, {})
    got = _others_subtracted(y, points, [0], live, models, reach)
    assert np.array_equal(got.view(np.uint64), want.view(np.uint64))
    assert len(at_samples) == 2 and at_samples[0] is some and at_samples[1] is warped


def test_a_model_is_bounded_over_every_known_box_once(monkeypatch):
    rng = np.random.default_rng(5)
    models = [_model(rng, (100.0, 100.0)), _model(rng, (520.0, 530.0))]
    sets = [_samples_about((100, 100), 10), _samples_about((110, 90), 10), _samples_about((90, 110), 10)]
    for name in ("cache", "boxes", "bounds"):
        monkeypatch.setattr(residual._OTHERS, name, {})
    residual._know_samples(sets)
    over_boxes = []
    real = residual.envelope_bound

    def counted(model, lo, hi=None):
        if hi is not None:
            over_boxes.append(len(lo))
        return real(model, lo, hi)

    monkeypatch.setattr(residual, "envelope_bound", counted)
    for points in sets:
        y = np.ones(points.shape[1], complex)
        assert np.array_equal(_others_subtracted(y, points, [0], [0, 1], models, 1e-5), y)
    assert over_boxes == [3]


def test_the_fitted_models_are_the_same_bits_without_the_box_test(monkeypatch):
    """Three lone targets, two of them far off each other's ridges (their models bounded away over the box of
    each other's fit samples): the fits end where they end when every sample is bounded."""
    rng = np.random.default_rng(11)
    shape = (560, 560)
    truth = [
        dataclasses.replace(_model(rng, p), chirp=np.zeros((2, 2)), kappa=np.zeros(1))
        for p in [(60.2, 70.6), (480.4, 492.3), (61.1, 488.7)]
    ]
    data = np.zeros(shape, complex)
    for m in truth:
        data += _model_on_box((slice(0, shape[0]), slice(0, shape[1])), m)
    found = [
        FitStart(m.position, m.ridges, m.band_centre, complex(data[tuple(np.rint(m.position).astype(int))]))
        for m in truth
    ]
    nulls = np.array([2.3, 2.1])
    decided = []
    real = residual._reach_by_box

    def counted(model, points, reach):
        decided.append(real(model, points, reach))
        return decided[-1]

    monkeypatch.setattr(residual, "_reach_by_box", counted)
    fitted = fit_response_models(data, found, nulls, EvaluateParams(), support_shape=True)
    assert False in decided and True in decided  # models bounded away over the boxes, and reaching all
    monkeypatch.setattr(residual, "_reach_by_box", lambda model, points, reach: None)
    every_sample = fit_response_models(data, found, nulls, EvaluateParams(), support_shape=True)
    for a, b in zip(fitted, every_sample):
        assert a is not None and b is not None
        for field in dataclasses.fields(a):
            u, v = np.asarray(getattr(a, field.name)), np.asarray(getattr(b, field.name))
            assert u.dtype == v.dtype and u.tobytes() == v.tobytes(), field.name


def test_an_empty_sample_set_is_not_decided(monkeypatch):
    rng = np.random.default_rng(9)
    models = [_model(rng, (100.0, 100.0)), _model(rng, (520.0, 530.0))]
    for name in ("cache", "boxes", "bounds"):
        monkeypatch.setattr(residual._OTHERS, name, {})
    empty = np.zeros((2, 0), dtype=int)
    residual._know_samples([empty])
    assert residual._reach_by_box(models[1], empty, 1e-5) is None
    assert _others_subtracted(np.zeros(0, complex), empty, [0], [0, 1], models, 1e-5).shape == (0,)
