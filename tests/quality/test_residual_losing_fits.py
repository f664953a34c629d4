"""Fits whose result is discarded unless it ends under a misfit stop once they cannot get there
(:data:`sarproc.quality.residual.LOSING_MARGIN`): the restarts of a misfitted lone target and the warp searches.
Their kept results, and so the reports, are those of the fits run to their end."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

import tests.quality.test_residual as tr
from sarproc.quality import residual
from sarproc.quality.metrics import evaluate_image


def test_a_fit_cannot_win_where_its_steps_left_cannot_take_it_under_the_bar():
    """The rule's decision: at misfit 1.0, a bar of 0.8 and 10 steps left, a step predicting 1e-3 (20 x 10 x 1e-3 =
    0.2 at most to go) cannot win; one predicting a little more still can."""
    assert residual.LOSING_MARGIN == 20.0
    assert residual._cannot_win(1.0, 1e-3, 10, 0.8)
    assert not residual._cannot_win(1.0, 1.01e-3, 10, 0.8)
    assert not residual._cannot_win(1.0, 1e-3, 11, 0.8)
    assert not residual._cannot_win(0.79, 0.0, 10, 0.8)  # already under it


def _defocused_scene() -> tuple:
    """tests/quality/test_residual.py's defocused target (2.5 rad at its band's edges) with a ghost at -35 dB: its
    box fit leaves 2.9 % (restarted, four times, none kept) and no warp lowers its misfit by the 20 % kept."""
    phase = tr.PHASE
    try:
        tr.PHASE = 2.5
        blurred, coords = tr._scene([(-40.0, 0.0)], [1.0])
    finally:
        tr.PHASE = phase
    return blurred + tr._scene([(35.0, 10.0)], [10 ** (-35 / 20)])[0], coords


def _evaluated(monkeypatch, margin: float) -> tuple:
    """(report, models, Gauss-Newton solves in the restarts, in the warp searches) of the defocused scene."""
    models: list = []
    counts = {"restart": 0, "warp": 0}
    phase = [None]
    fitted, step, restart, warp = (
        residual._fitted_response_models,
        residual._gauss_newton_step,
        residual._restart_misfitted_lone,
        residual._fit_warp,
    )

    def counting_step(*args):
        if phase[0] is not None:
            counts[phase[0]] += 1
        return step(*args)

    def in_phase(name, func):
        def wrapped(*args, **kwargs):
            phase[0] = name
            try:
                return func(*args, **kwargs)
            finally:
                phase[0] = None

        return wrapped

    def keeping(*args, **kwargs):
        out = fitted(*args, **kwargs)
        models.append(out)
        return out

    monkeypatch.setattr(residual, "LOSING_MARGIN", margin)
    monkeypatch.setattr(residual, "_fitted_response_models", keeping)
    monkeypatch.setattr(residual, "_gauss_newton_step", counting_step)
    monkeypatch.setattr(residual, "_restart_misfitted_lone", in_phase("restart", restart))
    monkeypatch.setattr(residual, "_fit_warp", in_phase("warp", warp))
    img, coords = _defocused_scene()
    rep = evaluate_image(img, ("azimuth", "range"), coords, tr.RES, [(-40.0, 0.0)], names=["A"], params=tr.PARAMS)
    monkeypatch.undo()
    return rep, models, counts["restart"], counts["warp"]


def _same_bits(a, b) -> bool:
    if a is None or b is None:
        return a is b
    for f in dataclasses.fields(a):
        u, v = getattr(a, f.name), getattr(b, f.name)
        if (u is None) != (v is None):
            return False
        if u is not None and (np.shape(u) != np.shape(v) or np.asarray(u).tobytes() != np.asarray(v).tobytes()):
            return False
    return True


def test_losing_restarts_and_warps_stop_early_with_the_same_models(monkeypatch):
    """The defocused target's four restarts and its warp search stop where they cannot win (fewer Gauss-Newton
    solves than run to their end, as with an infinite margin, the code before), and every model, so the residual's
    figures, is the same to the bit."""
    rep_full, models_full, restart_full, warp_full = _evaluated(monkeypatch, math.inf)
    rep, models, restarts, warps = _evaluated(monkeypatch, residual.LOSING_MARGIN)
    assert rep.residual.misfit_targets == ("A",)  # the precondition: a model that does not fit
    assert restarts < 0.8 * restart_full and warps < warp_full
    assert len(models) == len(models_full)
    for call, call_full in zip(models, models_full):
        assert len(call) == len(call_full)
        assert all(_same_bits(m, m_full) for m, m_full in zip(call, call_full))
    # what the models make (the targets' own figures do not use them; in one process an ISLR can differ in its last
    # bit between the first evaluate and later ones, fits or not)
    assert (rep.residual, rep.false_target, rep.false_targets) == (
        rep_full.residual,
        rep_full.false_target,
        rep_full.false_targets,
    )


@pytest.mark.parametrize("reachable", [True, False])
def test_a_warp_search_with_a_gain_ends_as_without_or_is_not_kept(reachable):
    """A warp search given the gain it is kept under: where its warp reaches it (a response whose ridge coordinates
    carry a warp) it ends with the same bits as without the gain; where nothing reaches it (no warp, complex noise
    at 30 % of the response) it stops sooner, leaving over the gain."""
    rng = np.random.default_rng(3)
    ndim = 2
    pos = np.array([40.0, 40.0])
    grid = np.stack([x.ravel() for x in np.meshgrid(np.arange(80.0), np.arange(80.0), indexing="ij")])
    model = residual.ResponseModel(
        position=pos,
        ridges=np.eye(ndim),
        nulls=np.array([4.0, 5.0]),
        band_centre=np.array([0.05, -0.02]),
        orders=residual.spectral_orders(ndim, 1, 2),
        coef=np.zeros(len(residual.spectral_orders(ndim, 1, 2)), dtype=complex),
        chirp=np.zeros((ndim, ndim)),
    )
    model = dataclasses.replace(model, coef=np.eye(len(model.orders))[0].astype(complex))
    W = np.zeros((ndim, ndim, ndim))
    W[1, 0, 0] = 2e-3  # the range coordinate bends with azimuth squared
    truth = dataclasses.replace(model, warp=W) if reachable else model
    y = residual.model_values(grid, truth)
    if not reachable:
        y = y + 0.3 * np.sqrt(np.mean(np.abs(y) ** 2)) * (
            rng.standard_normal(y.shape) + 1j * rng.standard_normal(y.shape)
        )
    counts = []
    step = residual._gauss_newton_step

    def counting(*args):
        counts[-1] += 1
        return step(*args)

    residual._gauss_newton_step = counting
    try:
        counts.append(0)
        full = residual._fit_warp(grid, y, model)
        counts.append(0)
        gained = residual._fit_warp(grid, y, model, residual.WARP_GAIN)
    finally:
        residual._gauss_newton_step = step
    assert full[1] == gained[1]
    if reachable:
        assert full[2] < residual.WARP_GAIN * full[1]  # kept
        assert counts[0] == counts[1] and full[2] == gained[2]
        assert np.asarray(full[0].warp).tobytes() == np.asarray(gained[0].warp).tobytes()
    else:
        assert full[2] >= residual.WARP_GAIN * full[1]  # not kept either way
        assert counts[1] < counts[0] and gained[2] >= residual.WARP_GAIN * gained[1]
