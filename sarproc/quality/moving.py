"""Moving truth targets in ``evaluate``: measured where they appear, judged against where they are.

Every processor here assumes a static scene, so a point target with a velocity in the truth table
(vx, vy, vz) is focused at its static-equivalent position S (:mod:`sarproc.product.moving`):
``evaluate`` measures it there (from the truth velocity and the image's own geometry: radar
metadata, track, frame), never at its true position. Per moving target the report adds
(:class:`MoverReport`):

* the truth: position at azimuth time 0, (v_a, v_r), illumination-centre time t_c, S;
* the product's estimate, when it holds one, from (first found)
  1. its ``moving_targets`` table: reconstruct's aux ``moving_targets`` (model.MOVING_TARGET_COLUMNS:
     ``v_r``, ``v_a``, ``apparent_x/y/z``, ``relocated_x/y/z``, ``truth_index``), else a structured
     array or list of mappings in ``attrs['moving_targets']`` with the same names (``truth``: the
     matched truth target's name). A row names its truth target, or is matched to the nearest truth S within
     ``MATCH_CELLS`` resolution cells of its apparent position;
  2. else ``reconstruct``'s per-window estimates (``attrs['reconstruct']['moving_targets']``, which
     ``backproject`` carries into the image): matched to a truth target by where it appears, the
     window's slant range at its beam-centre time and that time (within the window's half length
     plus ``MATCH_CELLS`` cells, and ``MATCH_CELLS`` azimuth cells), never by velocity;
* velocity errors (estimate - truth); the relocated position (the table's, else the measured peak
  taken back to time 0 with the estimated velocity, :func:`sarproc.product.moving.relocate`) and its
  error against the true position; and the relocation error the velocity error alone implies
  (first order, R |dv_los| / (v cos(theta)), dv_los = dv_r cos(theta) + dv_a sin(theta));
* the relocation's bound and verdict (:func:`relocation_check`, also written by reconstruct into its
  ``truth`` record for every matched mover).

Without an estimate (a single-channel image: nothing estimates velocities) the velocity and
relocation fields are None and ``estimate`` says 'none'.
"""

from __future__ import annotations

import dataclasses
import math
from typing import TYPE_CHECKING, Any

import numpy as np

from sarproc.product import moving
from sarproc.product.errors import InputError
from sarproc.product.metadata import C

if TYPE_CHECKING:
    from collections.abc import Collection, Sequence

    from sarproc.product.frames import Frame
    from sarproc.product.metadata import RadarMetadata
    from sarproc.product.model import Product
    from sarproc.quality.metrics import QualityReport

MATCH_CELLS = 10.0  # association gate between a detection and a truth mover, resolution cells


@dataclasses.dataclass(frozen=True)
class MoverReport:
    """One moving truth target (lengths m, velocities m/s, times s; positions in the scene frame)."""

    name: str
    true_position: tuple  # x, y, z at azimuth time 0
    v_a: float  # truth along-track velocity
    v_r: float  # truth slant-range velocity (zero-Doppler direction)
    centre_time: float  # illumination-centre time t_c
    apparent_position: tuple  # S, the static equivalent (where it was measured)
    apparent_coords: dict  # S in the image frame, {axis: value}
    shift: float  # |S - true position at t_c|
    measured_position: tuple  # the measured peak, scene frame
    estimate: str = "none"  # 'moving_targets' | 'reconstruct' | 'none'
    v_a_estimated: float | None = None
    v_r_estimated: float | None = None
    v_a_error: float | None = None
    v_r_error: float | None = None
    relocated_position: tuple | None = None
    relocation: str = ""  # 'table' | 'measured peak + estimated velocity' | ''
    relocation_error: float | None = None  # |relocated - true position|
    relocation_error_xyz: tuple | None = None
    relocation_error_from_velocity: float | None = None  # first-order implied by the velocity error
    # the relocation's bound and verdict (relocation_check): |start - S|, the velocity error's own relocation error
    # (S relocated with the estimated velocity, against the truth), their sum and whether relocation_error is within
    apparent_position_error: float | None = None
    velocity_relocation_error: float | None = None
    relocation_bound: float | None = None
    relocation_within_bound: bool | None = None
    # the velocity error's residual channel phase (rad, largest over the channels; eq. 8 term 2) and the first-order
    # false-target level it leaves (dB, eq. 6; -inf without an error): filled in by the multichannel reconstruction's
    # sarproc.focus.multichannel.channels.ghost_predictions where the image records its channels
    channel_phase_from_velocity: float | None = None
    ghost_level_from_velocity_db: float | None = None


