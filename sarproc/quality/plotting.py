"""Figures for ``sarproc evaluate --plot``: a dB quicklook and per-target contour plots.

matplotlib is imported inside the functions (it is slow to import) and only through its
object-oriented API with the Agg canvas, so no display or global pyplot state is involved.
Images are ``(azimuth, range)`` or ``(elevation, azimuth, range)``; the last axis is drawn
horizontally.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from sarproc.quality.raster import axis_label, axis_pairs, db_panels

if TYPE_CHECKING:
    from collections.abc import Sequence

    from matplotlib.artist import Artist
    from matplotlib.axes import Axes
    from matplotlib.colors import Colormap
    from matplotlib.figure import Figure

    from sarproc.quality.metrics import EvaluateParams, TargetReport

CONTOUR_LEVELS_DB = (-40, -30, -20, -13.26, -10, -6, -3)
TARGET_FILL_LEVELS_DB = np.arange(-40, 0.1, 2.5)  # the filled contours' levels, the colour bar's bands
DPI = 110
# zlib's level for the PNGs: 1 encodes these figures in a third of the default 6's time (same pixels;
# the files are larger, see docs/performance.md)
PNG_COMPRESS_LEVEL = 1


def safe_name(name: str) -> str:
    """File-name-safe version of a target name (stable: same name, same file)."""
    return re.sub(r"[^A-Za-z0-9_.-]", "_", name) or "_"


# Fixed margins of a target's figure, inches: the y label and tick labels left of each panel, the colour bar's
# tick labels and label right of it, the x label below, the suptitle and a two-line panel title above. matplotlib's
# constrained layout finds about these by drawing every text first: half of the demo's plotting time.
# (Tick labels of the sizes these figures draw, 5 characters and a sign, fit them.)
TARGET_MARGINS = {"left": 0.75, "right": 0.7, "bottom": 0.55, "top": 0.7}
QUICKLOOK_MARGINS = {"left": 0.75, "right": 0.7, "bottom": 0.55, "top": 0.55}  # the suptitle, a 3D panel's title
# each panel's colour bar and its gap, fractions of the panel's width (matplotlib's 0.15 and 0.05 narrowed the
# demo's image until its range tick labels touched)
COLORBAR_FRACTION, COLORBAR_PAD = 0.05, 0.04


def _figure(
    n_panels: int, margins: Mapping[str, float], width: float = 5.0, height: float = 4.2
) -> tuple[Figure, list[Axes]]:
    """A figure of ``n_panels`` side by side, laid out by ``margins`` (inches, as :data:`TARGET_MARGINS`)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    size = (width * n_panels, height)
    fig = Figure(figsize=size, dpi=DPI)
    FigureCanvasAgg(fig)
    gap = margins["left"] + margins["right"]  # a panel's colour bar labels, then the next one's y labels
    panel = (size[0] - gap * n_panels) / n_panels
    fig.subplots_adjust(
        left=margins["left"] / size[0],
        right=1 - margins["right"] / size[0],
        bottom=margins["bottom"] / size[1],
        top=1 - margins["top"] / size[1],
        wspace=gap / panel,
    )
    return fig, [fig.add_subplot(1, n_panels, i + 1) for i in range(n_panels)]


def _fixed_title(ax: Axes, text: str, fontsize: float) -> None:
    """An axes title at the axes' top (matplotlib's default place), given there instead of found by matplotlib
    at every draw (it measures the y tick labels to do so: a fifth of the targets' drawing). Only for panels
    with nothing above them: x ticks and labels below, and no y offset text (a target's offsets from its peak
    span zero, so they have none), where the place is the one matplotlib would find."""
    ax.set_title(text, fontsize=fontsize, y=1.0)


def _write_png(fig: Figure, path: str | Path) -> None:
    """Write what ``fig``'s Agg canvas holds (drawn already) as ``path``: what ``savefig`` writes after drawing."""
    from matplotlib.image import imsave

    buffer = fig.canvas.buffer_rgba()  # type: ignore[attr-defined]
    imsave(path, buffer, format="png", origin="upper", dpi=fig.dpi, pil_kwargs={"compress_level": PNG_COMPRESS_LEVEL})


