"""Azimuth ambiguities of a backprojection grid: where the pulses undersample the grid's Doppler.

Backprojection sums each pixel's own phase history, so a pixel whose history matches a scatterer's up to a
whole number of cycles per pulse (at the same range, its Doppler one PRF or more away) focuses that scatterer
too, at full strength when the two histories stay matched over the aperture. That happens only where the grid
spans more than the PRF of Doppler at one range: a squinted spotlight whose scene folds (paper 000's scenes,
which the squint deramp chain unfolds) imaged by backprojection over a grid that wide. This module finds it
before any pixel is summed: the grid's widest Doppler span at equal range (the aperture's centre pulse), and
for every static target of the table the alias positions inside the grid, with the image's level there against
the target's own, backprojected from the data (a handful of points).
"""

from __future__ import annotations

import dataclasses
import math
from typing import TYPE_CHECKING

import numpy as np

from sarproc.product.metadata import SINC_IRW_FACTOR, C
from sarproc.product.sorted_values import unique_integers

if TYPE_CHECKING:
    from collections.abc import Callable, Mapping, Sequence

    from sarproc.focus.backprojection import BackprojectionPlan, PulseSet
    from sarproc.product.frames import Frame
    from sarproc.product.metadata import RadarMetadata
    from sarproc.product.model import Product

GRID_SAMPLES = 256  # grid points per axis for the Doppler span (its extent, not its detail, matters)
ORDERS = (-2, -1, 1, 2)  # alias orders searched (Doppler offsets of m PRF)


@dataclasses.dataclass(frozen=True)
class DopplerAlias:
    """A target's echoes focused a second time, ``order`` PRFs away in Doppler, inside the grid."""

    target: str
    order: int
    azimuth: float  # frame coordinates of the alias, or of the grid's nearest point where it peaks beyond the edge
    range: float
    level_db: float  # |image| there over |image| at the target, from the data
    beyond_edge: bool = False


@dataclasses.dataclass(frozen=True)
class GridAmbiguity:
    """The grid's widest Doppler span at equal range (Hz, centre pulse) against the PRF, the azimuth distance
    one PRF of Doppler makes at the grid centre (m), and every target alias inside the grid."""

    doppler_span: float
    prf: float
    alias_spacing: float
    aliases: tuple[DopplerAlias, ...]

    @property
    def ambiguous(self) -> bool:
        return self.doppler_span > self.prf


def _history(
    xyz: np.ndarray, tx: np.ndarray, rx: np.ndarray, v_tx: np.ndarray, v_rx: np.ndarray, wavelength: float
) -> tuple[np.ndarray, np.ndarray]:
    """Two-way path (m) and Doppler (Hz) of points ``xyz`` (n, 3) at one pulse."""
    d_tx, d_rx = xyz - tx, xyz - rx
    n_tx, n_rx = np.linalg.norm(d_tx, axis=-1), np.linalg.norm(d_rx, axis=-1)
    rate = (d_tx @ v_tx) / n_tx + (d_rx @ v_rx) / n_rx  # d(path)/dt with the scene still: -(v . u) per leg
    return n_tx + n_rx, rate / wavelength


def _widest_span(path: np.ndarray, doppler: np.ndarray, bandwidth: float) -> float:
    """The widest Doppler span among points of equal path (bins of one two-way range resolution, c / B)."""
    bins = np.floor((path - path.min()) / (C / bandwidth)).astype(np.int64)
    n = int(bins.max()) + 1
    hi = np.full(n, -np.inf)
    lo = np.full(n, np.inf)
    np.maximum.at(hi, bins, doppler)
    np.minimum.at(lo, bins, doppler)
    seen = np.isfinite(hi)
    return float((hi[seen] - lo[seen]).max())