def truth_frame(product: Product, source: str = "") -> Frame:
    from sarproc.product.frames import frame_from_spec

    where = f"{source}: " if source else ""
    spec = product.attrs.get("frame")
    if spec is None:
        raise InputError(
            f"{where}image attribute 'frame' is missing: its moving targets cannot be placed where they appear"
        )
    return frame_from_spec(spec)


def apparent_truth(product: Product, source: str = "") -> np.ndarray:
    """The product's targets table with every moving target at its static equivalent (image frame)."""
    targets = product.targets
    if len(targets) == 0 or not np.any(moving.is_moving(targets)):
        return targets
    where = f"{source}: " if source else ""
    if "platform_position" not in product.aux:
        raise InputError(
            f"{where}aux 'platform_position' is missing: the moving target(s) "
            f"{_names(targets[moving.is_moving(targets)])} cannot be placed where they appear"
        )
    return moving.apparent_targets(
        targets, product.radar, moving.pulse_times(product), truth_frame(product, source), moving.phase_centres(product)
    )


def _names(table: np.ndarray) -> str:
    return ", ".join(n.decode() if isinstance(n, bytes) else str(n) for n in table["name"])


def _rows(table: Any) -> list[dict]:
    if table is None:
        return []
    if isinstance(table, np.ndarray) and table.dtype.names:
        return [
            {
                k: (v.decode() if isinstance(v, bytes) else v.item() if hasattr(v, "item") else v)
                for k, v in zip(table.dtype.names, row)
            }
            for row in table
        ]
    return [dict(r) for r in table]


def _xyz(row: dict, prefix: str) -> np.ndarray | None:
    keys = [f"{prefix}_{c}" for c in "xyz"]
    if all(k in row for k in keys):
        v = np.array([float(row[k]) for k in keys])
        return v if np.all(np.isfinite(v)) else None
    return None


def moving_target_table(product: Product) -> list[dict]:
    """Rows of the product's ``moving_targets`` table (module docstring), [] if it has none.

    reconstruct's table is aux ``moving_targets`` (model.MOVING_TARGET_COLUMNS, float64); its
    ``truth_index`` (row of the targets table, -1 none) becomes the ``truth`` name here."""
    from sarproc.product.model import moving_target_rows, target_names

    if (
        "moving_targets" in product.aux
        and getattr(product.aux["moving_targets"], "dtype", None) is not None
        and not product.aux["moving_targets"].dtype.names
    ):
        names = target_names(product.targets)
        rows = moving_target_rows(product.aux)
        for r in rows:
            k = int(r.get("truth_index", -1))
            r["truth"] = names[k] if 0 <= k < len(names) else ""
        return rows
    for table in (
        getattr(product, "moving_targets", None),
        product.aux.get("moving_targets"),
        product.attrs.get("moving_targets"),
    ):
        rows = _rows(table)
        if rows:
            return rows
    return []


def _match_table(rows: Sequence[dict], movers: Sequence[_TruthMover], cell: float) -> dict[str, dict]:
    """{truth name: row}: by the row's truth column, else the nearest S within MATCH_CELLS cells."""
    out: dict[str, dict] = {}
    for row in rows:
        name = row.get("truth")
        if name:
            out.setdefault(str(name), row)
            continue
        s = _xyz(row, "apparent")
        if s is None:
            continue
        dist = {m.name: float(np.linalg.norm(m.apparent - s)) for m in movers if m.name not in out}
        if dist:
            best = min(dist, key=dist.__getitem__)
            if dist[best] <= MATCH_CELLS * cell:
                out[best] = row
    return out


def implied_relocation_error(radar: RadarMetadata, slant_range: float, dv_a: float, dv_r: float) -> float:
    """First-order relocation error (m, scene) of velocity errors: R |dv_los| / (v cos(theta))."""
    th = radar.squint
    return abs(slant_range * (dv_r * math.cos(th) + dv_a * math.sin(th)) / (radar.velocity * math.cos(th)))


