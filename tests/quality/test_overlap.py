"""sarproc.quality.overlap: targets sharing one 2D cell (paper 004, Fig. 5), against analytic cases."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sarproc.quality.overlap import cell_energy, coherent_overlap, coincident_groups, image_overlap, overlap_ratios


def test_groups_join_targets_within_half_a_cell_transitively():
    pos = np.array([[0.0, 490.0], [0.0, 490.1], [5.0, 490.0], [0.0, 490.25], [0.0, 495.0]])
    assert coincident_groups(pos, (0.4, 0.4)) == [[0, 1, 3], [2], [4]]
    assert coincident_groups(pos, (0.1, 0.1)) == [[0], [1], [2], [3], [4]]
    assert coincident_groups(np.zeros((0, 2)), (1.0, 1.0)) == []


def test_ratios_read_the_cell_peak_against_the_lone_cells():
    az, rg = np.arange(-4.0, 5.0), np.arange(480.0, 500.0, 0.5)
    n = 5
    a = np.linspace(0.5, 2.5, n) * np.exp(1j * np.arange(n))
    img = np.zeros((n, len(az), len(rg)), complex)
    ia, ir = 4, int(np.argmin(np.abs(rg - 490.0)))
    img[:, ia, ir + 1] = a  # the peak one sample off the nominal position: still found
    img[:, ia, ir] = 0.1 * a
    for x, r, v in ((-3.0, 485.0, 1.0), (3.0, 495.0, 3.0)):  # lone cells, energies 1 and 9
        img[:, int(np.argmin(np.abs(az - x))), int(np.argmin(np.abs(rg - r)))] = v
    np.testing.assert_allclose(cell_energy(img, az, rg, (0.0, 490.0)), np.abs(a) ** 2)
    ratio = overlap_ratios(img, az, rg, (0.0, 490.0), [(-3.0, 485.0), (3.0, 495.0)])
    np.testing.assert_allclose(ratio, np.abs(a) ** 2 / 5.0)
    with pytest.raises(ValueError, match="no reference"):
        overlap_ratios(img, az, rg, (0.0, 490.0), [])


def test_coherent_sum_of_three_targets_is_the_papers_formula():
    """Three unit targets at slant range r and elevations 0, +-theta, receivers at v_n across track of a
    transmitter on the track: |1 + 2 cos(2 pi v_n sin(theta) / lambda)|^2 (Fig. 5's "about 3 times")."""
    lam, h, r, th = 0.008, 500.0, 490.0, math.radians(2)
    v = (np.arange(28) - 13.5) * 0.0764
    p = np.array([[0.0, r * math.sin(e), h - r * math.cos(e)] for e in (0.0, th, -th)])
    rx = np.stack([np.zeros_like(v), v, np.full_like(v, h)], axis=1)
    tx = np.array([0.0, 0.0, h])
    paths = np.linalg.norm(p - tx, axis=1)[None, :] + np.linalg.norm(p[None] - rx[:, None], axis=-1)
    got = coherent_overlap(paths, lam, np.ones(3), 1.0)
    want = (1 + 2 * np.cos(2 * np.pi * v * math.sin(th) / lam)) ** 2
    # the exact paths differ from -v sin(theta) by v^2 sin^2(theta) / (2 r): 1e-4 of a wavelength here
    np.testing.assert_allclose(got, want, atol=0.02)
    assert np.mean(got) == pytest.approx(3.0, abs=0.2)
    # amplitudes and the reference power scale it
    np.testing.assert_allclose(coherent_overlap(paths, lam, 2 * np.ones(3), 2.0), 2 * got)


def test_image_overlap_groups_and_references():
    az, rg = np.arange(-6.0, 7.0), np.arange(480.0, 500.0, 0.5)
    names = ["1", "2", "3", "6"]
    pos = np.array([[0.0, 485.0], [5.0, 490.0], [0.0, 490.0], [0.0, 490.0]])
    img = np.zeros((2, len(az), len(rg)), complex)
    for (x, r), v in zip(pos, (1.0, 1.0, 1.0, 1.0)):
        img[:, int(np.argmin(np.abs(az - x))), int(np.argmin(np.abs(rg - r)))] += v
    paths = np.array([[0.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 0.004]])  # receiver 2: half a wavelength apart
    groups, lone = image_overlap(img, az, rg, names, pos, (0.5, 0.5), paths, np.ones(4), 0.008)
    assert lone == ["1", "2"] and [g.targets for g in groups] == [["3", "6"]]
    np.testing.assert_allclose(groups[0].ratio, [4.0, 4.0])  # the synthetic image adds in phase
    np.testing.assert_allclose(groups[0].predicted, [4.0, 0.0], atol=1e-12)
    d = groups[0].to_dict()
    assert d["mean_predicted"] == pytest.approx(2.0) and d["azimuth"] == 0.0 and d["range"] == 490.0
    assert image_overlap(img, az, rg, names[:2], pos[:2], (0.5, 0.5), paths[:, :2], np.ones(2), 0.008)[0] == []
