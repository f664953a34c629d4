"""A false target on the image's edge cell (Session 41 open item, issue 20 item 1).

The level of a false target is refined on the chip's band-limited interpolant; the chip is zero beyond the image,
and the interpolant of a response cut there overshoots (Gibbs): a -40.00 dB ghost centred on the last range cell
read -39.35 dB, one 0.2 samples inside it -39.22 dB (0.78 dB over). Along an edge axis the peak is now a parabola
through the edge sample and the two inside it, kept within the half cell inside the edge.
"""

from __future__ import annotations

import numpy as np
import pytest

from sarproc.quality.metrics import EvaluateParams, evaluate_image

SHAPE = (120, 100)


def image(ghost_range: float) -> np.ndarray:
    a = np.arange(SHAPE[0])[:, None].astype(float)
    r = np.arange(SHAPE[1])[None, :].astype(float)

    def sinc2(a0: float, r0: float, amp: float) -> np.ndarray:  # two samples per null on both axes
        return amp * np.sinc((a - a0) / 2) * np.sinc((r - r0) / 2)

    return (sinc2(40, 50, 1.0) + sinc2(85, ghost_range, 10 ** (-40 / 20))).astype(complex)


def report(ghost_range: float):
    coords = {"azimuth": np.arange(SHAPE[0]) * 1.0, "range": np.arange(SHAPE[1]) * 1.0}
    return evaluate_image(
        image(ghost_range), ("azimuth", "range"), coords, (1.772, 1.772), [[40.0, 50.0]], ["A"], EvaluateParams()
    )


@pytest.mark.parametrize("ghost_range", [0.0, 0.2, 98.6, 98.8, 99.0, 99.3])
def test_a_ghost_on_an_edge_cell_is_not_read_over_its_level(ghost_range):
    """main: 99.0 -> -39.35 dB, 98.8 -> -39.22, 98.6 -> -39.29 (each 0.6-0.8 dB over -40); now -40.00, -40.14,
    -40.26; beyond the edge (99.3) the edge pixel, -40.32 (main -39.95)."""
    rep = report(ghost_range)
    false = rep.false_target
    assert false.position["azimuth"] == pytest.approx(85.0, abs=0.05)
    inside = min(max(ghost_range, 0.0), SHAPE[1] - 1.0)  # the ghost's level within the image
    level = -40 + 20 * np.log10(abs(np.sinc((inside - ghost_range) / 2)))
    assert false.level_db <= level + 0.02
    assert false.level_db >= level - 0.35
    assert rep.false_targets is not None
    if rep.false_targets.entries:
        assert rep.false_targets.entries[0].level_db == pytest.approx(false.level_db, abs=1e-9)