def _solve_alias(
    start: tuple[float, float], goal: tuple[float, float], history: Callable[[np.ndarray], tuple[float, float]]
) -> tuple[float, float] | None:
    """Frame coordinates (azimuth, range) where ``history`` (path, Doppler) is ``goal``, by Newton from ``start``."""
    q = np.array(start, float)
    for _ in range(30):
        value = np.array(history(q)) - goal
        if abs(value[0]) < 1e-4 and abs(value[1]) < 1e-4:
            return float(q[0]), float(q[1])
        jac = np.empty((2, 2))
        for a, step in enumerate((1e-2, 1e-2)):
            shifted = q.copy()
            shifted[a] += step
            jac[:, a] = (np.array(history(shifted)) - goal - value) / step
        try:
            q = q - np.linalg.solve(jac, value)
        except np.linalg.LinAlgError:
            return None
    return None


def grid_ambiguity(
    plan: BackprojectionPlan, pulses: PulseSet, times: np.ndarray, radar: RadarMetadata
) -> GridAmbiguity | None:
    """The grid's azimuth ambiguity (None for a 3D grid or a single pulse): see the module doc.

    A beam that moves with the platform (stripmap, sliding spotlight) lets each point's echoes into the pulses
    of its own beam only: the Doppler that can meet at one range is then the beam's band, and a grid longer
    than the beam is no ambiguity while that band fits the PRF (the simulator warns when it does not)."""
    if plan.elevation is not None or len(times) < 3:
        return None
    prf = float(radar.prf)
    if radar.mode != "spotlight" and radar.azimuth_beamwidth > 0:
        band = 2 * radar.velocity * math.cos(radar.squint) * radar.azimuth_beamwidth / radar.wavelength
        if band <= prf:
            return GridAmbiguity(band, prf, math.inf, ())
    c = len(times) // 2
    tx, rx = pulses.tx, pulses.rx[0]
    v_tx, v_rx = np.gradient(tx, times, axis=0)[c], np.gradient(rx, times, axis=0)[c]
    wavelength = C / pulses.carrier_frequency
    frame = plan.frame
    history = _centre_history(frame, tx[c], rx[c], v_tx, v_rx, wavelength)
    az = plan.azimuth[unique_integers(np.linspace(0, len(plan.azimuth) - 1, GRID_SAMPLES).astype(int))]
    rg = plan.range[unique_integers(np.linspace(0, len(plan.range) - 1, GRID_SAMPLES).astype(int))]
    grid_az, grid_rg = np.meshgrid(az, rg, indexing="ij")
    xyz = np.asarray(frame.to_xyz(grid_az.ravel(), grid_rg.ravel()), float).reshape(-1, 3)
    path, doppler = _history(xyz, tx[c], rx[c], v_tx, v_rx, wavelength)
    span = _widest_span(path, doppler, pulses.bandwidth)
    mid = (float(np.mean(plan.azimuth)), float(np.mean(plan.range)))
    step = max(float(np.ptp(plan.azimuth)) / 100, 1e-3)
    slope = (history(np.array([mid[0] + step, mid[1]]))[1] - history(np.array(mid))[1]) / step  # Hz per m
    spacing = prf / abs(slope) if slope != 0 else math.inf
    if span <= prf:
        return GridAmbiguity(span, prf, spacing, ())
    found = []
    # an alias up to a resolution cell beyond the grid's edge still puts its main lobe inside
    irw = [float(x) for x in plan.attrs.get("theoretical_irw", (0.0, 0.0))]
    bounds = (min(plan.azimuth[0], plan.azimuth[-1]) - irw[0], max(plan.azimuth[0], plan.azimuth[-1]) + irw[0])
    r_bounds = (min(plan.range[0], plan.range[-1]) - irw[1], max(plan.range[0], plan.range[-1]) + irw[1])
    targets = plan.targets
    for k in range(len(targets)):  # type: ignore[arg-type]
        row = targets[k]  # type: ignore[index]
        if any(float(row[v]) != 0 for v in ("vx", "vy", "vz")):
            continue  # a mover focuses where it appears, not at its table position
        p = (float(row["azimuth"]), float(row["range"]))
        if not (bounds[0] <= p[0] <= bounds[1] and r_bounds[0] <= p[1] <= r_bounds[1]):
            continue
        path_p, f_p = history(np.array(p))
        for m in ORDERS:
            q = _solve_alias((p[0] + m * prf / slope, p[1]), (path_p, f_p + m * prf), history)
            if q is not None and bounds[0] <= q[0] <= bounds[1] and r_bounds[0] <= q[1] <= r_bounds[1]:
                found.append((row["name"], m, p, q))
    edges = ((bounds[0] + irw[0], bounds[1] - irw[0]), (r_bounds[0] + irw[1], r_bounds[1] - irw[1]))
    return GridAmbiguity(span, prf, spacing, tuple(_levels(found, frame, pulses, edges)))


