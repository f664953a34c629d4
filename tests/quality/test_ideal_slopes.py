"""The closed-form Gauss-Newton columns of a 3D neighbour's ideal response (metrics._ideal_columns, from the
kernel ideal_response_boxes_slopes, and from its numpy reference) against central differences of the response
itself: sinc and Hamming shapes, a periodic and a tabulated one, a skewed support, a chirp."""

from __future__ import annotations

import numpy as np
import pytest

from sarproc.quality.metrics import ResponseShapes, _group_samples, _ideal_columns

SKEW = [(a, b) for a in range(3) for b in range(3) if a != b]
NULLS = np.array([2.5, 1.7, 2.2])


def _shapes(kind: str) -> ResponseShapes | None:
    if kind == "sinc":
        return None
    if kind == "periodic":
        return ResponseShapes(np.array([6.0, 0.0, 0.0]), np.zeros((3, 3)), np.zeros(3))
    q = np.arange(-40, 41) / 8.0
    table = np.stack([np.full(81, np.nan), np.full(81, np.nan), np.sinc(q) * (1 - 0.01 * q**2)])
    return ResponseShapes(np.zeros(3), table, np.array([0.0, 0.0, 8.0]))


@pytest.mark.parametrize("hamming", [False, True])
@pytest.mark.parametrize("kind", ["sinc", "periodic", "tabled"])
def test_closed_form_columns_equal_central_differences(hamming, kind):
    rng = np.random.default_rng(5)
    data = np.zeros((30, 26, 28), dtype=complex)
    position = np.array([14.3, 12.6, 13.2])
    points, _, boxes = _group_samples(data, [position, position + [2.0, -3.0, 1.0]], NULLS)
    V = np.eye(3) + 0.06 * rng.standard_normal((3, 3))
    np.fill_diagonal(V, 1.0)
    f_c, chirp, shapes = np.array([0.1, -0.2, 0.05]), np.array([0.004, -0.006, 0.002]), _shapes(kind)
    offs = points - position[:, None]
    cols = _ideal_columns(boxes, offs, position, V, NULLS, f_c, hamming, chirp, shapes, SKEW)

    def model(p: np.ndarray = position, v: np.ndarray = V) -> np.ndarray:
        return boxes.ideal_response(p, v, NULLS, f_c, hamming, chirp, shapes)

    assert np.array_equal(cols[0], model())
    reference = _ideal_columns(None, offs, position, V, NULLS, f_c, hamming, chirp, shapes, SKEW)  # numpy's
    for got, want in zip(cols, reference):
        assert np.abs(got - want).max() < 1e-8 * np.abs(want).max()
    h = 1e-4
    expected = [(model(p=position + h * e) - model(p=position - h * e)) / (2 * h) for e in np.eye(3)]
    for a, b in SKEW:
        d = np.zeros((3, 3))
        d[a, b] = h
        expected.append((model(v=V + d) - model(v=V - d)) / (2 * h))
    scale = np.abs(np.stack(expected)).max()
    # a table is interpolated linearly: its slope jumps at the knots (8 per null along ridge 2), where
    # differences straddling one see a mix of the two slopes; those samples are left out
    q = ((np.linalg.inv(V.T) / NULLS[:, None]) @ offs)[2] * 8.0
    keep = np.abs(q - np.rint(q)) > 0.01 if kind == "tabled" else np.ones(q.shape, dtype=bool)
    assert keep.mean() > 0.9
    for got, want in zip(cols[1:], expected):
        assert np.abs(got - want)[keep].max() < 1e-6 * scale
    assert np.abs(np.stack(cols[1:])).max() > 0.1 * scale  # a real comparison: the columns are not zero
