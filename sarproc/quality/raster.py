"""Quicklook pictures drawn with numpy alone: dB image, axes in metres, colour bar, targets, PNG bytes.

``sarproc quicklook`` is one short process; importing matplotlib took 0.42-0.48 s of it (docs/performance.md,
twelfth round), more than the drawing. This module draws the same content (the magnitude in dB on the "gray"
ramp over the dynamic range, axes with ticks in the coordinates' units, labels, title, a colour bar, truth
targets circled and named; 3D cubes as three maximum projections) into an RGB array and encodes it as PNG with
zlib. Image pixels are drawn as blocks of whole screen pixels (nearest neighbour, no resampling), so every
pixel of the (already block-maximum reduced) preview is on the picture. Text uses a 5 x 7 bitmap font
(printable ASCII, descenders below) drawn at twice its size.

Images are ``(azimuth, range)`` or ``(elevation, azimuth, range)`` as in :mod:`sarproc.quality.plotting`; the
last axis is drawn horizontally, the first of each pair vertically with its first sample at the bottom.
"""

from __future__ import annotations

import math
import struct
import zlib
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from collections.abc import Mapping, Sequence

# 5 x 7 glyphs (and a row for descenders) of ASCII 32..126, five columns each, bit 0 the top row (the classic
# HD44780-style font).
_FONT_HEX = (
    "0000000000"
    "00005f0000"
    "0007000700"
    "147f147f14"
    "242a7f2a12"
    "2313086462"
    "3649562050"
    "0000070000"
    "001c224100"
    "0041221c00"
    "14083e0814"
    "08083e0808"
    "0050300000"
    "0808080808"
    "0060600000"
    "2010080402"
    "3e5149453e"
    "00427f4000"
    "4261514946"
    "2141454b31"
    "1814127f10"
    "2745454539"
    "3c4a494930"
    "0171090503"
    "3649494936"
    "064949291e"
    "0036360000"
    "0056360000"
    "0814224100"
    "1414141414"
    "0041221408"
    "0201510906"
    "3249794136"
    "7e1111117e"
    "7f49494936"
    "3e41414122"
    "7f4141221c"
    "7f49494941"
    "7f09090901"
    "3e4149497a"
    "7f0808087f"
    "00417f4100"
    "2040413f01"
    "7f08142241"
    "7f40404040"
    "7f020c027f"
    "7f0408107f"
    "3e4141413e"
    "7f09090906"
    "3e4151215e"
    "7f09192946"
    "4649494931"
    "01017f0101"
    "3f4040403f"
    "1f2040201f"
    "3f4038403f"
    "6314081463"
    "0708700807"
    "6151494543"
    "007f414100"
    "0204081020"
    "0041417f00"
    "0402010204"
    "4040404040"
    "0001020400"
    "2054545478"
    "7f48444438"
    "3844444420"
    "384444487f"
    "3854545418"
    "087e090102"
    "18a4a4a47c"
    "7f08040478"
    "00447d4000"
    "4080847d00"
    "7f10284400"
    "00417f4000"
    "7c04180478"
    "7c08040478"
    "3844444438"
    "fc24242418"
    "18242424fc"
    "7c08040408"
    "4854545420"
    "043f444020"
    "3c4040207c"
    "1c2040201c"
    "3c4030403c"
    "4428102844"
    "1ca0a0a07c"
    "4464544c44"
    "0008364100"
    "00007f0000"
    "0041360800"
    "0804081008"
)
GLYPH_W, GLYPH_H = 5, 8
TEXT_SCALE = 2  # screen pixels per font pixel
CHAR_ADVANCE = (GLYPH_W + 1) * TEXT_SCALE
TEXT_HEIGHT = GLYPH_H * TEXT_SCALE

WHITE = (255, 255, 255)
BLACK = (0, 0, 0)
TARGET_RED = (214, 39, 40)  # matplotlib's "tab:red", as the matplotlib drawing used
TARGET_RADIUS = 7.0  # px: matplotlib's 80 pt^2 circle at 110 dpi
MIN_SIDE, MAX_SIDE = 240, 1024  # small previews are enlarged by whole pixels towards MIN_SIDE, never past MAX_SIDE
TICK, PAD, GAP = 5, 4, 8
COLORBAR_W = 18


@dataclass(frozen=True)
class PlacedText:
    """A string drawn on the picture: top-left corner (x, y) in pixels; ``vertical`` reads bottom to top."""

    text: str
    x: int
    y: int
    vertical: bool = False


@dataclass(frozen=True)
class Panel:
    """Where one image panel is: top-left pixel of its image box, and screen pixels per image pixel."""

    top: int
    left: int
    rows: int  # image pixels drawn vertically
    cols: int
    row_factor: int
    col_factor: int