def _levels(found: list, frame: Frame, pulses: PulseSet, edges: tuple) -> list[DopplerAlias]:
    """Each alias with the image's level there against its target's, backprojected from the pulses; an alias
    peaking beyond the grid's ``edges`` ((lo, hi) per axis) is read at the grid's nearest point."""
    from sarproc.focus.backprojection import backproject_points

    if not found:
        return []
    found = [(n, m, p, (float(np.clip(q[0], *edges[0])), float(np.clip(q[1], *edges[1]))), q) for n, m, p, q in found]
    coords = np.array([c for _, _, p, q, _ in found for c in (p, q)], float)
    xyz = np.asarray(frame.to_xyz(coords[:, 0], coords[:, 1]), float).reshape(-1, 3)
    values = np.zeros(len(xyz), complex)
    for rc, rx in zip(pulses.channels, pulses.rx):  # the channels summed coherently, as the image sums them
        values += backproject_points(
            rc, pulses.range_time, pulses.tx, rx, xyz, pulses.carrier_frequency, gate_offset=pulses.gate_offset
        )
    out = []
    for i, (name, m, _, q, peak) in enumerate(found):
        at_p, at_q = abs(values[2 * i]), abs(values[2 * i + 1])
        level = 20 * math.log10(at_q / at_p) if at_p > 0 and at_q > 0 else -math.inf
        label = name.decode() if isinstance(name, bytes) else str(name)
        out.append(DopplerAlias(label, m, q[0], q[1], level, beyond_edge=q != peak))
    return out


def messages(ambiguity: GridAmbiguity | None, floor_db: float = -50.0) -> list[str]:
    """What to warn about (nothing where the grid's Doppler fits the PRF, or its targets' aliases are all below
    ``floor_db``)."""
    if ambiguity is None or not ambiguity.ambiguous:
        return []
    head = (
        f"the grid spans {ambiguity.doppler_span:.4g} Hz of Doppler at equal range, more than the PRF "
        f"{ambiguity.prf:.4g} Hz: pixels about {ambiguity.alias_spacing:.4g} m apart in azimuth receive the same "
        "echoes (raise the PRF, narrow the grid's azimuth extent, or use a chain that unfolds the spectrum)"
    )
    strong = [a for a in ambiguity.aliases if a.level_db > floor_db]
    if not ambiguity.aliases:
        return [head + "; a scatterer in one also appears in the other"]
    if not strong:
        return []
    ghosts = "; ".join(
        f"target {a.target}'s ghost {'on the grid edge ' if a.beyond_edge else ''}at azimuth {a.azimuth:.6g} m, "
        f"range {a.range:.8g} m ({a.order:+d} PRF, {a.level_db:+.1f} dB against {a.target})"
        for a in sorted(strong, key=lambda a: -a.level_db)
    )
    return [f"{head}; in this image: {ghosts}"]