def relocation_check(
    radar: RadarMetadata,
    times: np.ndarray,
    positions: np.ndarray,
    truth_xyz: np.ndarray,
    truth_apparent: np.ndarray,
    start: np.ndarray,
    relocated: np.ndarray,
    v_a: float,
    v_r: float,
) -> dict[str, Any]:
    """A relocated mover against the truth, with the bound its errors allow (lengths m, scene frame).

    The relocated position is f(start, v): the relocation map f (:func:`sarproc.product.moving.relocate`) of the
    apparent position the relocation started from (reconstruct's table: its apparent position; evaluate without a
    table: the measured peak) with the estimated velocity v = (``v_a``, ``v_r``); the truth position is
    f(S, v_true), S its static equivalent (``truth_apparent``). Then f(start, v) - truth = [f(start, v) - f(S, v)]
    + [f(S, v) - truth]: f moves a point by a shift of the velocity (a near-translation, Jacobian identity +
    O(|v| / v_platform)), so the first term is at most the apparent-position error |start - S| times
    (1 + |v| / v_platform), and the second is the velocity error's own relocation error, computed exactly (S
    relocated with v). The bound is their sum (triangle inequality) plus twice relocate's convergence tolerance
    (two relocated positions, each within RELOCATE_TOLERANCE of its fixed point): every term measured or stated by
    the method, nothing allowed for by hand. Returns ``relocation_error``
    (|relocated - truth|), ``apparent_position_error``, ``velocity_relocation_error``, ``relocation_bound`` and
    ``relocation_within_bound``; the last three None where S cannot be relocated with v (no convergence)."""
    truth_xyz, s = np.asarray(truth_xyz, float).reshape(3), np.asarray(truth_apparent, float).reshape(3)
    out: dict[str, Any] = {
        "relocation_error": float(np.linalg.norm(np.asarray(relocated, float).reshape(3) - truth_xyz)),
        "apparent_position_error": float(np.linalg.norm(np.asarray(start, float).reshape(3) - s)),
        "velocity_relocation_error": None,
        "relocation_bound": None,
        "relocation_within_bound": None,
    }
    try:
        at_s = moving.relocate(radar, times, s, moving.scene_velocity(s, v_a, v_r, radar.altitude), positions)
    except InputError:
        return out
    velocity_term = float(np.linalg.norm(at_s - truth_xyz))
    speed = math.hypot(v_a, v_r)  # |v| (m/s), the relocation map's departure from a translation per v_platform
    apparent_term = out["apparent_position_error"] * (1 + speed / radar.velocity)
    bound = velocity_term + apparent_term + 2 * moving.RELOCATE_TOLERANCE
    out.update(
        velocity_relocation_error=velocity_term,
        relocation_bound=bound,
        relocation_within_bound=bool(out["relocation_error"] <= bound),
    )
    return out


def _match_windows(
    windows: Sequence[dict], movers: Sequence[_TruthMover], radar: RadarMetadata, cell_range: float, cell_azimuth: float
) -> dict[str, dict]:
    """{truth name: window}: reconstruct's windows matched by slant range at t_c and t_c."""
    out = {}
    range_cell = C / (2 * radar.range_sampling_rate)
    for w in windows:
        half = 0.5 * (w.get("last_cell", 0) - w.get("first_cell", 0)) * range_cell
        best, best_cost = None, math.inf
        for m in movers:
            if m.name in out:
                continue
            d_range = abs(m.slant_range - float(w["slant_range"]))
            d_az = abs(m.centre_time - float(w["beam_centre_time"])) * radar.velocity
            if d_range <= half + MATCH_CELLS * cell_range and d_az <= MATCH_CELLS * cell_azimuth:
                cost = d_range / cell_range + d_az / cell_azimuth
                if cost < best_cost:
                    best, best_cost = m.name, cost
        if best is not None:
            out[best] = w
    return out


@dataclasses.dataclass(frozen=True)
class _TruthMover:
    """A moving truth target measured in the report: where it is, how it moves, where the image shows it."""

    name: str
    k: int  # its row in the targets table
    xyz: np.ndarray  # true position at azimuth time 0 (m)
    vel: np.ndarray  # velocity (m/s)
    apparent: np.ndarray  # its static equivalent S (m)
    centre_time: float  # illumination-centre time t_c (s)
    slant_range: float  # |S - phase centre at t_c| (m)


def mover_reports(
    product: Product, apparent: np.ndarray, report: QualityReport, source: str = ""
) -> tuple[MoverReport, ...]:
    """One :class:`MoverReport` per moving truth target measured in ``report`` (module docstring).

    Steps: :func:`_truth_movers` (the measured movers), their estimates matched (:func:`_match_table` to the
    product's moving_targets table, else :func:`_match_windows` to reconstruct's windows), then
    :func:`_mover_report` for each."""
    targets = product.targets
    if len(targets) == 0 or not np.any(moving.is_moving(targets)):
        return ()
    radar = product.radar
    frame = truth_frame(product, source)
    times = moving.pulse_times(product)
    positions = moving.phase_centres(product)
    measured = {t.name: t for t in report.targets}
    irw = [float(v) for v in product.attrs.get("theoretical_irw", [])]
    cell_az = irw[list(product.dims).index("azimuth")] if "azimuth" in product.dims and irw else 1.0
    cell_rg = irw[list(product.dims).index("range")] if "range" in product.dims and irw else 1.0
    movers = _truth_movers(targets, apparent, measured, radar, times, positions)
    table = moving_target_table(product)
    if table:
        source_name, matched = "moving_targets", _match_table(table, movers, max(cell_az, cell_rg))
    else:
        windows = (product.attrs.get("reconstruct") or {}).get("moving_targets") or []
        source_name = "reconstruct"
        matched = _match_windows(windows, movers, radar, cell_rg, cell_az)
    out = []
    for m in movers:
        t = measured[m.name]
        coords = {d: float(t.axis(d).position) for d in product.dims}
        peak = np.asarray(frame.to_xyz(*[coords[d] for d in frame.axes]), float).reshape(3)
        apparent_coords = {d: float(apparent[d][m.k]) for d in product.dims}
        est = matched.get(m.name)
        out.append(_mover_report(m, peak, apparent_coords, est, source_name, radar, times, positions))
    return tuple(out)