@dataclass(frozen=True)
class Picture:
    """An RGB picture (height, width, 3) uint8 and what is drawn where (for tests and callers)."""

    rgb: np.ndarray
    panels: tuple[Panel, ...]
    texts: tuple[PlacedText, ...]


def _glyphs() -> dict[str, np.ndarray]:
    raw = bytes.fromhex(_FONT_HEX)
    bits = (np.frombuffer(raw, np.uint8).reshape(-1, GLYPH_W)[:, None, :] >> np.arange(GLYPH_H)[None, :, None]) & 1
    return {chr(32 + i): bits[i].astype(bool) for i in range(len(bits))}


_GLYPHS = _glyphs()


def text_mask(text: str, scale: int = TEXT_SCALE) -> np.ndarray:
    """Boolean (8 scale, 6 scale len - scale) mask of ``text``; characters outside printable ASCII draw as '?'."""
    if not text:
        return np.zeros((GLYPH_H * scale, 0), dtype=bool)
    gap = np.zeros((GLYPH_H, 1), dtype=bool)
    cols = []
    for ch in text:
        cols += [_GLYPHS.get(ch, _GLYPHS["?"]), gap]
    mask = np.concatenate(cols[:-1], axis=1)
    return np.repeat(np.repeat(mask, scale, axis=0), scale, axis=1)


def text_width(text: str) -> int:
    return max(0, len(text) * CHAR_ADVANCE - TEXT_SCALE)


def gray_levels(db: np.ndarray, dynamic_range_db: float) -> np.ndarray:
    """uint8 gray of dB values on the "gray" ramp: -dynamic_range_db and below black, 0 dB and above white."""
    norm = np.clip((np.asarray(db, dtype=float) + dynamic_range_db) / dynamic_range_db, 0.0, 1.0)
    return np.round(norm * 255.0).astype(np.uint8)


def nice_ticks(lo: float, hi: float, min_spacing: float, length_px: float) -> tuple[np.ndarray, int]:
    """Round tick values in [lo, hi] (steps 1, 2, 2.5, 5 x 10^n) at least ``min_spacing`` px apart along
    ``length_px`` px, and the decimals that print them. ``min_spacing`` may grow with the labels' width."""
    lo, hi = min(lo, hi), max(lo, hi)
    span = hi - lo
    if not span > 0 or not math.isfinite(span):
        return np.array([lo]), 0
    wanted = max(1.0, length_px / max(min_spacing, 1.0))
    raw = span / wanted
    exp = math.floor(math.log10(raw))
    for e in (exp, exp + 1):
        for m in (1.0, 2.0, 2.5, 5.0, 10.0):
            step = m * 10.0**e
            if step >= raw * (1 - 1e-9):
                first = math.ceil(lo / step - 1e-9)
                ticks = (first + np.arange(int(math.floor(hi / step + 1e-9)) - first + 1)) * step
                decimals = max(0, -e + (1 if m == 2.5 else 0))
                return ticks, decimals
    return np.array([lo, hi]), 0  # pragma: no cover - the loop always finds a step


def tick_labels(ticks: np.ndarray, decimals: int) -> list[str]:
    return [f"{0.0 if abs(v) < 0.5 * 10.0**-decimals else v:.{decimals}f}" for v in ticks]


def _axis_ticks(
    lo: float, hi: float, length_px: float, horizontal: bool, spacing: float = 0.0
) -> tuple[np.ndarray, list[str]]:
    # labels must not touch: widen the spacing until the widest label fits (horizontal) or the height does
    spacing = spacing or (60.0 if horizontal else 40.0)
    for _ in range(8):
        ticks, dec = nice_ticks(lo, hi, spacing, length_px)
        labels = tick_labels(ticks, dec)
        need = (max(map(text_width, labels)) if horizontal else TEXT_HEIGHT) + 2 * GAP
        step_px = length_px * abs(ticks[1] - ticks[0]) / abs(hi - lo) if len(ticks) > 1 else math.inf
        if step_px >= need:
            break
        spacing *= 1.5
    return ticks, labels


def _edges(c: np.ndarray) -> tuple[float, float, float]:
    """(coordinate at the first pixel's outer edge, at the last's, coordinate per pixel) of pixel centres ``c``."""
    n = len(c)
    d = float(c[-1] - c[0]) / (n - 1) if n > 1 else 1.0
    return float(c[0]) - d / 2, float(c[-1]) + d / 2, d