# An alias whose main lobe lies beyond the image still puts its azimuth side lobes in: an unweighted response
# falls only as 1 / (pi d / null), -31 dB at 11 nulls (paper 000's small scene, fine-focus and backprojection
# alike). Warned about down to this level (measured in the image, and expected of a sinc at that distance).
EDGE_FLOOR_DB = -50.0
EDGE_ROWS = 3  # the image rows at its azimuth edge read for an entering side-lobe ridge
EDGE_COLUMNS = 2  # and the range samples either side of where the ridge crosses the edge


@dataclasses.dataclass(frozen=True)
class EdgeAlias:
    """A target's echoes focused a second time, ``order`` PRFs away, with its main lobe at (``azimuth``,
    ``range``) beyond the image's azimuth edge and its azimuth side-lobe ridge entering the image at
    (``entry_azimuth``, ``entry_range``): the image's level there (``level_db``) and a sinc's at that distance
    (``expected_db``), both against the target's own peak in the image; ``distance`` m from the alias. An alias
    whose main lobe is in the image (or within a resolution cell of its edge) has distance 0, expected 0 dB, and
    for entry the strongest pixel near it (:func:`_strongest_near`: where the image put it)."""

    target: str
    order: int
    azimuth: float
    range: float
    entry_azimuth: float
    entry_range: float
    distance: float  # along the azimuth axis, from the alias to the edge
    level_db: float
    expected_db: float

    def describe(self) -> str:
        if self.distance == 0:
            return (
                f"target {self.target}'s alias ({self.order:+d} PRF) in the image, where backprojection focuses it "
                f"at azimuth {self.azimuth:.1f} m, range {self.range:.1f} m; strongest within {ALIAS_SEARCH_IRW:g} "
                f"IRW of it at azimuth {self.entry_azimuth:.1f} m, range {self.entry_range:.1f} m, {self.level_db:.1f} "
                f"dB against {self.target}"
            )
        return (
            f"target {self.target}'s alias ({self.order:+d} PRF) at azimuth {self.azimuth:.1f} m, range "
            f"{self.range:.1f} m, {self.distance:.0f} m beyond the edge, enters at azimuth {self.entry_azimuth:.1f} m, "
            f"range {self.entry_range:.1f} m at {self.level_db:.1f} dB against {self.target} (a sinc's side lobe "
            f"there: {self.expected_db:.1f} dB)"
        )


def edge_alias_message(aliases: list[EdgeAlias], prf: float) -> str:
    """One warning for :func:`image_edge_aliases`' finds (empty string for none)."""
    if not aliases:
        return ""
    return (
        f"the PRF ({prf:.4g} Hz) folds targets' echoes onto aliases in or just beyond the image's azimuth edges "
        "(the data cannot tell an alias from its target), and their azimuth side lobes enter the image: not "
        "scatterers (a higher PRF, or an azimuth taper, lowers them): " + "; ".join(a.describe() for a in aliases)
    )


def edge_alias_warning(image: Product) -> tuple[str, list[dict]]:
    """What a focusing stage warns of its 2D ``image`` (empty: nothing) and records in its history: every target
    alias whose azimuth side lobes enter it from beyond its azimuth edge (:func:`image_edge_aliases`), as
    evaluate lists them. An image spanning the PRF's unambiguous extent has a target near one edge aliased just
    beyond the other, its side lobes in the data as in any image of them: fine-focus (-31 dB on
    configs/an2012_exp1_small.yaml) and pfa2 (Session 41 new-user trial: -45.6 and -48.8 dB at 35 GHz, squint
    -35 deg, PRF 2 kHz, listed by evaluate, unsaid by pfa2 before) warn of them."""
    aliases = image_edge_aliases(image)
    return edge_alias_message(aliases, float(image.radar.prf)), edge_alias_records(aliases)


def edge_alias_records(aliases: list[EdgeAlias]) -> list[dict]:
    """The edge aliases as an image's history records them (floats to 0.01)."""
    rounded = [dataclasses.asdict(a).items() for a in aliases]
    return [{k: (round(float(v), 2) if isinstance(v, float) else v) for k, v in items} for items in rounded]


