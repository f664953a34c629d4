"""Worst quality over targets and axes, and the tolerance score, on measured and hand-built reports."""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pytest

from sarproc.quality.metrics import AxisMetrics, TargetReport, evaluate_image
from sarproc.quality.summary import (
    Tolerance,
    WorstQuality,
    tolerance_score,
    worst_of_targets,
    worst_quality,
    worst_quality_json,
)

STEP = (0.6, 0.5)  # sample spacing, m
BANDWIDTH = (1.0, 1.2)  # cycles per metre: nulls 1 m and 0.83 m


def _axis(name: str, irw_ratio: float, pslr: float, islr: float, pos: float, **theory: float) -> AxisMetrics:
    return AxisMetrics(
        axis=name,
        irw=irw_ratio,
        irw_theory=1.0,
        irw_ratio=irw_ratio,
        pslr_db=pslr,
        islr_db=islr,
        mainlobe_width=2.0,
        position=pos,
        truth=0.0,
        position_error=pos,
        position_error_cells=pos,
        band_center=0.0,
        **theory,
    )


def _target(name: str, peak: float, *axes: AxisMetrics) -> TargetReport:
    return TargetReport(name, peak, 0.0, (0, 0), False, tuple(axes))


def test_worst_is_taken_over_targets_and_axes_with_signs_folded():
    a = _target("A", 1.0, _axis("azimuth", 0.97, -13.0, -10.5, -0.3), _axis("range", 1.01, -14.0, -9.8, 0.1))
    b = _target("B", 0.4, _axis("azimuth", 1.02, -12.1, -11.0, 0.2), _axis("range", 1.0, -15.0, -10.2, -0.05))
    got = worst_of_targets([a, b])
    assert got.irw_dev == pytest.approx(0.03)  # A's azimuth 0.97, beyond B's 1.02
    assert got.pslr_db == -12.1 and got.islr_db == -9.8
    assert got.position_cells == pytest.approx(0.3)  # |-0.3|, A's azimuth
    assert got.weakest_peak == 0.4 and got.false_target_db is None


def test_unmeasured_figures_are_left_out_and_nothing_measured_is_none():
    t = _target("A", 1.0, _axis("azimuth", 1.02, -math.inf, -10.0, 0.1), _axis("range", math.nan, -13.0, -10.1, 0.2))
    got = worst_of_targets([t])
    assert got.pslr_db == -13.0  # -inf (no side lobe found) is no worst
    assert got.irw_dev == pytest.approx(0.02)  # the NaN cut is skipped, not propagated
    assert worst_of_targets([]) == WorstQuality(None, None, None, None, None, None)


def test_report_and_its_json_give_the_same_row():
    coords = [(np.arange(160) - 80) * s for s in STEP]
    truth = [(-20.3, -15.2), (18.7, 21.4)]
    image = np.zeros((160, 160), complex)
    for (x0, y0), amp in zip(truth, (1.0, 0.5)):
        image += amp * np.outer(np.sinc(BANDWIDTH[0] * (coords[0] - x0)), np.sinc(BANDWIDTH[1] * (coords[1] - y0)))
    ghost = 10 ** (-30 / 20) * np.outer(np.sinc(BANDWIDTH[0] * (coords[0] - 25.1)), np.sinc(BANDWIDTH[1] * coords[1]))
    irw = [0.886 / b for b in BANDWIDTH]
    report = evaluate_image(image + ghost, ("azimuth", "range"), coords, irw, truth, names=["A", "B"])
    row = worst_quality(report)
    assert row.irw_dev < 0.01 and abs(row.pslr_db + 13.26) < 0.2 and row.position_cells < 0.05  # sinc responses
    assert row.weakest_peak == pytest.approx(0.5, rel=0.01)
    assert row.false_target_db == pytest.approx(-30.0, abs=0.2)  # the ghost
    from_json = worst_quality_json(json.loads(json.dumps(report.to_dict())))
    assert from_json == row


def test_tolerance_score_is_worst_deviation_over_tolerance_against_own_theory():
    hamming = {"pslr_theory_db": -42.7, "islr_theory_db": -36.8}
    t = _target("A", 1.0, _axis("azimuth", 1.03, -42.5, -36.6, 0.1, **hamming), _axis("range", 0.99, -13.0, -10.2, 0.4))
    assert tolerance_score(t) == pytest.approx(0.8)  # range position 0.4 / 0.5
    assert tolerance_score(t, Tolerance(position_cells=None)) == pytest.approx(0.6)  # azimuth IRW 0.03 / 0.05
    sinc_judged = dataclasses.replace(t, axes=(_axis("azimuth", 1.0, -42.5, -36.6, 0.0),))
    assert tolerance_score(sinc_judged) == pytest.approx((42.5 - 13.26) / 0.5)  # no recorded theory: a sinc's
    unmeasured = dataclasses.replace(t, axes=(_axis("azimuth", math.nan, -13.0, -10.2, 0.0),))
    assert math.isnan(tolerance_score(unmeasured))
    with pytest.raises(ValueError, match="positive"):
        Tolerance(irw_dev=0.0)
