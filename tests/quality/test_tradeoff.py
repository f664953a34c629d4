"""Accuracy against time: "faster" only beyond the spread of repeated times, the Pareto front, its figure."""

from __future__ import annotations

import math

import pytest

from sarproc.quality.tradeoff import dominates, faster, faster_groups, pareto_front, timing_stats


def test_timing_stats_best_median_spread():
    s = timing_stats([2.0, 1.0, 4.0])
    assert (s["best"], s["median"], s["worst"], s["spread"], s["repeats"]) == (1.0, 2.0, 4.0, 3.0, 3)
    with pytest.raises(ValueError):
        timing_stats([])
    with pytest.raises(ValueError):
        timing_stats([1.0, math.nan])


def test_faster_only_when_the_ranges_do_not_overlap():
    assert faster([1.0, 1.2], [1.3, 2.0])
    assert not faster([1.0, 1.4], [1.3, 2.0])  # medians differ, ranges overlap: no call
    assert not faster([1.3, 2.0], [1.0, 1.2])
    assert faster_groups([[1.0, 1.1], [1.05, 1.5], [2.0, 2.1]]) == [[2], [2], []]


def test_front_is_pareto_on_best_times():
    times = [[1.0, 1.3], [1.2, 1.4], [2.0, 2.2], [0.5, 0.6]]
    assert pareto_front(times, [0.5, 0.5, 0.1, 0.9]) == [3, 0, 2]  # B: A is as good and faster at best
    assert pareto_front(times, [0.5, 0.4, 0.6, 0.9]) == [3, 0, 1]  # C: slower and worse than A
    assert dominates([1.0, 1.3], 0.5, [1.2, 1.4], 0.5)
    assert not dominates([1.0, 1.3], 0.5, [1.0, 1.3], 0.5)  # equal: neither
    assert not dominates([1.5, 1.6], 0.4, [1.0, 1.3], 0.5)  # better, but slower


def test_wide_spreads_do_not_collapse_the_front():
    """Measured on make accuracy-002 (loaded machine): with spreads of 2-7 s, a rule that drops a
    setting whenever a better one's times overlap kept only the slowest, best setting; on best times
    the fast, poor plain PFA stays, and it is faster beyond the spread than the slow best one."""
    times = [[1.45, 2.43, 3.54], [2.74, 6.94, 7.67], [2.96, 8.28, 9.85], [9.39, 14.27, 14.97]]
    quality = [116.1, 3.95, 0.99, 0.32]
    assert pareto_front(times, quality) == [0, 1, 2, 3]
    assert faster(times[0], times[3]) and not faster(times[1], times[2])


def test_front_skips_settings_without_quality():
    assert pareto_front([[1.0], [2.0], [0.5]], [0.2, 0.1, None]) == [0, 1]
    assert pareto_front([[1.0], [2.0]], [math.nan, 0.1]) == [1]


def test_figure_numbers_do_not_collide(tmp_path):
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    from sarproc.quality.tradeoff_plot import number_groups, plot_tradeoff

    fig = Figure(figsize=(4, 3))
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    ax.set_xlim(0, 10)
    ax.set_ylim(0, 10)
    # three markers on one spot share a label; one far away keeps its own
    assert number_groups(ax, [5.0, 8.0, 5.0, 5.05], [5.0, 1.0, 5.0, 5.01]) == [[0, 2, 3], [1]]
    png = plot_tradeoff(
        tmp_path / "t.png",
        ["a", "b", "c"],
        [[1.0, 1.1], [2.0, 2.5], [3.0]],
        [0.3, 0.1, None],
        quality_label="q",
        log_quality=True,
        floor=1e-3,
    )
    assert png.stat().st_size > 10_000 and png.read_bytes()[:4] == b"\x89PNG"