def image_edge_aliases(image: Product, floor_db: float = EDGE_FLOOR_DB) -> list[EdgeAlias]:
    """Every static target's aliases (m = +-1, +-2 PRF, solved as :func:`grid_ambiguity` solves them, at the
    aperture's centre pulse) that peak in a 2D image, or beyond its azimuth edge yet put their azimuth side lobes
    into it, over ``floor_db``, both as measured in the image and as a sinc's side lobe at that distance would be.

    An alias has its target's range history (same two-way path at the centre pulse), so its azimuth side-lobe
    ridge, perpendicular to the line of sight, runs along the iso-range line through it: it enters the image on
    the nearest azimuth edge where that line crosses it. That line is the target's own azimuth ridge too: an alias
    farther from the edge than its target is left out (the target's own side lobes are the stronger there), and of
    a target's aliases beyond one edge only the nearest is kept. Nothing is returned for a product without the pulses'
    positions or a target table, or a 3D one."""
    from sarproc.product.frames import frame_from_spec

    targets, aux = image.targets, image.aux
    if image.data.ndim != 2 or targets is None or len(targets) == 0 or "platform_position" not in aux:
        return []
    names = targets.dtype.names or ()
    if (
        tuple(image.dims) != ("azimuth", "range")
        or "frame" not in image.attrs
        or not {"azimuth", "range"} <= set(names)
    ):
        return []
    pos = np.asarray(aux["platform_position"], float)
    az = np.asarray(image.coords["azimuth"], float)
    rg = np.asarray(image.coords["range"], float)
    radar = image.radar
    prf = float(radar.prf)
    if len(pos) < 3 or len(az) < 2 or len(rg) < 2 or _beam_band_fits(radar):
        return []
    tx = pos + np.asarray(aux.get("tx_offset", np.zeros(3)), float)
    rx = pos + np.asarray(aux.get("rx_offset", np.zeros((1, 3))), float)[0]
    c = len(pos) // 2
    v_tx, v_rx = np.gradient(tx, axis=0)[c] * prf, np.gradient(rx, axis=0)[c] * prf
    history = _centre_history(
        frame_from_spec(image.attrs["frame"]), tx[c], rx[c], v_tx, v_rx, C / radar.carrier_frequency
    )
    irw = [float(x) for x in image.attrs.get("theoretical_irw", (abs(az[1] - az[0]), abs(rg[1] - rg[0])))]
    found = _edge_candidates(targets, az, rg, irw, prf, history, floor_db, inside=True)
    blocks = [np.abs(image.data[w]) for f in found for w in (f.peak, f.read)]
    return _edge_levels(found, blocks, targets, az, rg, irw, floor_db)


