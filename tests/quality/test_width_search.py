"""The residual's width search (residual._search_widths) with its bases kept across scales (_WidthBases) and its
decision-only early stop, and the ridge frames kept per (ridges, nulls): the same arrays and decisions as computing
everything anew."""

from __future__ import annotations

import dataclasses

import numpy as np

from helpers import warped_model
from sarproc.quality import residual
from sarproc.quality.residual import _ridge_frame, _search_widths, _WidthBases, response_basis, spectral_orders


def _rectangle(seed: int) -> residual.ResponseModel:
    """A skewed, chirped 2D model without keystone or warp: what the widening searches widths for."""
    model = warped_model(np.random.default_rng(seed), position=(60.3, 81.7))
    orders = spectral_orders(2, 2, 3)
    coef = np.random.default_rng(seed + 1).normal(size=(len(orders), 2)) @ np.array([1.0, 1j])
    return dataclasses.replace(model, kappa=None, warp=None, orders=orders, coef=coef)


def _points(seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    flat = np.unique(rng.integers(0, 130 * 160, size=3000))
    # column-major, as residual.unique_columns lays the fits' samples out
    return np.stack(np.unravel_index(flat, (130, 160)), axis=1).T


def _bits(a: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(a).view(np.uint64)


def test_width_bases_are_response_basis_bit_for_bit(monkeypatch):
    model, points = _rectangle(3), _points(4)
    nulls = np.array([2.3, 2.1])
    calls = []
    real = residual._shifted_sincs

    def counted(c, m):
        calls.append(c)
        return real(c, m)

    monkeypatch.setattr(residual, "_shifted_sincs", counted)
    bases = _WidthBases(points, model, nulls)
    scales = [(1.0, 1.0), (1.25, 1.0), (0.8, 1.0), (1.25, 1.0), (1.25, 1.25), (1.25, 0.64), (0.9, 1.1)]
    for scale in scales:
        scale = np.array(scale)
        got = bases(scale)
        want = response_basis(
            points, model.position, model.ridges, nulls * scale, model.band_centre, model.orders, model.chirp
        )
        assert got.shape == want.shape
        assert np.array_equal(_bits(got), _bits(want)), scale
    # response_basis's two per scale (14), and the kept bases' 9: both axes at the first scale, then only the
    # axis whose widths changed (one kept per axis: the fourth scale's axis 0 again), both at the last
    assert len(calls) == 14 + 9


def test_a_stopped_width_search_decides_as_the_full_one(monkeypatch):
    """Where only whether the search gets under a misfit is asked (the widening's first search), it stops at the
    first scale under it: the same answer to that question as the full search, with fewer least squares."""
    model = _rectangle(5)
    grid = np.meshgrid(np.arange(44, 78), np.arange(66, 98), indexing="ij")  # +-8 nulls about its peak
    points = np.stack([g.ravel() for g in grid])
    nulls = np.array([2.3, 2.1])
    wide = dataclasses.replace(model, nulls=nulls * np.array([1.5, 1.0]))
    rng = np.random.default_rng(7)
    noise = rng.normal(size=(points.shape[1], 2)) @ np.array([1.0, 1j])
    y = residual.model_values(points, wide) + 0.01 * noise
    solves = []
    real = residual.least_squares

    def counted(B, y, exact=False):
        solves.append(1)
        return real(B, y, exact)

    monkeypatch.setattr(residual, "least_squares", counted)
    scale, full = _search_widths(model, points, y, nulls)
    n_full = len(solves)
    first = _search_widths(model, points, y, nulls, below=0.0)[1]  # nothing under 0: the full search
    assert first == full and len(solves) == 2 * n_full
    # the misfit at the image's widths, and a bar the search passes on its way to the best
    start = _search_widths(model, points, y, nulls, below=np.inf)[1]
    assert full < 0.5 * start
    del solves[:]
    stopped = _search_widths(model, points, y, nulls, below=0.5 * start)[1]
    assert stopped < 0.5 * start and len(solves) < n_full
    # the full search answers the same question the same way
    assert (full < 0.5 * start) == (stopped < 0.5 * start)


def test_kept_ridge_frames_are_the_inverse_and_cannot_be_spoiled():
    V = np.array([[0.99, 0.14], [-0.05, 1.0]])
    nulls = np.array([2.3, 2.1])
    first, p = _ridge_frame((3.0, 4.0), V, nulls)
    want = np.linalg.inv(V.T) / nulls[:, None]
    assert np.array_equal(_bits(first), _bits(want)) and np.array_equal(p, [3.0, 4.0])
    first[:] = 0.0  # a caller writing into its frame does not change the one kept
    again = _ridge_frame((5.0, 6.0), V.copy(), nulls.copy())[0]
    assert np.array_equal(_bits(again), _bits(want))


def test_envelope_bound_at_points_is_the_bound_over_one_sample_boxes():
    """At points the bound takes no radius (its zero sums changed no bit): the same bits as over boxes of one
    sample, for straight, keystoned and bowed models."""
    rng = np.random.default_rng(8)
    points = rng.integers(0, 200, size=(500, 2)).astype(float)
    for kappa, curvature in ((0.0, 0.0), (0.02, 0.0), (0.0, -0.04), (0.03, 0.05)):
        model = dataclasses.replace(
            warped_model(rng, kappa=kappa, curvature=curvature), warp=None, kappa=np.array([kappa]) if kappa else None
        )
        got = residual.envelope_bound(model, points)
        want = residual.envelope_bound(model, points, points.copy())
        assert np.array_equal(_bits(got), _bits(want)), (kappa, curvature)