def plot_quicklook(
    path: str | Path,
    data: np.ndarray,
    dims: Sequence[str],
    coords: Mapping[str, np.ndarray],
    truth: np.ndarray | None = None,
    names: Sequence[str] = (),
    units: Mapping[str, str] | None = None,
    dynamic_range_db: float = 50.0,
    title: str = "",
    frame: str = "",
) -> Path:
    """dB image (3D: maximum projections) normalised to its peak, truth marked; writes ``path`` (PNG).

    ``data`` may be complex or a magnitude already (e.g. :func:`sarproc.product.io.read_magnitude_preview`);
    ``frame`` names the image frame in the axis labels.
    """
    units = units or {}
    panels = db_panels(np.abs(np.asarray(data)), dynamic_range_db)
    fig, axs = _figure(len(panels), QUICKLOOK_MARGINS)
    for ax, panel in zip(axs, panels):
        v, h, other, db = panel.v, panel.h, panel.other, panel.db
        cv, ch = np.asarray(coords[dims[v]]), np.asarray(coords[dims[h]])
        extent = (ch[0], ch[-1], cv[0], cv[-1])
        im = ax.imshow(
            db,
            origin="lower",
            aspect="auto",
            extent=extent,
            cmap="gray",
            vmin=-dynamic_range_db,
            vmax=0,
            interpolation="nearest",
        )
        if truth is not None and len(truth):
            t = np.asarray(truth, dtype=float)
            ax.scatter(t[:, h], t[:, v], s=80, facecolors="none", edgecolors="tab:red", linewidths=1.0)
            for n, row in zip(names, t):
                ax.annotate(
                    str(n), (row[h], row[v]), xytext=(5, 5), textcoords="offset points", color="tab:red", fontsize=8
                )
        ax.set_xlabel(axis_label(dims[h], units, frame))
        ax.set_ylabel(axis_label(dims[v], units, frame))
        if other:
            ax.set_title(f"max over {', '.join(dims[o] for o in other)}", fontsize=9)
        fig.colorbar(im, ax=ax, label="dB", fraction=COLORBAR_FRACTION, pad=COLORBAR_PAD)
    if title:
        fig.suptitle(title, fontsize=10)
    fig.canvas.draw()
    _write_png(fig, path)
    return Path(path)