def grid_edge_aliases(
    plan: BackprojectionPlan, pulses: PulseSet, times: np.ndarray, radar: RadarMetadata, floor_db: float = EDGE_FLOOR_DB
) -> list[EdgeAlias]:
    """:func:`image_edge_aliases` of a backprojection grid before any pixel is summed: the aliases beyond its
    azimuth edge whose side lobes enter it, read where they enter and at their targets' peaks by backprojecting
    those few pixels from the pulses (one pass over them). The aliases inside the grid are :func:`grid_ambiguity`'s."""
    from sarproc.focus.backprojection import backproject_points

    if plan.elevation is not None or len(times) < 3 or plan.targets is None:
        return []
    targets = np.asarray(plan.targets)
    az, rg = np.asarray(plan.azimuth, float), np.asarray(plan.range, float)
    if len(targets) == 0:
        return []
    if len(az) < 2 or len(rg) < 2 or _beam_band_fits(radar):
        return []
    c = len(times) // 2
    tx, rx = pulses.tx, pulses.rx[0]
    v_tx, v_rx = np.gradient(tx, times, axis=0)[c], np.gradient(rx, times, axis=0)[c]
    history = _centre_history(plan.frame, tx[c], rx[c], v_tx, v_rx, C / pulses.carrier_frequency)
    irw = [float(x) for x in plan.attrs.get("theoretical_irw", (abs(az[1] - az[0]), abs(rg[1] - rg[0])))]
    found = _edge_candidates(targets, az, rg, irw, float(radar.prf), history, floor_db, inside=False)
    if not found:
        return []
    grids = [np.meshgrid(az[r], rg[k], indexing="ij") for f in found for r, k in (f.peak, f.read)]
    flat_az = np.concatenate([a.ravel() for a, _ in grids])
    flat_rg = np.concatenate([b.ravel() for _, b in grids])
    xyz = np.asarray(plan.frame.to_xyz(flat_az, flat_rg), float).reshape(-1, 3)
    values = np.zeros(len(xyz), complex)
    for rc, rx_k in zip(pulses.channels, pulses.rx):  # the channels summed coherently, as the image sums them
        values += backproject_points(
            rc, pulses.range_time, pulses.tx, rx_k, xyz, pulses.carrier_frequency, gate_offset=pulses.gate_offset
        )
    ends = np.cumsum([a.size for a, _ in grids])
    blocks = [np.abs(v).reshape(a.shape) for v, (a, _) in zip(np.split(values, ends[:-1]), grids)]
    return _edge_levels(found, blocks, targets, az, rg, irw, floor_db)


def _beam_band_fits(radar: RadarMetadata) -> bool:
    """A beam that moves with the platform (stripmap, sliding spotlight) whose Doppler band fits the PRF: no
    target aliases at one range (as :func:`grid_ambiguity` reasons)."""
    if radar.mode == "spotlight" or not radar.azimuth_beamwidth > 0:
        return False
    band = 2 * radar.velocity * math.cos(radar.squint) * radar.azimuth_beamwidth / radar.wavelength
    return bool(band <= radar.prf)


def _centre_history(
    frame: Frame, tx: np.ndarray, rx: np.ndarray, v_tx: np.ndarray, v_rx: np.ndarray, wavelength: float
) -> Callable[[np.ndarray], tuple[float, float]]:
    """(two-way path, Doppler) of one point's frame coordinates (azimuth, range) at the centre pulse."""

    def history(coords: np.ndarray) -> tuple[float, float]:
        xyz = np.asarray(frame.to_xyz(coords[0], coords[1]), float).reshape(1, 3)
        path, doppler = _history(xyz, tx, rx, v_tx, v_rx, wavelength)
        return float(path[0]), float(doppler[0])

    return history


Window = tuple[slice, slice]  # rows and columns of the image grid


@dataclasses.dataclass(frozen=True)
class _EdgeCandidate:
    """An alias found from the geometry alone, with the image windows its level is read on: its target's peak and
    where it is (``edge`` None: its main lobe in the image, read at the strongest pixel near it) or where its side
    lobes enter the image (at azimuth ``edge``, range ``entry_range``; a sinc's level there ``expected_db``)."""

    target: str
    order: int
    alias: tuple[float, float]
    peak: Window
    read: Window
    edge: float | None
    distance: float
    entry_range: float
    expected_db: float


def _window(az: np.ndarray, rg: np.ndarray, at: Sequence[float] | np.ndarray, rows: int, cols: int) -> Window:
    """The ``rows`` x ``cols`` samples either side of the sample nearest ``at`` (azimuth, range)."""
    i, j = int(np.argmin(np.abs(az - at[0]))), int(np.argmin(np.abs(rg - at[1])))
    return slice(max(i - rows, 0), i + rows + 1), slice(max(j - cols, 0), j + cols + 1)


