"""The ``pfa2`` chain (Nie 2016): raw product -> ground image in the ``ground_los`` frame.

range compression + motion compensation to the scene centre with the recorded gate (eq. 3,
:mod:`.phase_history`) -> sliding-spotlight de-aliasing by sub-apertures (Fig. 2,
:mod:`.dealias`) -> PFA with line-of-sight polar interpolation (eqs. 4-6, :mod:`.polar`),
either alone (``method: plain``) or as the first step of the beam-segmentation two-step PFA
(``method: two_step``, Figs. 3-5, :mod:`.two_step`).
"""

from __future__ import annotations

import dataclasses
import logging
import math
import time
from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np

from sarproc.dsp.interp import KERNELS
from sarproc.dsp.rangecomp import WINDOWS
from sarproc.focus.pfa import dealias as dealias_mod
from sarproc.focus.pfa.correction import (
    PfaGeometry,
    distortion_field,
    extended_grid,
    pfa_distortions,
    warp_to_truth,
)
from sarproc.focus.pfa.phase_history import compensate
from sarproc.focus.pfa.polar import (
    Grid,
    Interpolation,
    KGrid,
    Rect,
    data_sampling,
    inscribed_support,
    los_components,
    make_kgrid,
    pfa,
    polar_support,
    rectangle_range_theory,
    wavenumbers,
)
from sarproc.focus.pfa.two_step import (
    SubImageTask,
    Tile,
    TileSupport,
    grown_slices,
    lit_pulses,
    local_irw,
    mosaic,
    own_range_theory,
    partition_weights,
    plan_tiles,
    pslr_rise_db,
    run_tasks,
    tile_rects,
    track_corner_phase,
    track_pslr_rise_db,
    track_radius,
    track_residual,
    valid_radius,
    window_slices,
)
from sarproc.product.config import as_dict, param
from sarproc.product.errors import IMAGE_DEFECT, InputError
from sarproc.product.frames import GroundLosFrame, image_axis, make_frame, targets_in_frame
from sarproc.product.metadata import SINC_IRW_FACTOR, aperture_center_position
from sarproc.product.model import Product, target_names
from sarproc.product.theory import fill_target_theory, window_theory

if TYPE_CHECKING:
    from collections.abc import Iterator, Mapping, Sequence
    from typing import Any

    from sarproc.focus.pfa.phase_history import PhaseHistory
    from sarproc.product.metadata import RadarMetadata
    from sarproc.product.steps import ProgressFactory

log = logging.getLogger(__name__)

METHODS = ("plain", "two_step")


