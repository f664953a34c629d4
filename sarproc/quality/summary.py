"""One line per image: the worst quality over its targets and their principal axes.

Sweeps, accuracy tables and reproductions compare settings by one row each: the largest
|IRW / theory - 1|, the highest PSLR and ISLR, the largest |position error| (resolution cells), the
false-target level and the weakest peak over every measured target and cut. :func:`worst_quality`
takes a :class:`~sarproc.quality.metrics.QualityReport`, :func:`worst_quality_json` the same report
as ``sarproc evaluate`` writes it (report.json), :func:`worst_of_targets` any targets (e.g. each
measured alone in its own image). Non-finite figures (a PSLR of -inf: no side lobe found; JSON null)
are left out; a figure nothing measured is None.

:func:`tolerance_score` folds one target into one number against tolerances around its own theory
(worst deviation / tolerance: 1 is on the edge), for plots of quality against a knob or a distance.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable, Mapping
from typing import Any

from sarproc.quality.metrics import SINC_PSLR_DB, AxisMetrics, FalseTarget, QualityReport, TargetReport

SINC_ISLR_DB = -10.16  # over +-10 nulls (the contract's ISLR window)


@dataclasses.dataclass(frozen=True)
class WorstQuality:
    """Worst figures over targets and axes (None: nothing measured)."""

    irw_dev: float | None  # largest |IRW / theory - 1|
    pslr_db: float | None  # highest PSLR, dB
    islr_db: float | None  # highest ISLR, dB
    position_cells: float | None  # largest |position error|, resolution cells
    false_target_db: float | None  # the image's false-target level, dB (None: not searched or none found)
    weakest_peak: float | None  # smallest |peak|, image units

    def as_dict(self) -> dict[str, float | None]:
        return dataclasses.asdict(self)


def _worst(values: Iterable[float | None], pick: Any = max) -> float | None:
    finite = [float(v) for v in values if v is not None and math.isfinite(v)]
    return pick(finite) if finite else None


def _summarise(axes: list[Mapping[str, Any]], peaks: list[float | None], false_db: float | None) -> WorstQuality:
    def deviation(key: str, centre: float = 0.0) -> list[float | None]:
        return [None if a.get(key) is None else abs(a[key] - centre) for a in axes]

    return WorstQuality(
        irw_dev=_worst(deviation("irw_ratio", 1.0)),
        pslr_db=_worst(a.get("pslr_db") for a in axes),
        islr_db=_worst(a.get("islr_db") for a in axes),
        position_cells=_worst(deviation("position_error_cells")),
        false_target_db=false_db if false_db is not None and math.isfinite(false_db) else None,
        weakest_peak=_worst(peaks, min),
    )


def _axis_fields(a: AxisMetrics) -> dict[str, float]:
    return {
        "irw_ratio": a.irw_ratio,
        "pslr_db": a.pslr_db,
        "islr_db": a.islr_db,
        "position_error_cells": a.position_error_cells,
    }


def worst_of_targets(targets: Iterable[TargetReport], false_target: FalseTarget | None = None) -> WorstQuality:
    """Worst quality over ``targets`` (their principal-axis cuts); ``false_target``: the image's, if any."""
    targets = list(targets)
    return _summarise(
        [_axis_fields(a) for t in targets for a in t.axes],
        [t.peak_amplitude for t in targets],
        false_target.level_db if false_target is not None else None,
    )


def worst_quality(report: QualityReport) -> WorstQuality:
    """Worst quality over every target and axis of an evaluate report, with its false-target level."""
    return worst_of_targets(report.targets, report.false_target)


def worst_quality_json(report: Mapping[str, Any]) -> WorstQuality:
    """:func:`worst_quality` of a report as ``sarproc evaluate`` writes it (JSON: non-finite figures are null)."""
    targets = report.get("targets") or []
    ft = report.get("false_target")
    return _summarise(
        [a for t in targets for a in t.get("axes") or []],
        [t.get("peak_amplitude") for t in targets],
        ft.get("level_db") if ft else None,
    )


@dataclasses.dataclass(frozen=True)
class Tolerance:
    """Allowed deviations of one cut from its theory; ``position_cells`` None leaves the position out."""

    irw_dev: float = 0.05  # |IRW / theory - 1|
    pslr_db: float = 0.5  # |PSLR - theory|, dB
    islr_db: float = 0.5  # |ISLR - theory|, dB
    position_cells: float | None = 0.5  # |position error|, resolution cells

    def __post_init__(self) -> None:
        given = [self.irw_dev, self.pslr_db, self.islr_db, self.position_cells]
        if any(v is not None and not v > 0 for v in given):
            raise ValueError(f"tolerances must be positive, got {self}")


def tolerance_score(target: TargetReport, tolerance: Tolerance = Tolerance()) -> float:
    """Worst deviation of a target's cuts from their theory over the tolerance (<= 1: within it).

    Side lobes are judged against each cut's own theory (``pslr_theory_db``, ``islr_theory_db``: the
    target's support and window), an unweighted sinc's where the cut records none. A figure that could
    not be measured (NaN) gives NaN: no score hides an unmeasured cut.
    """
    terms = []
    for a in target.axes:
        pslr_theory = SINC_PSLR_DB if a.pslr_theory_db is None else a.pslr_theory_db
        islr_theory = SINC_ISLR_DB if a.islr_theory_db is None else a.islr_theory_db
        terms += [
            abs(a.irw_ratio - 1) / tolerance.irw_dev,
            abs(a.pslr_db - pslr_theory) / tolerance.pslr_db,
            abs(a.islr_db - islr_theory) / tolerance.islr_db,
        ]
        if tolerance.position_cells is not None:
            terms.append(abs(a.position_error_cells) / tolerance.position_cells)
    if any(math.isnan(t) for t in terms):
        return math.nan
    return max(terms)