def _edge_candidates(
    targets: np.ndarray,
    az: np.ndarray,
    rg: np.ndarray,
    irw: list[float],
    prf: float,
    history: Callable[[np.ndarray], tuple[float, float]],
    floor_db: float,
    inside: bool,
) -> list[_EdgeCandidate]:
    """The static targets' aliases beyond the grid's azimuth edge that :func:`image_edge_aliases` reads (and,
    ``inside``, those whose main lobe is in the grid), from the geometry alone: of each target's beyond one edge
    the nearest, where a sinc's side lobe there is over ``floor_db`` (so nothing is read for a grid much
    narrower than the aliases' spacing)."""
    lo, hi = min(az[0], az[-1]), max(az[0], az[-1])
    r_lo, r_hi = min(rg[0], rg[-1]), max(rg[0], rg[-1])
    mid = np.array([float(np.mean(az)), float(np.mean(rg))])
    step = max(float(np.ptp(az)) / 100, 1e-3)
    slope = (history(mid + [step, 0.0])[1] - history(mid)[1]) / step  # Hz per m of azimuth
    if slope == 0:
        return []
    null = irw[0] / SINC_IRW_FACTOR
    names = targets.dtype.names or ()
    nearest: dict[tuple, _EdgeCandidate] = {}
    for row in targets:
        if any(float(row[v]) != 0 for v in ("vx", "vy", "vz") if v in names):
            continue  # a mover focuses where it appears, not at its table position
        p = np.array([float(row["azimuth"]), float(row["range"])])
        if not (lo <= p[0] <= hi and r_lo <= p[1] <= r_hi):
            continue
        label = row["name"].decode() if isinstance(row["name"], bytes) else str(row["name"])
        peak = _window(az, rg, p, 1, 1)
        path_p, f_p = history(p)
        solved = [(m, _solve_alias((p[0] + m * prf / slope, p[1]), (path_p, f_p + m * prf), history)) for m in ORDERS]
        aliases = [(m, q) for m, q in solved if q is not None]
        # the target's responses in the image: itself and its aliases whose main lobe is in it
        responses = [p[0]] + [q[0] for _, q in aliases if lo - irw[0] <= q[0] <= hi + irw[0]]
        for m, q in aliases:
            if lo - irw[0] <= q[0] <= hi + irw[0]:  # its main lobe in the image (or at its edge): a ghost proper
                rows = np.flatnonzero(np.abs(az - q[0]) <= ALIAS_SEARCH_IRW * irw[0])
                if inside and r_lo <= q[1] <= r_hi and rows.size:
                    j = int(np.argmin(np.abs(rg - q[1])))
                    read = slice(int(rows[0]), int(rows[-1]) + 1), slice(max(j - 2, 0), min(j + 3, len(rg)))
                    nearest[("in", label, m)] = _EdgeCandidate(label, m, q, peak, read, None, 0.0, q[1], 0.0)
                continue
            edge = lo if q[0] < lo else hi
            distance = abs(q[0] - edge)
            # the target's own ridge reaches that edge along the same iso-range line, and so do its aliases' in
            # the image (every alias has the target's path): the alias must be nearer the edge than all of them
            known = nearest.get(("edge", label, edge))
            nearer = min(abs(x - edge) for x in responses)
            if distance >= nearer or (known is not None and not distance < known.distance):
                continue
            entry = _on_iso_path(history, path_p, edge, q[1])
            if entry is None or not r_lo <= entry <= r_hi:
                continue
            expected = 20 * math.log10(null / (math.pi * distance))
            read = _window(az, rg, (edge, entry), EDGE_ROWS - 1, EDGE_COLUMNS)
            nearest[("edge", label, edge)] = _EdgeCandidate(label, m, q, peak, read, edge, distance, entry, expected)
    return [f for f in nearest.values() if f.expected_db > floor_db]