class TargetFigure:
    """Contours (dB) of the upsampled response around a target's peak, one panel per axis pair; one figure
    drawn for every target of an image in turn.

    Offsets are relative to the refined peak in axis units, with the -3 dB contour emphasised. The figure, its
    panels, axis labels, ticks and colour bars are made and drawn once (the contour levels are fixed, so one bar
    serves every target; a panel's offsets depend on the image's axes only, ``half_width_nulls`` nulls of each,
    so every target has the same limits and ticks); :meth:`draw` draws each target's contours, frames and titles
    over a copy of that drawing and writes a PNG: the pixels ``savefig`` of the whole figure writes.
    """

    def __init__(
        self,
        data: np.ndarray,
        dims: Sequence[str],
        coords: Mapping[str, np.ndarray],
        theoretical_irw: Sequence[float],
        units: Mapping[str, str] | None = None,
        params: EvaluateParams | None = None,
        half_width_nulls: float = 4.0,
        upsample: int = 8,
    ) -> None:
        self.data, self.dims, self.coords, self.theoretical_irw = data, dims, coords, theoretical_irw
        self.units = units or {}
        self.params, self.half_width_nulls, self.upsample = params, half_width_nulls, upsample
        self.pairs = axis_pairs(np.ndim(data))
        self.fig: Figure | None = None
        self.cmap: Colormap | None = None
        self.axs: list[Axes] = []
        self.contours: list[list[Artist]] = []  # per panel, the present target's
        self.suptitle: Artist | None = None
        self.background: tuple[object, object] | None = None  # (the panels' limits, the canvas region)

    def draw(self, path: str | Path, target: TargetReport) -> Path:
        """Draw ``target`` (a :class:`sarproc.quality.metrics.TargetReport`) and write ``path`` (PNG)."""
        from sarproc.quality.metrics import target_patch

        dims, units = self.dims, self.units
        if self.fig is None:
            from matplotlib import colormaps

            self.cmap = colormaps["viridis"]  # a copy of the registry's, once
            self.fig, self.axs = _figure(len(self.pairs), TARGET_MARGINS, width=4.6)
            for ax, (v, h) in zip(self.axs, self.pairs):
                ax.set_xlabel(f"{axis_label(dims[h], units)} from peak")
                ax.set_ylabel(f"{axis_label(dims[v], units)} from peak")
        fig = self.fig
        for artists in self.contours:
            for artist in artists:
                artist.remove()
        first, self.contours = not self.contours, []
        for ax, (v, h) in zip(self.axs, self.pairs):
            off_v, off_h, vals = target_patch(
                self.data,
                dims,
                self.coords,
                self.theoretical_irw,
                target,
                pair=(v, h),
                half_width_nulls=self.half_width_nulls,
                upsample=self.upsample,
                params=self.params,
            )
            db = 20 * np.log10(np.maximum(np.abs(vals), 1e-6))
            cs = ax.contourf(off_h, off_v, db, levels=TARGET_FILL_LEVELS_DB, cmap=self.cmap, extend="min")
            # the lines from the filled contours' generator (matplotlib's reuse of a contour set's grid)
            lines = ax.contour(cs, levels=list(CONTOUR_LEVELS_DB), colors="k", linewidths=0.5, linestyles="solid")
            half = ax.contour(cs, levels=[-3], colors="w", linewidths=1.2, linestyles="solid")
            ax.set_xlim(off_h[0], off_h[-1])  # as the contours set them, whatever an earlier target's were
            ax.set_ylim(off_v[0], off_v[-1])
            self.contours.append([cs, lines, half])
            _fixed_title(
                ax,
                "\n".join(
                    f"{d}: IRW {target.axis(d).irw:.3g} {units.get(d, '')}, PSLR {target.axis(d).pslr_db:.2f} dB"
                    for d in (dims[h], dims[v])
                ),
                fontsize=8,
            )
            if first:
                fig.colorbar(cs, ax=ax, label="dB", fraction=COLORBAR_FRACTION, pad=COLORBAR_PAD)
        self.suptitle = fig.suptitle(f"target {target.name}", fontsize=10)
        limits = [(ax.get_xlim(), ax.get_ylim()) for ax in self.axs]
        if self.background is None or self.background[0] != limits:
            self.background = (limits, self._draw_background())
        canvas = fig.canvas
        canvas.restore_region(self.background[1])  # type: ignore[attr-defined]
        for ax, artists in zip(self.axs, self.contours):
            # in the order Axes.draw draws them (zorder): filled contours, lines, then the frame over them
            for artist in [*artists, *ax.spines.values(), ax.title]:
                ax.draw_artist(artist)
        fig.draw_artist(self.suptitle)
        _write_png(fig, path)
        return Path(path)

    def _changing(self) -> list[Artist]:
        """What :meth:`draw` draws over the background: the contours, the panels' frames (drawn over the
        contours) and the titles."""
        assert self.suptitle is not None
        out: list[Artist] = [self.suptitle]
        for ax, artists in zip(self.axs, self.contours):
            out += [*artists, *ax.spines.values(), ax.title]
        return out

    def _draw_background(self) -> object:
        """The whole figure drawn without :meth:`_changing`'s artists, as a canvas region to restore."""
        assert self.fig is not None
        changing = self._changing()
        visible = [a.get_visible() for a in changing]
        for a in changing:
            a.set_visible(False)
        try:
            self.fig.canvas.draw()
            return self.fig.canvas.copy_from_bbox(self.fig.bbox)  # type: ignore[attr-defined]
        finally:
            for a, shown in zip(changing, visible):
                a.set_visible(shown)


def plot_target(
    path: str | Path,
    data: np.ndarray,
    dims: Sequence[str],
    coords: Mapping[str, np.ndarray],
    theoretical_irw: Sequence[float],
    target: TargetReport,
    units: Mapping[str, str] | None = None,
    params: EvaluateParams | None = None,
    half_width_nulls: float = 4.0,
    upsample: int = 8,
) -> Path:
    """One target's :class:`TargetFigure` (several targets of one image: draw them with one TargetFigure)."""
    figure = TargetFigure(data, dims, coords, theoretical_irw, units, params, half_width_nulls, upsample)
    return figure.draw(path, target)