def _truth_movers(
    targets: np.ndarray,
    apparent: np.ndarray,
    measured: Collection[str],
    radar: RadarMetadata,
    times: np.ndarray,
    positions: np.ndarray,
) -> list[_TruthMover]:
    """The moving truth targets whose names are ``measured``, in table order, with their static equivalents
    (``apparent``, the targets table where the image shows them) and illumination centres."""
    movers: list[_TruthMover] = []
    for k in np.nonzero(moving.is_moving(targets))[0]:
        name = targets["name"][k].decode() if isinstance(targets["name"][k], bytes) else str(targets["name"][k])
        if name not in measured:
            continue
        xyz = np.array([targets[c][k] for c in "xyz"], float)
        vel = np.array([targets[f"v{c}"][k] for c in "xyz"], float)
        s = np.array([apparent[c][k] for c in "xyz"], float)
        t_c = moving.illumination_centre_time(radar, times, xyz, vel, positions)
        p_c = np.array([np.interp(t_c, times, positions[:, i]) for i in range(3)])
        movers.append(_TruthMover(name, int(k), xyz, vel, s, t_c, float(np.linalg.norm(s - p_c))))
    return movers


def _mover_report(
    m: _TruthMover,
    peak: np.ndarray,
    apparent_coords: dict[str, float],
    est: dict | None,
    source_name: str,
    radar: RadarMetadata,
    times: np.ndarray,
    positions: np.ndarray,
) -> MoverReport:
    """The :class:`MoverReport` of truth mover ``m`` measured at ``peak`` (scene xyz), with its matched estimate
    ``est`` (a row of ``source_name``'s table or window; None: not estimated): velocity errors and relocation (the
    table's relocated position, else the measured peak moved by the estimated velocity)."""
    v_a, v_r = moving.slant_velocity(m.xyz, m.vel, radar.altitude)
    fields: dict[str, Any] = dict(
        name=m.name,
        true_position=tuple(m.xyz),
        v_a=v_a,
        v_r=v_r,
        centre_time=m.centre_time,
        apparent_position=tuple(m.apparent),
        apparent_coords=apparent_coords,
        shift=float(np.linalg.norm(m.apparent - (m.xyz + m.vel * m.centre_time))),
        measured_position=tuple(float(c) for c in peak),
    )
    if est is not None:
        e_vr = float(est.get("v_r", est.get("radial_velocity", math.nan)))
        e_va = float(est.get("v_a", est.get("along_track_velocity", math.nan)))
        relocated = _xyz(est, "relocated") if source_name == "moving_targets" else None
        how, start = "table", _xyz(est, "apparent")
        if relocated is None and math.isfinite(e_vr) and math.isfinite(e_va):
            e_vel = moving.scene_velocity(peak, e_va, e_vr, radar.altitude)
            relocated = moving.relocate(radar, times, peak, e_vel, positions)
            how, start = "measured peak + estimated velocity", peak
        implied = implied_relocation_error(radar, m.slant_range, e_va - v_a, e_vr - v_r)
        fields.update(
            estimate=source_name,
            v_a_estimated=e_va,
            v_r_estimated=e_vr,
            v_a_error=e_va - v_a,
            v_r_error=e_vr - v_r,
            relocation_error_from_velocity=implied,
        )
        if relocated is not None:
            err = relocated - m.xyz
            fields.update(
                relocated_position=tuple(float(c) for c in relocated),
                relocation=how,
                relocation_error=float(np.linalg.norm(err)),
                relocation_error_xyz=tuple(float(c) for c in err),
            )
            if start is not None and math.isfinite(e_vr) and math.isfinite(e_va):
                check = relocation_check(radar, times, positions, m.xyz, m.apparent, start, relocated, e_va, e_vr)
                fields.update({k: v for k, v in check.items() if k != "relocation_error"})
    return MoverReport(**fields)