@dataclasses.dataclass(frozen=True)
class Pfa2Params:
    """``pfa2:`` section."""

    method: str = param(default="two_step", choices=METHODS, doc="plain PFA, or two-step beam-segmentation PFA")
    azimuth_extent: float | None = param(
        "length",
        default=None,
        gt=0,
        doc="image size along azimuth (x'); default: the targets' span plus 2 x margin_cells",
    )
    range_extent: float | None = param("length", default=None, gt=0, doc="image size along ground range (y')")
    azimuth_center: float | None = param(
        "length", default=None, doc="image centre, frame azimuth; default: middle of the targets, else the scene centre"
    )
    range_center: float | None = param("length", default=None, doc="image centre, frame range")
    azimuth_spacing: float | None = param("length", default=None, gt=0, doc="default: theoretical IRW / oversample")
    range_spacing: float | None = param("length", default=None, gt=0, doc="default: theoretical IRW / oversample")
    oversample: float = param(default=2.0, ge=1.05, doc="pixels per theoretical IRW for default spacings")
    margin_cells: float = param(default=24.0, ge=0, doc="resolution cells around the targets for default extents")
    range_window: str = param(default="none", choices=WINDOWS, doc="range spectral taper")
    range_oversampling: float = param(
        default=2.0,
        ge=1.2,
        le=8,
        doc=("range FFT length over the recorded window: how finely the band is sampled for the range interpolation"),
    )
    range_kernel: str = param(default="knab", choices=KERNELS, doc="range (line-of-sight) interpolation kernel")
    range_kernel_length: int = param(default=8, ge=1, le=64, doc="taps of the range kernel (windowed sincs)")
    azimuth_kernel: str = param(default="knab", choices=KERNELS, doc="azimuth interpolation kernel")
    azimuth_kernel_length: int = param(default=8, ge=1, le=64, doc="taps of the azimuth kernel")
    subimage_size: float | None = param(
        "length", default=None, gt=0, doc=("two_step: side of a sub-image's core; default the valid radius of eq. (7)")
    )
    subimage_overlap: float = param(
        default=0.25,
        ge=0,
        le=4,
        doc=("two_step: extra window around each core, as a fraction of the core (the paper: 512 of 2048 = 0.25)"),
    )
    subimage_reach: float = param(
        default=0.5,
        ge=0,
        le=1,
        doc=(
            "two_step: how far each sub-image's output reaches past its core, as a fraction of the core; above 0 "
            "the step-1 image is cut into a partition of unity (pieces blended across each seam), each piece "
            "focused onto its core grown by this much and the pieces added, so that a target's far ridges "
            "cross the seams; 0: each sub-image returns its core alone (ridges stop at the seams). 0.5 against 0: "
            "residual floor -38.5 -> -46.1 dB on Table 1 (nie2016) for 1.42x the two-step's wall (docs/pfa.md, "
            "sessions 45-46)"
        ),
    )
    subimage_oversampling: float = param(
        default=1.5,
        ge=1.1,
        le=4,
        doc=("two_step: sampling of a sub-image's decimated signal over what its window's extent needs"),
    )
    valid_radius_factor: float = param(default=1.3, gt=0, doc="K_a of eq. (7), main-lobe broadening factor")
    track_phase_budget: float = param(
        default=0.0126,
        gt=0,
        doc=(
            "two_step: largest phase error (rad) a curved track's planar-wavefront residual may leave at a "
            "sub-image's corner; the default sub-image is shrunk below eq. (7) to keep it (0.0126 rad: a PSLR "
            "rises by 0.25 dB at most)"
        ),
    )
    correct_distortion: bool = param(
        default=False,
        doc=(
            "plain: read the image back at the planar-wavefront distortion of every pixel (true geometry, "
            "phase 0 at each peak); off, plain PFA's image is the paper's, distortion included"
        ),
    )
    dealias: str = param(
        default="auto",
        choices=dealias_mod.MODES,
        doc=(
            "sliding-spotlight sub-aperture de-aliasing (Fig. 2): auto (when the deramped scene band exceeds the PRF), "
            "on, off"
        ),
    )
    subaperture_pulses: int | None = param(
        default=None, ge=8, doc="de-aliasing sub-aperture length; default from the beam's footprint and slide"
    )
    upsample: int | None = param(
        default=None, ge=1, le=64, doc="de-aliasing upsampling factor; default: enough for the whole deramped band"
    )
    block_pulses: int = param(default=256, ge=1, doc="pulses per range-compression block (memory bound)")


def antenna_positions(raw: Product) -> np.ndarray:
    """Phase centres of a monostatic raw product (n_pulses, 3), m."""
    pos = np.asarray(raw.aux["platform_position"], float)
    tx = np.asarray(raw.aux.get("tx_offset", np.zeros(3)), float).reshape(3)
    rx = np.asarray(raw.aux.get("rx_offset", np.zeros((1, 3))), float).reshape(-1, 3)
    if len(rx) != 1:
        raise InputError(f"pfa2: needs one receive channel, the product has {len(rx)}")
    return pos + (tx + rx[0]) / 2


def image_frame(raw: Product) -> GroundLosFrame:
    spec = raw.attrs.get("frame")
    if isinstance(spec, dict) and spec.get("name") == "ground_los":
        frame = make_frame("ground_los", raw.radar, **{k: v for k, v in spec.items() if k != "name"})
    else:
        frame = make_frame(
            "ground_los", raw.radar, origin=raw.radar.scene_center, aperture_center=aperture_center_position(raw.radar)
        )
    assert isinstance(frame, GroundLosFrame)
    return frame


def check_polar_support(raw: Product) -> None:
    """Raise InputError (:func:`inscribed_support`'s reason) where the pulses' polar supports, over the chirp
    band, share no rectangle in the image frame: what pfa2 would find after range compression, told by --dry-run
    from the header (the pulses' positions) before any data is read."""
    frame = image_frame(raw)
    ua, ur = los_components(antenna_positions(raw), frame.origin, frame.u_azimuth, frame.u_range)
    half = 0.5 * float(raw.radar.bandwidth)
    inscribed_support(ua, ur, float(raw.radar.carrier_frequency), np.array([-half, half]))


