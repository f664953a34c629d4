"""Accuracy against time, honestly: repeated timings, "faster" only beyond the spread, the Pareto front.

Timings on a shared machine scatter by tens of percent between runs, so one run per setting can
flip a front. Each setting is timed over repeats (interleaved by the caller: round-robin over the
settings, so a slow spell of the machine hits them all) and summarised by its best, median and
spread (max - min). The rule used everywhere:

* A is **faster** than B only beyond the spread: A's *worst* time is below B's *best* time
  (their ranges of repeated times do not overlap). Tables say which settings each one is faster than.
* The **front** is the Pareto front of (best time, quality): B dominates A when B's best time and
  quality are both no worse and one is better. The best of the repeats is the timing statistic
  because the machine's noise only ever adds time. (A front that drops A whenever some better
  setting's times merely overlap A's collapses through chains of overlaps when the spreads are wide,
  dropping settings that are faster than the survivor beyond the spread; measured on make
  accuracy-002, it kept one setting of twelve.) Adjacent front settings whose times overlap are not
  resolved: the "faster" column says which are.

Quality is "lower is better" (e.g. worst deviation over tolerance).
"""

from __future__ import annotations

import math
import statistics
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from collections.abc import Sequence


def timing_stats(times: Sequence[float]) -> dict:
    """best, median, worst and spread (max - min) of a setting's repeated times (s)."""
    values = [float(t) for t in times]
    if not values or not all(math.isfinite(t) and t >= 0 for t in values):
        raise ValueError(f"timing_stats: need finite non-negative times, got {values!r}")
    best, worst = min(values), max(values)
    return {
        "best": best,
        "median": statistics.median(values),
        "worst": worst,
        "spread": worst - best,
        "repeats": len(values),
    }


def faster(a_times: Sequence[float], b_times: Sequence[float]) -> bool:
    """True when A is faster than B beyond the spread: every repeat of A beat every repeat of B."""
    return max(a_times) < min(b_times)


def dominates(b_times: Sequence[float], b_quality: float, a_times: Sequence[float], a_quality: float) -> bool:
    """B dominates A: best time and quality both no worse, one of them better."""
    b_best, a_best = min(b_times), min(a_times)
    return b_quality <= a_quality and b_best <= a_best and (b_quality < a_quality or b_best < a_best)


def pareto_front(times: Sequence[Sequence[float]], quality: Sequence[float]) -> list[int]:
    """Indices of the settings no other dominates, sorted by best time (then quality).

    ``times[i]`` is the list of repeated times of setting i, ``quality[i]`` its quality (lower is
    better). A setting with no quality (None or NaN) is on no front and dominates nothing.
    """
    ok = [i for i, q in enumerate(quality) if q is not None and math.isfinite(q)]
    front = [i for i in ok if not any(dominates(times[j], quality[j], times[i], quality[i]) for j in ok if j != i)]
    return sorted(front, key=lambda i: (min(times[i]), quality[i]))


def faster_groups(times: Sequence[Sequence[float]]) -> list[list[int]]:
    """For each setting, the indices of the settings it is faster than beyond the spread."""
    return [[j for j in range(len(times)) if j != i and faster(times[i], times[j])] for i in range(len(times))]