def _factor(n: int) -> int:
    return int(min(max(1, math.ceil(MIN_SIDE / max(n, 1))), max(1, MAX_SIDE // max(n, 1))))


def axis_pairs(ndim: int) -> list[tuple[int, int]]:
    """(vertical axis, horizontal axis) index pairs: the image itself in 2D; the three projections
    (azimuth-range, elevation-range, elevation-azimuth) in 3D."""
    return [(0, 1)] if ndim == 2 else [(1, 2), (0, 2), (0, 1)]


def axis_label(dim: str, units: Mapping[str, str], frame: str = "") -> str:
    """'range (m, ground frame)': the axis name, its unit and the image frame where known."""
    inside = ", ".join(x for x in (units.get(dim, ""), f"{frame} frame" if frame else "") if x)
    return f"{dim} ({inside})" if inside else dim


class _Canvas:
    def __init__(self, height: int, width: int) -> None:
        self.rgb = np.full((height, width, 3), 255, dtype=np.uint8)
        self.texts: list[PlacedText] = []

    def fill(self, y0: int, y1: int, x0: int, x1: int, color: tuple[int, int, int]) -> None:
        h, w = self.rgb.shape[:2]
        self.rgb[max(y0, 0) : min(y1, h), max(x0, 0) : min(x1, w)] = color

    def mask(self, m: np.ndarray, y: int, x: int, color: tuple[int, int, int], clip: tuple[int, ...] = ()) -> None:
        y0, x0, y1, x1 = clip or (0, 0, *self.rgb.shape[:2])
        ys, xs = np.nonzero(m)
        ys, xs = ys + y, xs + x
        keep = (ys >= y0) & (ys < y1) & (xs >= x0) & (xs < x1)
        self.rgb[ys[keep], xs[keep]] = color

    def text(self, s: str, y: int, x: int, color: tuple[int, int, int] = BLACK, vertical: bool = False) -> None:
        m = text_mask(s)
        self.mask(np.rot90(m) if vertical else m, y, x, color)
        self.texts.append(PlacedText(s, x, y, vertical))


@dataclass(frozen=True)
class _PanelPlan:
    db: np.ndarray  # (rows, cols) drawn with row 0 at the bottom
    v: int
    h: int
    kv: int
    kh: int
    yticks: tuple[np.ndarray, list[str]]
    xticks: tuple[np.ndarray, list[str]]
    cticks: tuple[np.ndarray, list[str]]
    left: int  # width left of the image box
    right: int  # width right of it (colour bar and its labels)
    title: str


@dataclass(frozen=True)
class DbPanel:
    """One panel of a quicklook: image axes ``v`` (vertical) and ``h``, the axes ``other`` maximised over, and the
    projection in dB below the image's peak, clipped at the dynamic range."""

    v: int
    h: int
    other: tuple[int, ...]
    db: np.ndarray


def db_panels(mag: np.ndarray, dynamic_range_db: float) -> list[DbPanel]:
    """The panels both quicklook renderers draw of a magnitude image (2D: one; 3D: its three maximum projections)."""
    if not dynamic_range_db > 0:
        raise ValueError(f"dynamic range must be positive, got {dynamic_range_db} dB")
    peak = float(mag.max()) if mag.size and mag.max() > 0 else 1.0
    panels = []
    for v, h in axis_pairs(mag.ndim):
        other = tuple(a for a in range(mag.ndim) if a not in (v, h))
        proj = mag.max(axis=other) if other else mag  # axes (v, h): v < h in every pair
        panels.append(DbPanel(v, h, other, 20 * np.log10(np.maximum(proj / peak, 10 ** (-dynamic_range_db / 20)))))
    return panels


def _plan_panel(
    panel: DbPanel,
    coords_v: np.ndarray,
    coords_h: np.ndarray,
    dynamic_range_db: float,
    title: str,
) -> _PanelPlan:
    v, h, db = panel.v, panel.h, panel.db
    kv, kh = _factor(db.shape[0]), _factor(db.shape[1])
    lo_v, hi_v, _ = _edges(coords_v)
    lo_h, hi_h, _ = _edges(coords_h)
    yticks = _axis_ticks(lo_v, hi_v, db.shape[0] * kv, horizontal=False)
    xticks = _axis_ticks(lo_h, hi_h, db.shape[1] * kh, horizontal=True)
    cticks = _axis_ticks(-dynamic_range_db, 0.0, db.shape[0] * kv, horizontal=False, spacing=60.0)
    left = TEXT_HEIGHT + GAP + max(map(text_width, yticks[1])) + PAD + TICK
    right = 2 * GAP + COLORBAR_W + TICK + PAD + max(map(text_width, cticks[1])) + GAP + TEXT_HEIGHT
    return _PanelPlan(db, v, h, kv, kh, yticks, xticks, cticks, left, right, title)


def _pixel(value: float, c: np.ndarray, factor: int) -> float:
    """Screen offset (px, from the first pixel's outer edge) of coordinate ``value`` along pixel centres ``c``."""
    lo, _, d = _edges(c)
    return (value - lo) / d * factor


def render_quicklook(
    data: np.ndarray,
    dims: Sequence[str],
    coords: Mapping[str, np.ndarray],
    truth: np.ndarray | None = None,
    names: Sequence[str] = (),
    units: Mapping[str, str] | None = None,
    dynamic_range_db: float = 50.0,
    title: str = "",
    frame: str = "",
) -> Picture:
    """dB picture of a 2D image (3D: its three maximum projections) normalised to its peak, truth marked.

    Same arguments as :func:`sarproc.quality.plotting.plot_quicklook`: ``data`` complex or magnitude,
    ``truth`` one row per target in ``dims`` order, ``names`` their labels.
    """
    if not dynamic_range_db > 0:
        raise ValueError(f"dynamic range must be positive, got {dynamic_range_db} dB")
    units = units or {}
    mag = np.abs(np.asarray(data))
    if mag.ndim not in (2, 3):
        raise ValueError(f"a quicklook draws 2D images and 3D cubes, got {mag.ndim} dimensions")
    plans = []
    for panel in db_panels(mag, dynamic_range_db):
        sub = f"max over {', '.join(dims[o] for o in panel.other)}" if panel.other else ""
        cv, ch = np.asarray(coords[dims[panel.v]], float), np.asarray(coords[dims[panel.h]], float)
        plans.append(_plan_panel(panel, cv, ch, dynamic_range_db, sub))

    margin = 12
    top = margin + (TEXT_HEIGHT + 2 * GAP if title else 0) + (TEXT_HEIGHT + GAP if mag.ndim == 3 else 0)
    image_h = max(p.db.shape[0] * p.kv for p in plans)
    bottom = TICK + PAD + TEXT_HEIGHT + GAP + TEXT_HEIGHT + margin
    widths = [p.left + p.db.shape[1] * p.kh + p.right for p in plans]
    labels_w = [text_width(axis_label(dims[p.h], units, frame)) for p in plans]
    widths = [max(w, p.left + lw) for w, p, lw in zip(widths, plans, labels_w)]
    width = max(2 * margin + sum(widths) + 2 * GAP * (len(plans) - 1), 2 * margin + text_width(title))
    canvas = _Canvas(top + image_h + bottom, width)
    if title:
        canvas.text(title, margin, (width - text_width(title)) // 2)

    panels = []
    x = margin
    for plan, pw in zip(plans, widths):
        panels.append(
            _draw_panel(canvas, plan, top, x + plan.left, dims, coords, truth, names, units, frame, dynamic_range_db)
        )
        x += pw + 2 * GAP
    return Picture(canvas.rgb, tuple(panels), tuple(canvas.texts))


def _draw_panel(
    canvas: _Canvas,
    plan: _PanelPlan,
    top: int,
    left: int,
    dims: Sequence[str],
    coords: Mapping[str, np.ndarray],
    truth: np.ndarray | None,
    names: Sequence[str],
    units: Mapping[str, str],
    frame: str,
    dynamic_range_db: float,
) -> Panel:
    rows, cols = plan.db.shape
    ih, iw = rows * plan.kv, cols * plan.kh
    gray = gray_levels(plan.db[::-1], dynamic_range_db)  # first row at the bottom
    gray = np.repeat(np.repeat(gray, plan.kv, axis=0), plan.kh, axis=1)
    canvas.rgb[top : top + ih, left : left + iw] = gray[..., None]
    canvas.fill(top - 1, top + ih + 1, left - 1, left, BLACK)  # frame
    canvas.fill(top - 1, top + ih + 1, left + iw, left + iw + 1, BLACK)
    canvas.fill(top - 1, top, left - 1, left + iw + 1, BLACK)
    canvas.fill(top + ih, top + ih + 1, left - 1, left + iw + 1, BLACK)
    if plan.title:
        canvas.text(plan.title, top - TEXT_HEIGHT - GAP, left + (iw - text_width(plan.title)) // 2)

    cv, ch = np.asarray(coords[dims[plan.v]], float), np.asarray(coords[dims[plan.h]], float)
    for value, label in zip(*plan.xticks):
        px = left + int(math.floor(_pixel(value, ch, plan.kh)))
        if left <= px <= left + iw:
            px = min(px, left + iw - 1)
            canvas.fill(top + ih + 1, top + ih + 1 + TICK, px, px + 1, BLACK)
            canvas.text(label, top + ih + 1 + TICK + PAD, px - text_width(label) // 2)
    for value, label in zip(*plan.yticks):
        py = top + ih - int(math.ceil(_pixel(value, cv, plan.kv)))
        if top <= py <= top + ih:
            py = min(py, top + ih - 1)
            canvas.fill(py, py + 1, left - 1 - TICK, left - 1, BLACK)
            canvas.text(label, py - TEXT_HEIGHT // 2, left - 1 - TICK - PAD - text_width(label))
    xlabel, ylabel = axis_label(dims[plan.h], units, frame), axis_label(dims[plan.v], units, frame)
    canvas.text(xlabel, top + ih + 1 + TICK + PAD + TEXT_HEIGHT + GAP, left + (iw - text_width(xlabel)) // 2)
    canvas.text(ylabel, top + (ih - text_width(ylabel)) // 2, left - plan.left, vertical=True)

    # colour bar: 0 dB at the top, -dynamic range at the bottom, the same ramp as the image
    cx = left + iw + 2 * GAP
    ramp = gray_levels(-dynamic_range_db * (np.arange(ih) + 0.5) / ih, dynamic_range_db)
    canvas.rgb[top : top + ih, cx : cx + COLORBAR_W] = ramp[:, None, None]
    canvas.fill(top - 1, top + ih + 1, cx - 1, cx, BLACK)
    canvas.fill(top - 1, top + ih + 1, cx + COLORBAR_W, cx + COLORBAR_W + 1, BLACK)
    canvas.fill(top - 1, top, cx - 1, cx + COLORBAR_W + 1, BLACK)
    canvas.fill(top + ih, top + ih + 1, cx - 1, cx + COLORBAR_W + 1, BLACK)
    label_x = cx + COLORBAR_W + 1 + TICK + PAD
    for value, label in zip(*plan.cticks):
        py = min(top + int(round(-value / dynamic_range_db * ih)), top + ih - 1)
        canvas.fill(py, py + 1, cx + COLORBAR_W + 1, cx + COLORBAR_W + 1 + TICK, BLACK)
        canvas.text(label, py - TEXT_HEIGHT // 2, label_x)
    db_x = label_x + max(map(text_width, plan.cticks[1])) + GAP
    canvas.text("dB", top + (ih - text_width("dB")) // 2, db_x, vertical=True)

    if truth is not None and len(truth):
        t = np.asarray(truth, dtype=float)
        clip = (top, left, top + ih, left + iw)
        r = int(math.ceil(TARGET_RADIUS + 1))
        yy, xx = np.mgrid[-r : r + 1, -r : r + 1]
        ring = np.abs(np.hypot(yy, xx) - TARGET_RADIUS) < 0.75
        for i, row in enumerate(t):
            x = left + _pixel(row[plan.h], ch, plan.kh)
            y = top + ih - _pixel(row[plan.v], cv, plan.kv)
            if not (left <= x <= left + iw and top <= y <= top + ih):
                continue
            cy, cx = int(math.floor(y)), int(math.floor(x))  # the screen pixel holding the target
            canvas.mask(ring, cy - r, cx - r, TARGET_RED, clip)
            if i < len(names):
                canvas.mask(text_mask(str(names[i])), cy - r - TEXT_HEIGHT, cx + r, TARGET_RED)
                canvas.texts.append(PlacedText(str(names[i]), cx + r, cy - r - TEXT_HEIGHT))
    return Panel(top, left, rows, cols, plan.kv, plan.kh)


def encode_png(rgb: np.ndarray, level: int = 1) -> bytes:
    """PNG file bytes of an (height, width, 3) uint8 RGB array (8 bits per channel, no filtering).

    zlib ``level`` 1: a noisy 2048 x 2048 picture in 0.22 s and 5.95 MB against 1.53 s and 5.66 MB at level 6;
    the demo's 43 against 35 kB."""
    rgb = np.ascontiguousarray(rgb, dtype=np.uint8)
    if rgb.ndim != 3 or rgb.shape[2] != 3:
        raise ValueError(f"expected an (height, width, 3) RGB array, got shape {rgb.shape}")
    h, w = rgb.shape[:2]
    rows = np.concatenate([np.zeros((h, 1), np.uint8), rgb.reshape(h, 3 * w)], axis=1)  # filter byte 0 per row

    def chunk(kind: bytes, body: bytes) -> bytes:
        return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body) & 0xFFFFFFFF)

    header = struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0)
    idat = zlib.compress(rows.tobytes(), level)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", idat) + chunk(b"IEND", b"")
