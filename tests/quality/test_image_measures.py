"""Truth-free image measures on images whose bright points, peaks and entropy are known by construction."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sarproc.quality.image_measures import bright_points, deviation_db, entropy, magnitude_ncc, subpixel_peak


def _blobs(shape: tuple[int, int], centres: list[tuple[float, float]], amplitudes: list[float]) -> np.ndarray:
    rows, cols = np.mgrid[: shape[0], : shape[1]]
    img = np.zeros(shape)
    for (r, c), a in zip(centres, amplitudes):
        img += a * np.exp(-((rows - r) ** 2 + (cols - c) ** 2) / 4.0)
    return img


def test_bright_points_are_separated_maxima_away_from_edges_and_above_the_floor():
    centres = [(30, 40), (60, 20), (32, 46), (3, 50), (80, 80)]  # (32, 46) is 6 px from the first; (3, 50) at the edge
    img = _blobs((100, 100), centres, [1.0, 0.8, 0.9, 2.0, 0.05])
    got = bright_points(img, n=10, separation=10, edge=8, floor=0.1)
    assert [tuple(p) for p in got] == [(30, 40), (60, 20)]  # brightest first; the neighbour, edge and weak one out
    assert [tuple(p) for p in bright_points(img, n=10, separation=2, edge=8)] == [
        (30, 40),
        (32, 46),
        (60, 20),
        (80, 80),
    ]
    assert len(bright_points(img, n=1, separation=10, edge=0)) == 1
    assert tuple(bright_points(img, n=1, separation=10, edge=0)[0]) == (3, 50)  # no edge margin: the brightest
    with pytest.raises(ValueError, match="2-D"):
        bright_points(img[0], n=1, separation=1, edge=0)


def test_subpixel_peak_finds_the_vertex_of_a_sampled_parabola():
    rows, cols = np.mgrid[:9, :9]
    peak = (4.3, 3.8)
    mag = 10.0 - (rows - peak[0]) ** 2 - 0.5 * (cols - peak[1]) ** 2
    assert subpixel_peak(mag, 4, 4) == pytest.approx(peak, abs=1e-12)  # a parabola's vertex is exact
    assert subpixel_peak(np.ones((5, 5)), 0, 4) == (1.0, 3.0)  # moved in from the border; flat: no offset


def test_entropy_of_uniform_and_single_point_images():
    assert entropy(np.ones((8, 16))) == pytest.approx(math.log(128))
    point = np.zeros((8, 8))
    point[3, 4] = 5.0
    assert entropy(point) == 0.0
    assert entropy(_blobs((40, 40), [(20, 20)], [1.0])) < entropy(_blobs((40, 40), [(20, 20), (10, 30)], [1.0, 1.0]))


def test_magnitude_ncc_ignores_gain_and_offset():
    rng = np.random.default_rng(3)
    a = rng.random((32, 32))
    assert magnitude_ncc(a, 3.0 * a + 1.0) == pytest.approx(1.0)
    assert magnitude_ncc(a, -a) == pytest.approx(-1.0)
    assert abs(magnitude_ncc(a, rng.random((32, 32)))) < 0.1


def test_deviation_db_is_the_peak_normalised_largest_difference():
    ref = np.zeros((8, 8), complex)
    ref[2, 3] = 10.0
    img = ref.copy()
    img[5, 5] = 0.1j  # -40 dB of the reference's peak
    assert deviation_db(img, ref) == pytest.approx(-40.0)
    assert deviation_db(ref, ref) == pytest.approx(-600.0)  # identical: the floor
    with pytest.raises(ValueError, match="shape"):
        deviation_db(img[:4], ref)
