"""Accuracy-against-time figures: repeated times as bars, the Pareto front as a line, numbered markers.

Labels of a dozen settings overlap when written next to their markers; each marker carries only its
number (markers whose numbers would collide share one label, "2, 9, 12") and a table beside the axes names every number,
with its times and quality, the front's settings starred. The front and the "faster" rule are
:mod:`sarproc.quality.tradeoff`'s.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from sarproc.quality.tradeoff import pareto_front, timing_stats

if TYPE_CHECKING:
    from collections.abc import Sequence

    import numpy as np
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure


def _figure(width: float, height: float) -> Figure:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width, height), layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def number_groups(ax: Axes, xs: Sequence[float], ys: Sequence[float], min_px: float = 12.0) -> list[list[int]]:
    """Markers whose numbers would collide (closer than ``min_px`` vertically and three digits'
    width horizontally on the drawn axes), grouped: each group gets one label "2, 9, 12" at its first
    member, so no two labels overlap and none sits on another marker's row."""
    ax.figure.canvas.draw()
    disp: np.ndarray | list = ax.transData.transform(list(zip(xs, ys))) if len(xs) else []
    groups: list[list[int]] = []
    for i, (x, y) in enumerate(disp):
        for g in groups:
            if any(abs(x - disp[j][0]) < 2.5 * min_px and abs(y - disp[j][1]) < min_px for j in g):
                g.append(i)
                break
        else:
            groups.append([i])
    return groups


def plot_tradeoff(
    path: str | Path,
    labels: Sequence[str],
    times: Sequence[Sequence[float]],
    quality: Sequence[float],
    *,
    quality_label: str,
    title: str = "",
    log_quality: bool = False,
    floor: float | None = None,
) -> Path:
    """One panel: each setting's repeated times (bar from best to worst, dot at the median) against its
    quality (lower is better), the Pareto front as a line through the front's best times, numbered
    markers and a numbered table of the settings. Writes ``path`` (PNG)."""
    n = len(labels)
    stats = [timing_stats(t) for t in times]
    ok = [i for i in range(n) if quality[i] is not None]
    shown = [max(quality[i], floor) if floor is not None else quality[i] for i in range(n) if i in ok]
    qy = dict(zip(ok, shown))
    front = pareto_front(times, quality)
    fig = _figure(11.5, max(4.5, 1.6 + 0.2 * n))
    grid = fig.add_gridspec(1, 2, width_ratios=(1.15, 1.0))
    ax = fig.add_subplot(grid[0, 0])
    for i in ok:
        s = stats[i]
        color = "tab:red" if i in front else "tab:blue"
        ax.plot([s["best"], s["worst"]], [qy[i], qy[i]], "-", color=color, lw=2.5, alpha=0.45)
        ax.plot([s["median"]], [qy[i]], "o", color=color, ms=5)
    if front:
        fx = [stats[i]["best"] for i in front]
        fy = [qy[i] for i in front]
        # a step line: the best quality reachable within a time budget
        ax.step(
            fx + [max(s["worst"] for s in stats)],
            fy + [fy[-1]],
            where="post",
            color="tab:red",
            lw=1.2,
            label="Pareto front (best times)",
        )
        ax.legend(loc="best", fontsize=8)
    if log_quality:
        ax.set_yscale("log")
    ax.set_xscale("log")
    ax.margins(x=0.1, y=0.12)  # room for the numbers at the edges
    ax.set_xlabel("time (s): bar best..worst of the repeats, dot median")
    ax.set_ylabel(quality_label)
    if title:
        ax.set_title(title, fontsize=10)
    for group in number_groups(ax, [stats[i]["best"] for i in ok], [qy[i] for i in ok]):
        first = ok[group[0]]
        ax.annotate(
            ", ".join(str(ok[g] + 1) for g in group),
            (stats[first]["best"], qy[first]),
            xytext=(-3, 5),
            textcoords="offset points",
            fontsize=8,
            ha="right",
            color="tab:red" if all(ok[g] in front for g in group) else "black",
        )
    table = fig.add_subplot(grid[0, 1])
    table.axis("off")
    rows = [
        [
            str(i + 1) + (" *" if i in front else ""),
            labels[i],
            f"{stats[i]['best']:.3g}",
            f"{stats[i]['median']:.3g}",
            f"{stats[i]['spread']:.2g}",
            "n/a" if quality[i] is None else f"{quality[i]:.3g}",
        ]
        for i in range(n)
    ]
    tab = table.table(
        cellText=rows,
        colLabels=["#", "setting", "best s", "median s", "spread s", "quality"],
        loc="upper center",
        cellLoc="left",
        colWidths=[0.06, 0.56, 0.095, 0.095, 0.095, 0.095],
    )
    tab.auto_set_font_size(False)
    tab.set_fontsize(6.5 if max(map(len, labels), default=0) > 36 else 7)
    table.set_title(f"* on the front; {stats[0]['repeats'] if stats else 0} interleaved repeats each", fontsize=8)
    fig.savefig(path, dpi=110, format="png")
    return Path(path)
