"""A group fit's step halved at most residual.HALVINGS times: where no step along the Gauss-Newton direction lowers
the misfit (here the direction turned uphill), the fit stops after that many trials with its start."""

from __future__ import annotations

import dataclasses

import numpy as np

from helpers import warped_model
from sarproc.quality import residual


def test_a_step_that_never_lowers_the_misfit_is_halved_halvings_times(monkeypatch):
    model = dataclasses.replace(warped_model(np.random.default_rng(3), position=(40.2, 50.6)), warp=None)
    grid = np.meshgrid(np.arange(26, 56), np.arange(36, 66), indexing="ij")
    points = np.stack([g.ravel() for g in grid])
    y = residual.model_values(points, model)
    start = residual.FitStart(
        position=model.position,
        ridges=model.ridges,
        band_centre=model.band_centre + np.array([0.01, -0.01]),  # off its answer: a step has somewhere to go
        value=1.0 + 0.0j,
    )
    real_step, real_amplitudes = residual._gauss_newton_step, residual._amplitudes
    calls = []

    def uphill(*args, **kwargs):
        step, predicted = real_step(*args, **kwargs)
        return -step, predicted

    def counted(*args, **kwargs):
        calls.append(1)
        return real_amplitudes(*args, **kwargs)

    monkeypatch.setattr(residual, "_gauss_newton_step", uphill)
    monkeypatch.setattr(residual, "_amplitudes", counted)
    coef, f_c, K, shape = residual._fit_group(
        [0],
        points,
        y,
        [start],
        model.nulls,
        model.orders,
        [np.zeros((2, 2))],
        [(np.zeros(2), np.zeros(1))],
        [np.ones(2)],
    )
    assert residual.HALVINGS == 20
    assert len(calls) == 1 + residual.HALVINGS  # the start's amplitudes, then every halving's trial, none kept
    assert np.array_equal(f_c[0], start.band_centre)