def _edge_levels(
    found: list[_EdgeCandidate],
    blocks: list[np.ndarray],
    targets: np.ndarray,
    az: np.ndarray,
    rg: np.ndarray,
    irw: list[float],
    floor_db: float,
) -> list[EdgeAlias]:
    """The candidates measured: ``blocks`` holds |image| on each one's peak window then its read window, in order;
    those over ``floor_db`` (measured, and a sinc's expected), strongest first."""
    own = np.array([[float(t["azimuth"]), float(t["range"])] for t in targets])  # every target's own response
    out = []
    for f, peak_block, block in zip(found, blocks[::2], blocks[1::2]):
        peak = float(peak_block.max())
        if not peak > 0:
            continue
        if f.edge is None:
            strongest = _strongest_in(block, az[f.read[0]], rg[f.read[1]], irw, own)
            if strongest is None:
                continue
            level, entry_az, entry_rg = strongest
            distance, expected = 0.0, 0.0
        else:
            level, entry_az, entry_rg = float(block.max()), f.edge, f.entry_range
            distance, expected = f.distance, f.expected_db
        level_db = 20 * math.log10(level / peak) if level > 0 else -math.inf
        alias = EdgeAlias(f.target, f.order, f.alias[0], f.alias[1], entry_az, entry_rg, distance, level_db, expected)
        out.append(alias)
    out = [a for a in out if a.level_db > floor_db and a.expected_db > floor_db]
    return sorted(out, key=lambda a: -a.level_db)


def _on_iso_path(
    history: Callable[[np.ndarray], tuple[float, float]], path: float, azimuth: float, start: float
) -> float | None:
    """The range at ``azimuth`` whose two-way path (centre pulse) is ``path``, by Newton from ``start``."""
    r = float(start)
    for _ in range(30):
        value = history(np.array([azimuth, r]))[0] - path
        if abs(value) < 1e-4:
            return r
        deriv = (history(np.array([azimuth, r + 1e-2]))[0] - path - value) / 1e-2
        if deriv == 0:
            return None
        r -= value / deriv
    return None


# An alias inside an image whose processing maps positions right only within its declared scene (paper 000's
# flow 2, the NLCS perturbation) lands displaced and defocused: 9-18 m (3.5-7 IRW) from where it peaks in
# backprojection on configs/an2012_exp1.yaml's flow-2 image. Its strongest pixel is read within this many
# azimuth IRWs of that place (and 2 range samples), every target's own main lobe (2 IRW) left out.
ALIAS_SEARCH_IRW = 8.0


def _strongest_in(
    block: np.ndarray, az: np.ndarray, rg: np.ndarray, irw: list[float], own: np.ndarray
) -> tuple[float, float, float] | None:
    """(|pixel|, azimuth, range) of the strongest pixel of ``block`` (|image| on the grid ``az`` x ``rg``) outside
    2 IRWs of every ``own`` (azimuth, range) position; None if all of it is left out."""
    A, R = np.meshgrid(az, rg, indexing="ij")
    keep = np.ones(A.shape, dtype=bool)
    for p in own:
        keep &= (np.abs(A - p[0]) > 2 * irw[0]) | (np.abs(R - p[1]) > 2 * irw[1])
    if not keep.any():
        return None
    w = np.where(keep, block, -1.0)
    k = np.unravel_index(int(np.argmax(w)), w.shape)
    return float(w[k]), float(A[k]), float(R[k])


def listed_at_aliases(aliases: list[EdgeAlias], image: Product, entries: Sequence[Mapping[str, float]]) -> list[int]:
    """For each alias, the index into ``entries`` (false targets' image-sample positions, {dim: sample}) of the
    first within EDGE_ROWS rows and EDGE_COLUMNS + 1 range samples of where its side lobes enter (-1: none)."""
    az = np.asarray(image.coords["azimuth"], float)
    rg = np.asarray(image.coords["range"], float)
    out = []
    for a in aliases:
        i, j = int(np.argmin(np.abs(az - a.entry_azimuth))), int(np.argmin(np.abs(rg - a.entry_range)))
        near = [
            k
            for k, e in enumerate(entries)
            if abs(e["azimuth"] - i) <= EDGE_ROWS and abs(e["range"] - j) <= EDGE_COLUMNS + 1
        ]
        out.append(near[0] if near else -1)
    return out