def output_grid(params: Pfa2Params, raw: Product, frame: GroundLosFrame, irw: Sequence[float]) -> Grid:
    """Image grid (offsets from the frame origin along e_a, e_r)."""
    t = targets_in_frame(raw.targets, frame)
    coords = {"azimuth": t["azimuth"], "range": t["range"] - frame.ground_range}
    axes = []
    for i, ax in enumerate(("azimuth", "range")):
        centre = getattr(params, f"{ax}_center")
        if centre is not None and ax == "range":
            centre -= frame.ground_range
        centre, spacing, n = image_axis(
            coords[ax],
            irw[i],
            params.oversample,
            params.margin_cells,
            getattr(params, f"{ax}_spacing"),
            centre,
            getattr(params, f"{ax}_extent"),
        )
        axes.append((centre - (n // 2) * spacing, spacing, n))
    return Grid(*axes[0], *axes[1])


def _interp(params: Pfa2Params, azimuth_oversampling: float) -> Interpolation:
    return Interpolation(
        params.range_kernel,
        params.range_kernel_length,
        params.azimuth_kernel,
        params.azimuth_kernel_length,
        azimuth_oversampling,
    )


def pfa2(
    raw: Product,
    params: Pfa2Params = Pfa2Params(),
    progress: ProgressFactory | None = None,
    mapper: Callable | None = None,
) -> Product:
    """Focus a raw product with the paper 002 chain; returns an ``image`` product (ground_los frame)."""
    if raw.kind != "raw":
        raise InputError(f"pfa2 needs a single-channel raw product, got {raw.kind!r}")
    timing = {}
    t_all = time.perf_counter()
    radar = raw.radar
    frame = image_frame(raw)
    origin = frame.origin
    e_a, e_r = frame.u_azimuth, frame.u_range
    pos = antenna_positions(raw)
    t0 = time.perf_counter()
    ph = compensate(
        raw.data,
        raw.coords["range_time"],
        pos,
        radar,
        origin,
        raw.aux.get("range_gate_offset"),
        raw.coords["azimuth_time"],
        range_window=params.range_window,
        range_oversampling=params.range_oversampling,
        block_pulses=params.block_pulses,
    )
    timing["range_compression_moco"] = time.perf_counter() - t0
    ua, ur = los_components(ph.positions, origin, e_a, e_r)
    rect = inscribed_support(ua, ur, ph.carrier_frequency, ph.freqs)
    irw = _rect_irw(rect)
    grid = output_grid(params, raw, frame, irw)
    t0 = time.perf_counter()
    ph, alias = dealias_mod.dealias(
        ph, radar, e_a, e_r, grid, params.dealias, params.subaperture_pulses, params.upsample
    )
    timing["dealias"] = time.perf_counter() - t0
    az_os = max(1.05, alias["azimuth_oversampling"])
    attrs: dict[str, Any] = {"method": params.method, "dealias": alias}
    t0 = time.perf_counter()
    if params.method == "plain" and params.correct_distortion:
        img, kg = _plain_corrected(ph, rect, grid, origin, e_a, e_r, _interp(params, az_os))
        timing["pfa"] = time.perf_counter() - t0
    elif params.method == "plain":
        img, kg = pfa(ph, e_a, e_r, grid, rect=rect, interp=_interp(params, az_os))
        timing["pfa"] = time.perf_counter() - t0
    else:
        img, kg, info = _two_step(ph, params, grid, origin, e_a, e_r, radar, az_os, progress, mapper, timing)
        attrs.update(info)
    timing["total"] = time.perf_counter() - t_all
    radius = valid_radius(
        2 * math.pi / kg.spans[0],
        float(np.linalg.norm(pos[len(pos) // 2] - origin)),
        radar.wavelength,
        params.valid_radius_factor,
    )
    attrs.update(
        {
            "frame": frame.spec,
            "theoretical_irw": list(kg.irw()),
            "valid_radius": radius,
            "support_rectangle": [kg.ka0, kg.dka, kg.n_ka, kg.kr0, kg.dkr, kg.n_kr],
            "stage_seconds": timing,
        }
    )
    from sarproc.product.io import history_entry  # product layer; the core stays free of h5py at import

    targets = targets_in_frame(raw.targets, frame)
    attrs["target_distance"] = target_distances(targets, frame)
    if params.method == "plain":
        attrs["focus_limits"] = _plain_limits(targets, frame, grid, radius, ph, rect, params)
    _record_target_theory(targets, ph, e_a, e_r, kg, params, radar)
    out = raw.derive(
        "image",
        img,
        ("azimuth", "range"),
        {"azimuth": grid.a, "range": grid.r + frame.ground_range},
        targets=targets,
        attrs=attrs,
    )
    out.aux = {k: v for k, v in raw.aux.items() if k in ("platform_position", "tx_offset", "rx_offset")}
    from sarproc.focus.backprojection_alias import edge_alias_warning

    message, edge = edge_alias_warning(out)  # target aliases' side lobes entering from beyond the azimuth edges
    if message:
        log.warning("pfa2: %s", message, extra=IMAGE_DEFECT)
    out.history.append(history_entry("pfa2", {**as_dict(params), "azimuth_edge_aliases": edge}))
    return out


def _plain_corrected(
    ph: PhaseHistory,
    rect: Rect,
    grid: Grid,
    origin: np.ndarray,
    e_a: np.ndarray,
    e_r: np.ndarray,
    interp: Interpolation,
) -> tuple[np.ndarray, KGrid]:
    """Plain PFA on a grid grown by the distortion, read back at each pixel's distorted position."""
    ua, ur = los_components(ph.positions, origin, e_a, e_r)
    k_max = float(wavenumbers(ph.carrier_frequency, ph.freqs[-1]))
    geo = PfaGeometry(
        ph.positions,
        np.asarray(origin, float),
        np.asarray(e_a),
        np.asarray(e_r),
        ph.carrier_frequency,
        (float(ph.freqs[0]), float(ph.freqs[-1])),
    )
    dka, dkr = data_sampling(ua, ur, k_max, ph.freq_step)
    kg0, _ = make_kgrid(rect, dka, dkr, grid.da, grid.dr, grid.n_a, grid.n_r)
    warp = distortion_field(geo, kg0, grid)
    ext = extended_grid(grid, warp)
    kg, _ = make_kgrid(rect, dka, dkr, ext.da, ext.dr, ext.n_a, ext.n_r)
    img, _ = pfa(ph, e_a, e_r, ext, kgrid=kg, interp=interp)
    return warp_to_truth(img, ext, grid, warp, geo, kg, interp), kg


@dataclasses.dataclass(frozen=True)
class RadiusReach:
    """How far an image and its targets reach from the PFA reference, against eq. (7)'s valid radius (m)."""

    radius: float
    image_reach: float  # the farthest pixel's distance
    beyond: dict[str, float]  # the targets farther than the radius: name -> distance

    @property
    def exceeded(self) -> bool:
        return self.image_reach > self.radius or bool(self.beyond)


def radius_reach(grid: Grid, radius: float, distances: Mapping[str, float]) -> RadiusReach:
    """Distance of the grid's farthest corner, and the targets of ``distances`` (name -> m from the reference,
    :func:`target_distances`) beyond ``radius``."""
    reach = max(
        math.hypot(x, y)
        for x in (grid.a0, grid.a0 + (grid.n_a - 1) * grid.da)
        for y in (grid.r0, grid.r0 + (grid.n_r - 1) * grid.dr)
    )
    return RadiusReach(radius, reach, {n: d for n, d in distances.items() if d > radius})


def target_distances(targets: np.ndarray, frame: GroundLosFrame) -> dict[str, float]:
    """Each target's distance from the scene centre (the frame's reference O), m, in the ground plane."""
    dist = np.hypot(targets["azimuth"], targets["range"] - frame.ground_range)
    return {n: float(d) for n, d in zip(target_names(targets), dist)}


def radius_message(reach: RadiusReach, factor: float, shown: int = 8) -> str:
    """The warning that a plain PFA image reaches past eq. (7)'s valid radius, naming the targets beyond it."""
    r = reach.radius
    msg = (
        f"plain PFA focuses within eq. (7)'s valid radius, {r:.4g} m around the scene reference (main lobe "
        f"broadened by up to valid_radius_factor = {factor:g} there; the defocus grows as the distance squared); "
        f"this image reaches {reach.image_reach:.4g} m ({reach.image_reach / r:.2f} radii)"
    )
    if reach.beyond:
        far = sorted(reach.beyond.items(), key=lambda kv: (-round(kv[1], 6), kv[0]))
        listed = ", ".join(f"{n} {d:.4g} m ({d / r:.2f} radii)" for n, d in far[:shown])
        more = f" and {len(far) - shown} more" if len(far) > shown else ""
        msg += f"; {len(far)} target(s) lie beyond it, their responses defocused: {listed}{more}"
    return msg + "; method: two_step focuses the whole scene"


def _plain_limits(
    targets: np.ndarray,
    frame: GroundLosFrame,
    grid: Grid,
    radius: float,
    ph: PhaseHistory,
    rect: Rect,
    params: Pfa2Params,
) -> dict[str, Any]:
    """Plain PFA's limits on this image, warned about and recorded (``focus_limits``) for evaluate: how far the
    image reaches from the scene centre and the targets beyond eq. (7)'s valid radius (the image's own
    ``valid_radius`` attribute), and (``correct_distortion`` off) each static target's predicted
    planar-wavefront displacement (m, azimuth and range), which its position error then includes."""
    names = target_names(targets)
    reach = radius_reach(grid, radius, target_distances(targets, frame))
    if reach.exceeded:
        log.warning("pfa2: %s", radius_message(reach, params.valid_radius_factor), extra=IMAGE_DEFECT)
    limits: dict[str, Any] = {"image_reach": reach.image_reach, "beyond_valid_radius": reach.beyond}
    if not params.correct_distortion and len(targets):
        # a mover is imaged at its static equivalent, not at its table position: no prediction for it here
        fields = [v for v in ("vx", "vy", "vz") if v in (targets.dtype.names or ())]
        static = [i for i in range(len(targets)) if not any(float(targets[v][i]) for v in fields)]
        points = np.array([[targets[c][i] for c in ("x", "y", "z")] for i in static], float).reshape(-1, 3)
        where = pfa_distortions(
            ph.positions, frame.origin, points, frame.u_azimuth, frame.u_range, ph.carrier_frequency, ph.freqs, rect
        )
        limits["distortion_uncorrected"] = {
            names[i]: [
                d.azimuth - float(targets["azimuth"][i]),
                d.range - (float(targets["range"][i]) - frame.ground_range),
            ]
            for i, d in zip(static, where)
        }
    return limits


def _record_target_theory(
    targets: np.ndarray,
    ph: PhaseHistory,
    e_a: np.ndarray,
    e_r: np.ndarray,
    kg: KGrid,
    params: Pfa2Params,
    radar: RadarMetadata,
) -> None:
    """Fill each target's theory (irw_, null_, pslr_, islr_<axis>, in place): a flat azimuth support and the
    range window over the polar support it is focused with, the image's rectangle (plain) or its own
    inscribed one (two_step: each sub-image keeps its own support, so the IRW varies over the scene)."""
    band = (float(ph.freqs[0]), float(ph.freqs[-1]))
    shapes = (window_theory("none"), window_theory(params.range_window))
    nulls: Sequence[float] = [x / SINC_IRW_FACTOR for x in kg.irw()]
    if params.method != "two_step" and params.range_window != "none":
        # the taper rides on each pulse's band, of which the rectangle keeps the middle: a truncated window
        ua, ur = los_components(ph.positions, ph.reference, e_a, e_r)
        rng = rectangle_range_theory(kg, ua, ur, ph.carrier_frequency, radar.bandwidth, params.range_window)
        fill_target_theory(targets, ("azimuth", "range"), [[shapes[0].scaled(nulls[0]), rng]] * len(targets))
        return
    own = []
    for i in range(len(targets)):
        if params.method == "two_step":
            point = np.array([targets["x"][i], targets["y"][i], targets["z"][i]], float)
            lit = lit_pulses(radar, ph.positions, point)
            nulls = local_irw(ph.positions, point, e_a, e_r, ph.carrier_frequency, band, factor=1.0, lit=lit)
            if params.range_window != "none":  # its own rectangle keeps the middle of the tapered band
                own.append(
                    [
                        shapes[0].scaled(nulls[0]),
                        own_range_theory(
                            ph.positions,
                            point,
                            e_a,
                            e_r,
                            ph.carrier_frequency,
                            band,
                            radar.bandwidth,
                            params.range_window,
                            lit,
                        ),
                    ]
                )
                continue
        own.append([shape.scaled(null) for shape, null in zip(shapes, nulls)])
    fill_target_theory(targets, ("azimuth", "range"), own)


def _rect_irw(rect: Rect) -> tuple[float, float]:
    return SINC_IRW_FACTOR * 2 * math.pi / (rect.ka_hi - rect.ka_lo), SINC_IRW_FACTOR * 2 * math.pi / (
        rect.kr_hi - rect.kr_lo
    )


@dataclasses.dataclass(frozen=True)
class TwoStepScene:
    """What every step of the two-step PFA reads: the compensated phase history and the image frame."""

    ph: PhaseHistory
    grid: Grid  # the output grid (offsets from the origin along e_a, e_r)
    origin: np.ndarray
    e_a: np.ndarray
    e_r: np.ndarray

    @property
    def band(self) -> tuple[float, float]:
        return float(self.ph.freqs[0]), float(self.ph.freqs[-1])

    def los(self) -> tuple[np.ndarray, np.ndarray]:
        return los_components(self.ph.positions, self.origin, self.e_a, self.e_r)


@dataclasses.dataclass(frozen=True)
class SubImageSize:
    """The sub-image core (m) and what bounds it: eq. (7)'s valid radius and a curved track's limit, with the
    range r_ac (m) and K_max (rad/m) that limit is figured from."""

    core: float
    valid_radius: float
    track_residual: float
    track_limit: float  # inf for a track without wiggles
    reference_range: float
    k_max: float

    @property
    def track_pslr_rise(self) -> float:
        """Largest PSLR rise, dB, the track's wiggle can cause on sub-images of this core."""
        return track_pslr_rise_db(self.track_residual, self.reference_range, self.k_max, self.core)


@dataclasses.dataclass(frozen=True)
class FirstStep:
    """Step 1: the whole scene by PFA on the circumscribed support, on pixels covering every window."""

    grid: Grid
    image: np.ndarray
    kgrid: KGrid
    rect: Rect


@dataclasses.dataclass(frozen=True)
class SecondStepLayout:
    """Each sub-image's window (slices of the step-1 grid) and k grid, and the largest window's extent (m)."""

    slices: list[tuple[slice, slice]]
    kgrids: list[KGrid]  # on each sub-image's turned axes (TileSupport)
    angles: list[float]
    content_extent: tuple[float, float]
    margin: tuple[int, int] | None = None  # pixels each output reaches past its core (blended seams)


def _subimage_size(scene: TwoStepScene, params: Pfa2Params, radar: RadarMetadata) -> SubImageSize:
    """Sub-image core: ``subimage_size``, else eq. (7)'s valid radius shrunk to what a curved track allows."""
    ph, origin = scene.ph, scene.origin
    ua, ur = scene.los()
    r_ac = float(np.linalg.norm(ph.positions[len(ph.positions) // 2] - origin))
    rect_in = polar_support(ua, ur, ph.carrier_frequency, ph.freqs, "inscribed")
    radius = valid_radius(
        2 * math.pi / (rect_in.ka_hi - rect_in.ka_lo), r_ac, radar.wavelength, params.valid_radius_factor
    )
    # a curved track's residual (non-polynomial wiggle of the range) bounds the sub-image as well:
    # a core's corners, core / sqrt(2) from its centre, must stay within track_radius
    wiggle = track_residual(ph.positions, origin, scene.e_a, scene.e_r)
    k_max = float(wavenumbers(ph.carrier_frequency, scene.band[1]))
    curved = math.sqrt(2) * track_radius(wiggle, r_ac, k_max, params.track_phase_budget)
    core = params.subimage_size or min(radius, curved)
    if core > curved:
        corner = track_corner_phase(wiggle, r_ac, k_max, core)
        log.warning(
            "pfa2: sub-images of %.3g m exceed the %.3g m that the track's %.3g m wiggle allows: "
            "paired echoes of %.3g rad may raise a PSLR by up to %.2f dB",
            core,
            curved,
            wiggle,
            corner,
            pslr_rise_db(corner),
        )
    return SubImageSize(core, radius, wiggle, curved, r_ac, k_max)


def _first_step_grid(tiles: Sequence[Tile], rect1: Rect) -> Grid:
    """Step-1 pixels: fine enough for the circumscribed support (x 1.15), covering every window (+ 4 pixels)."""
    da1 = 2 * math.pi / ((rect1.ka_hi - rect1.ka_lo) * 1.15)
    dr1 = 2 * math.pi / ((rect1.kr_hi - rect1.kr_lo) * 1.15)
    a_lo = min(t.window[0] for t in tiles)
    a_hi = max(t.window[1] for t in tiles)
    r_lo = min(t.window[2] for t in tiles)
    r_hi = max(t.window[3] for t in tiles)
    return Grid(
        a_lo - 4 * da1,
        da1,
        int(math.ceil((a_hi - a_lo) / da1)) + 9,
        r_lo - 4 * dr1,
        dr1,
        int(math.ceil((r_hi - r_lo) / dr1)) + 9,
    )


def _first_step(scene: TwoStepScene, tiles: Sequence[Tile], interp: Interpolation) -> FirstStep:
    """Step 1: PFA of the whole scene on the circumscribed support (the inverse then loses no polar sample)."""
    ph = scene.ph
    ua, ur = scene.los()
    rect1 = polar_support(ua, ur, ph.carrier_frequency, ph.freqs, "circumscribed")
    g1 = _first_step_grid(tiles, rect1)
    k_max = float(wavenumbers(ph.carrier_frequency, ph.freqs[-1]))
    dka, dkr = data_sampling(ua, ur, k_max, ph.freq_step)
    if g1.n_a * g1.da <= 2 * math.pi / dka:
        # The grid within the data's period: the FFT's period (the data's, rounded up to an FFT length) folds a
        # +-1 PRF alias back near its own target, smeared over the band's spread of periods (-9.6 ... +63 m on
        # nie2016_small), at the data's own ambiguity level (there the image is within -64 dB of the peak of the
        # longer period's below, which would cost Table 1's scene 11.1 -> 17.0 GB peak memory).
        img1, kg1 = pfa(ph, scene.e_a, scene.e_r, g1, rect=rect1, interp=interp)
        return FirstStep(g1, img1, kg1, rect1)
    dka_lo = dka * float(wavenumbers(ph.carrier_frequency, ph.freqs[0])) / k_max  # at the band's bottom
    # A grid wider than the data's period (2 pi / dka, the PRF's: a target's +-1 PRF alias lies that far from it,
    # farthest at the band's lowest frequency) made step 1 repeat at just over the grid, and aliases beyond one
    # edge came back in at the other (E's and SW's, 129 m beyond the image's edges, inside it at -42.4 and -48.6
    # dB: Session 41 new-user trial, 35 GHz, squint -35 deg, PRF 2 kHz; docs/cli.md row 2d). A period of the
    # data's plus the grid's extent puts every such alias beyond the grid.
    period = 2 * math.pi / dka_lo + g1.n_a * g1.da
    kg1, _ = make_kgrid(rect1, 2 * math.pi / period, dkr, g1.da, g1.dr, g1.n_a, g1.n_r)
    img1, kg1 = pfa(ph, scene.e_a, scene.e_r, g1, kgrid=kg1, interp=interp)
    return FirstStep(g1, img1, kg1, rect1)


# A sub-image's k grid samples its rectangle for a period of SUBIMAGE_PERIOD x subimage_oversampling x its
# window: the second PFA's image repeats with that period along the sub-image's axes. A point p's ridges run
# turned from those axes by theta_p - theta_s (two_step.own_support), so its copy one period away has ridges
# parallel to p's own, off them by period x sin(theta_p - theta_s), across the core. At 1 x 1.5 windows
# (105.5 m on nie2016_row3) W's copy ridge ran 0.96 m (4 columns) beside W's own azimuth ridge, -41.7 dB at its
# guard edge, and C alone floored at -46.2 dB; at 2 x C alone floors at -57.9 dB, W alone at plain PFA's -61.1
# (docs/product.md, "The two-step's edge residue").
SUBIMAGE_PERIOD = 2.0


def _second_step_layout(
    scene: TwoStepScene,
    tiles: Sequence[Tile],
    supports: Sequence[TileSupport],
    first: FirstStep,
    oversampling: float,
    reach: float = 0.0,
) -> SecondStepLayout:
    """Windows of the step-1 image, and one k grid spacing for every sub-image: sampled for
    :data:`SUBIMAGE_PERIOD` x ``oversampling`` x the largest window, FFT-exact on the output pixels (each
    sub-image's own support). With ``reach`` (blended seams) each output is its core grown by ``reach`` x the
    core on every side, and the period covers that output plus a window, so that no copy of a window's
    content lands in it."""
    g1, grid = first.grid, scene.grid
    slices = [window_slices(g1, t.window) for t in tiles]
    wa = max((s[0].stop - s[0].start) * g1.da for s in slices)
    wr = max((s[1].stop - s[1].start) * g1.dr for s in slices)
    n_ca = max(t.rows.stop - t.rows.start for t in tiles)
    n_cr = max(t.cols.stop - t.cols.start for t in tiles)
    pa, pr = SUBIMAGE_PERIOD * oversampling * wa, SUBIMAGE_PERIOD * oversampling * wr
    margin = None
    if reach > 0 and len(tiles) > 1:
        margin = (int(math.ceil(reach * n_ca)), int(math.ceil(reach * n_cr)))
        n_ca, n_cr = min(grid.n_a, n_ca + 2 * margin[0]), min(grid.n_r, n_cr + 2 * margin[1])
        pa, pr = max(pa, n_ca * grid.da + wa), max(pr, n_cr * grid.dr + wr)
    kgrids = [
        make_kgrid(r, 2 * math.pi / pa, 2 * math.pi / pr, grid.da, grid.dr, n_ca, n_cr)[0]
        for r in (sup.rect for sup in supports)
    ]
    return SecondStepLayout(slices, kgrids, [sup.angle for sup in supports], (wa, wr), margin)


def _subimage_tasks(
    scene: TwoStepScene, tiles: Sequence[Tile], first: FirstStep, layout: SecondStepLayout, params: Pfa2Params
) -> Iterator[SubImageTask]:
    """One :class:`SubImageTask` per tile (lazily: each holds a copy of its window)."""
    g1, grid, ph = first.grid, scene.grid, scene.ph
    os_ = params.subimage_oversampling
    half = _ramp_half(tiles)
    for i, (t, (sa, sr), kg2, angle) in enumerate(zip(tiles, layout.slices, layout.kgrids, layout.angles)):
        wg = g1.sub(sa, sr)
        window = np.ascontiguousarray(first.image[sa, sr])
        if layout.margin is None:
            core_grid = grid.sub(t.rows, t.cols)
        else:  # this tile's piece of the step-1 image, focused onto its grown core
            core_grid = grid.sub(*grown_slices(t, (grid.n_a, grid.n_r), layout.margin))
            window *= partition_weights(tiles, i, wg, half)
        centre = scene.origin + t.center_offset[0] * scene.e_a + t.center_offset[1] * scene.e_r
        yield SubImageTask(
            window=window,
            window_grid=wg,
            forward=first.kgrid,
            forward_rect=first.rect,
            window_center=t.window_center,
            center=centre,
            center_offset=t.center_offset,
            core=core_grid,
            kgrid=kg2,
            positions=ph.positions,
            reference=scene.origin,
            e_azimuth=scene.e_a,
            e_range=scene.e_r,
            carrier_frequency=ph.carrier_frequency,
            band=scene.band,
            content_extent=layout.content_extent,
            oversampling=os_,
            interp=_interp(params, os_),
            support_angle=angle,
        )


def _ramp_half(tiles: Sequence[Tile]) -> tuple[float, float]:
    """Half-width (m) of the partition's ramps, one for all tiles (the pieces add up to one only if every tile
    weighs the same cells): half the least room between a core's box and its window (the overlap's, less the
    defocus spread's), so that each piece is zero at its window's edge."""
    room = [math.inf, math.inf]
    for t in tiles:
        b, w = t.box, t.window
        for k in (0, 1):
            if math.isfinite(b[2 * k]):
                room[k] = min(room[k], b[2 * k] - w[2 * k])
            if math.isfinite(b[2 * k + 1]):
                room[k] = min(room[k], w[2 * k + 1] - b[2 * k + 1])
    return max(room[0] / 2, 1e-6), max(room[1] / 2, 1e-6)


def _two_step(
    ph: PhaseHistory,
    params: Pfa2Params,
    grid: Grid,
    origin: np.ndarray,
    e_a: np.ndarray,
    e_r: np.ndarray,
    radar: RadarMetadata,
    az_os: float,
    progress: ProgressFactory | None,
    mapper: Callable | None,
    timing: dict[str, float],
) -> tuple[np.ndarray, KGrid, dict]:
    """Two-step PFA (Figs. 3-5): sub-image size -> tiles and their supports -> step 1 -> windows and k grids
    -> one task per sub-image (step 2) -> mosaic."""
    scene = TwoStepScene(ph, grid, origin, e_a, e_r)
    size = _subimage_size(scene, params, radar)
    t0 = time.perf_counter()
    tiles = plan_tiles(
        grid,
        (size.core, size.core),
        params.subimage_overlap,
        ph.positions,
        origin,
        e_a,
        e_r,
        ph.carrier_frequency,
        scene.band,
    )
    # a sub-image is plain PFA around its centre: its pixels must stay within eq. (7)'s radius of it
    reach = max(
        math.hypot((t.rows.stop - t.rows.start - 1) * grid.da, (t.cols.stop - t.cols.start - 1) * grid.dr) / 2
        for t in tiles
    )
    if reach > size.valid_radius:
        log.warning(
            "pfa2: sub-images of %.4g m (subimage_size) reach %.4g m from their centres, %.2f times eq. (7)'s "
            "valid radius of %.4g m: responses near their corners are defocused (the default core is the radius)",
            size.core,
            reach,
            reach / size.valid_radius,
            size.valid_radius,
            extra=IMAGE_DEFECT,
        )
    supports = tile_rects(tiles, ph.positions, origin, e_a, e_r, ph.carrier_frequency, scene.band, radar)
    timing["plan"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    first = _first_step(scene, tiles, _interp(params, az_os))
    timing["pfa_step1"] = time.perf_counter() - t0
    layout = _second_step_layout(scene, tiles, supports, first, params.subimage_oversampling, params.subimage_reach)
    t0 = time.perf_counter()
    results = run_tasks(_subimage_tasks(scene, tiles, first, layout, params), mapper)
    if progress is not None:
        results = progress(results)
    img = mosaic((grid.n_a, grid.n_r), tiles, results, layout.margin)
    timing["subimages"] = time.perf_counter() - t0
    info = {
        "subimages": len(tiles),
        "subimage_margin": list(layout.margin or (0, 0)),
        "subimage_core": size.core,
        "valid_radius_eq7": size.valid_radius,
        "track_residual": size.track_residual,
        "track_core_limit": size.track_limit if math.isfinite(size.track_limit) else -1.0,
        "track_reference_range": size.reference_range,
        "track_k_max": size.k_max,
        "track_pslr_rise": size.track_pslr_rise,
        "step1_shape": [first.grid.n_a, first.grid.n_r],
        "window_shape_max": [
            max(s[0].stop - s[0].start for s in layout.slices),
            max(s[1].stop - s[1].start for s in layout.slices),
        ],
    }
    centre_tile = min(range(len(tiles)), key=lambda i: math.hypot(*tiles[i].center_offset))
    return img, layout.kgrids[centre_tile], info
