"""Scene model: the YAML file that declares radar, geometry, acquisition, targets and effects.

Quantities accept units ("10 GHz", "300 km", "30 deg"); angles must carry one. Unknown keys are
refused. Only the effects listed under ``effects:`` are simulated. A scene file may also hold
the parameter sections of processing stages (``backproject:``, ``evaluate:`` ...), which the
scene loader ignores and each stage reads for itself.
"""

from __future__ import annotations

import dataclasses
import json
import logging
import math
from pathlib import Path

import numpy as np

from sarproc.product import beam
from sarproc.product.config import OTHER_SECTIONS, STAGE_SECTIONS, as_dict, build, load_yaml, param
from sarproc.product.errors import IMAGE_DEFECT, InputError
from sarproc.product.frames import Frame, frame_coordinates, frame_names, make_frame
from sarproc.product.metadata import (
    POLARIZATION_RE,
    POLARIZATIONS,
    SINC_IRW_FACTOR,
    C,
    RadarMetadata,
    scene_center_from_geometry,
)
from sarproc.product.model import make_targets
from sarproc.product.sorted_values import unique_integers

log = logging.getLogger(__name__)


@dataclasses.dataclass(frozen=True)
class RadarParams:
    carrier_frequency: float = param("frequency", gt=0, doc="carrier frequency f_c")
    bandwidth: float = param("frequency", gt=0, doc="chirp bandwidth B")
    pulse_duration: float = param("time", gt=0, doc="chirp duration T_p")
    range_sampling_rate: float = param("frequency", gt=0, doc="complex range sampling rate f_s (>= B)")
    prf: float = param("frequency", gt=0, doc="pulse repetition frequency")
    chirp: str = param(default="up", choices=("up", "down"), doc="chirp direction")
    polarization: str | None = param(
        default=None,
        doc=(
            "optional transmit:receive polarisation ('V:V', 'H:H', 'H:V', ...; SICD spelling), recorded in the "
            "products and written by export-sicd; absent: UNKNOWN"
        ),
    )

    def validate(self) -> None:
        if self.polarization is not None and not POLARIZATION_RE.fullmatch(str(self.polarization)):
            raise InputError(
                f"polarization: {self.polarization!r} is not TX:RCV with TX, RCV one of "
                f"{', '.join(POLARIZATIONS)} (e.g. 'V:V', 'H:V')"
            )
        if self.range_sampling_rate < self.bandwidth:
            raise InputError(
                f"range_sampling_rate: {self.range_sampling_rate:g} Hz is below the bandwidth "
                f"{self.bandwidth:g} Hz; complex sampling needs f_s >= B"
            )
        if self.bandwidth >= self.carrier_frequency:
            raise InputError("bandwidth: must be smaller than carrier_frequency")


@dataclasses.dataclass(frozen=True)
class PlatformParams:
    velocity: float = param("velocity", gt=0, doc="platform speed along +x")
    altitude: float = param("length", default=0.0, ge=0, doc="height over the target plane; 0 = slant-plane geometry")


@dataclasses.dataclass(frozen=True)
class GeometryParams:
    reference_range: float = param("length", gt=0, doc="slant range from the aperture centre to the scene centre")
    squint: float = param(
        "angle",
        default=0.0,
        gt=-math.radians(89),
        lt=math.radians(89),
        doc="squint of the line of sight to the scene centre at the aperture centre (+ forward)",
    )


@dataclasses.dataclass(frozen=True)
class RangeWindow:
    start: float = param("length", gt=0, doc="slant range of the first sample (two-way path / 2)")
    end: float = param("length", gt=0, doc="slant range of the last sample")

    def validate(self) -> None:
        if self.end <= self.start:
            raise InputError("end: must be greater than start")


@dataclasses.dataclass(frozen=True)
class AcquisitionParams:
    mode: str = param(
        default="spotlight",
        choices=("stripmap", "spotlight", "sliding_spotlight"),
        doc="beam steering; stripmap and sliding_spotlight need effects.antenna",
    )
    aperture_time: float | None = param("time", default=None, gt=0, doc="synthetic aperture duration")
    azimuth_resolution: float | None = param(
        "length", default=None, gt=0, doc="sets aperture_time = 0.886 lambda R / (2 rho v cos^2 squint)"
    )
    n_pulses: int | None = param(default=None, ge=1, doc="number of pulses")
    range_window: RangeWindow | None = param(default=None, doc="receive window; default covers every echo")
    range_margin: float = param("length", default=0.0, ge=0, doc="extra slant range on both sides of the auto window")

    def validate(self) -> None:
        given = [k for k in ("aperture_time", "azimuth_resolution", "n_pulses") if getattr(self, k) is not None]
        if len(given) != 1:
            raise InputError(
                "give exactly one of aperture_time, azimuth_resolution, n_pulses"
                + (f" (got {', '.join(given)})" if given else "")
            )


@dataclasses.dataclass(frozen=True)
class TargetPoint:
    name: str = param(doc="target label")
    azimuth: float = param("length", default=0.0, doc="azimuth coordinate in targets.frame")
    range: float = param("length", default=0.0, doc="range coordinate in targets.frame")
    elevation: float = param("angle", default=0.0, doc="elevation coordinate (3D frames only)")
    amplitude: float = param(default=1.0, ge=0, doc="echo amplitude")
    phase: float = param("angle", default=0.0, doc="echo phase")
    velocity: tuple[float, ...] = param(
        "velocity", default=(0.0, 0.0, 0.0), doc="(vx, vy, vz); needs effects.target_motion"
    )

    def validate(self) -> None:
        if len(self.velocity) != 3:
            raise InputError(f"velocity: expected three components (vx, vy, vz), got {len(self.velocity)}")


@dataclasses.dataclass(frozen=True)
class TargetGrid:
    azimuth_count: int = param(ge=1)
    range_count: int = param(ge=1)
    azimuth_spacing: float = param("length", ge=0)
    range_spacing: float = param("length", ge=0)
    amplitude: float = param(default=1.0, ge=0)
    prefix: str = param(default="G")


@dataclasses.dataclass(frozen=True)
class TargetsParams:
    frame: str = param(default="squint", doc="frame of the target coordinates (squint, zero_doppler, ground, los, ...)")
    origin: str = param(
        default="scene_center",
        choices=("scene_center", "absolute"),
        doc="coordinates are offsets from the scene centre, or absolute frame coordinates",
    )
    points: tuple[TargetPoint, ...] = param(default=(), doc="point targets")
    grid: TargetGrid | None = param(default=None, doc="a regular grid of targets centred on the origin")

    def validate(self) -> None:
        if self.frame not in frame_names():
            raise InputError(f"frame: {self.frame!r} is not one of {frame_names()}")
        names = [p.name for p in self.points]
        if len(set(names)) != len(names):
            raise InputError("points: target names must be unique")


@dataclasses.dataclass(frozen=True)
class ReferenceParams:
    """Optional absolute placement of the local scene (for standard formats such as SICD/CPHD)."""

    time: str | None = param(
        default=None,
        doc="UTC of azimuth time 0 (the aperture centre), ISO 8601 with a zone, e.g. '2024-05-01T10:00:00Z'",
    )
    latitude: float | None = param(
        "angle", default=None, ge=-math.pi / 2, le=math.pi / 2, doc="WGS84 geodetic latitude of the scene centre"
    )
    longitude: float | None = param(
        "angle", default=None, ge=-math.pi, le=math.pi, doc="WGS84 geodetic longitude of the scene centre"
    )
    height: float | None = param(
        "length",
        default=None,
        doc="height of the scene centre above the WGS84 ellipsoid (default 0 m when latitude and longitude are given)",
    )

    def validate(self) -> None:
        if (self.latitude is None) != (self.longitude is None):
            raise InputError("latitude/longitude: give both or neither")
        if self.height is not None and self.latitude is None:
            raise InputError("height: needs latitude and longitude")
        if self.time is not None:
            from sarproc.product.metadata import parse_utc

            parse_utc(self.time, "time")


@dataclasses.dataclass(frozen=True)
class SimulationParams:
    block_pulses: int = param(default=256, ge=1, doc="pulses simulated per block (bounds memory)")
    seed: int = param(default=0, ge=0, doc="random seed for noise")
    waveform: str = param(
        default="auto",
        choices=("auto", "band_limited", "continuous"),
        doc=(
            "band_limited: the pulse is the sampled chirp through a DAC filter flat over |f| <= B/2 and rejecting "
            "|f| >= f_s - B/2 (a digital waveform generator; 120 dB), so every echo compresses exactly; needs "
            "radar.range_sampling_rate above 1.01 x the bandwidth. continuous: each echo samples the continuous "
            "chirp at its delay (its spectral tails beyond f_s/2 alias, so a delay between samples compresses "
            "with a pedestal, about -45 dB at 1.2 B sampling; the default before session 35). auto: band_limited "
            "where the sampling rate allows it, else continuous (the scene as loaded records which)"
        ),
    )


@dataclasses.dataclass(frozen=True)
class SceneParams:
    radar: RadarParams = param()
    platform: PlatformParams = param()
    geometry: GeometryParams = param()
    acquisition: AcquisitionParams = param()
    targets: TargetsParams = param(default=TargetsParams())
    effects: dict = param(default={}, doc="effect name -> its parameters; only these are simulated")
    simulation: SimulationParams = param(default=SimulationParams())
    reference: ReferenceParams = param(default=ReferenceParams(), doc="optional UTC time and geodetic scene centre")


@dataclasses.dataclass
class Scene:
    """A loaded scene: typed parameters, effect plugins, derived metadata and targets."""

    params: SceneParams
    radar: RadarMetadata
    effects: list  # instances of sarproc.simulation.effects.base.Effect, in application order
    target_xyz: np.ndarray  # (n_targets, 3) m at azimuth time 0
    target_velocity: np.ndarray  # (n_targets, 3) m/s
    target_amplitude: np.ndarray  # (n_targets,) complex
    target_names: list[str]
    target_frame: Frame
    source: str = "<mapping>"
    # the scene file's stage sections, verbatim: recorded in the raw product's history, so a stage run on it
    # without --config can say that they are not applied (sarproc.cli.stage.unapplied_scene_section)
    stage_sections: dict = dataclasses.field(default_factory=dict)

    @property
    def n_pulses(self) -> int:
        return int(round(self.radar.aperture_time * self.radar.prf)) or 1

    def azimuth_time(self) -> np.ndarray:
        """Pulse times, s, centred on the aperture centre."""
        n = self.n_pulses
        return (np.arange(n) - (n - 1) / 2.0) / self.radar.prf

    def targets_table(self) -> np.ndarray:
        return make_targets(
            self.target_names,
            self.target_xyz.reshape(-1, 3),
            self.target_amplitude,
            self.target_velocity.reshape(-1, 3),
            frame_coordinates(self.target_frame, self.target_xyz),
        )

    def resolved(self) -> dict:
        return as_dict(self.params)

    def history_entry(self, command: str) -> dict:
        """The raw product's provenance record: the resolved scene, and the file's stage sections."""
        from sarproc.product.io import history_entry

        entry = history_entry(command, self.resolved())
        if self.stage_sections:
            entry["stage_sections"] = self.stage_sections
        return entry


def _aperture_time(p: SceneParams, wavelength: float) -> float:
    a = p.acquisition
    if a.aperture_time is not None:
        return a.aperture_time
    if a.n_pulses is not None:
        return a.n_pulses / p.radar.prf
    assert a.azimuth_resolution is not None  # AcquisitionParams.validate: exactly one of the three is given
    cos2 = math.cos(p.geometry.squint) ** 2
    return (
        SINC_IRW_FACTOR
        * wavelength
        * p.geometry.reference_range
        / (2 * a.azimuth_resolution * p.platform.velocity * cos2)
    )


def _targets(
    p: SceneParams, radar: RadarMetadata, source: str
) -> tuple[Frame, np.ndarray, np.ndarray, np.ndarray, list[str]]:
    t = p.targets
    frame = make_frame(t.frame, radar)
    axes = frame.axes
    points = list(t.points)
    if t.grid is not None:
        g = t.grid
        for i in range(g.azimuth_count):
            for j in range(g.range_count):
                points.append(
                    TargetPoint(
                        name=f"{g.prefix}{i:02d}_{j:02d}",
                        azimuth=(i - (g.azimuth_count - 1) / 2) * g.azimuth_spacing,
                        range=(j - (g.range_count - 1) / 2) * g.range_spacing,
                        amplitude=g.amplitude,
                    )
                )
    names = [pt.name for pt in points]
    if len(set(names)) != len(names):
        raise InputError(f"{source}: targets: target names must be unique")
    if not points:
        return frame, np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0, complex), []
    coords = {ax: np.array([getattr(pt, ax) for pt in points], float) for ax in axes}
    if t.origin == "scene_center":
        centre = frame.from_xyz(np.asarray(radar.scene_center))
        for ax, c in zip(axes, centre):
            coords[ax] = coords[ax] + float(c)
    try:
        xyz = frame.to_xyz(*(coords[ax] for ax in axes))
    except InputError as exc:
        raise InputError(f"{source}: targets: {exc}") from None
    vel = np.array([pt.velocity for pt in points], float)
    amp = np.array([pt.amplitude * np.exp(1j * pt.phase) for pt in points])
    return frame, xyz, vel, amp, names


def _reference(ref: ReferenceParams) -> dict:
    """RadarMetadata fields of the optional absolute reference (canonical UTC string, rad, m)."""
    from sarproc.product.metadata import parse_utc

    out: dict[str, object] = {}
    if ref.time is not None:
        out["reference_utc"] = parse_utc(ref.time, "reference.time")
    if ref.latitude is not None:
        out.update(
            reference_latitude=ref.latitude,
            reference_longitude=ref.longitude,
            reference_height=ref.height if ref.height is not None else 0.0,
        )
    return out


def scene_from_mapping(mapping: dict, source: str = "<mapping>") -> Scene:
    """Validate a scene mapping (as read from YAML) and derive its metadata and targets."""
    from sarproc.simulation.effects import build_effects

    mapping = dict(mapping)
    declared = tuple(section for section in STAGE_SECTIONS if section in mapping and section != "evaluate")
    sections = json.loads(json.dumps({k: mapping[k] for k in STAGE_SECTIONS if k in mapping}, default=str))
    for section in STAGE_SECTIONS + OTHER_SECTIONS:
        mapping.pop(section, None)
    p = build(SceneParams, mapping, source=source)
    r, g, pl = p.radar, p.geometry, p.platform
    wavelength = C / r.carrier_frequency
    try:
        centre = scene_center_from_geometry(g.reference_range, g.squint, pl.altitude)
    except InputError as exc:
        raise InputError(f"{source}: {exc}") from None
    radar = RadarMetadata(
        carrier_frequency=r.carrier_frequency,
        bandwidth=r.bandwidth,
        pulse_duration=r.pulse_duration,
        chirp_rate=(1 if r.chirp == "up" else -1) * r.bandwidth / r.pulse_duration,
        range_sampling_rate=r.range_sampling_rate,
        prf=r.prf,
        velocity=pl.velocity,
        altitude=pl.altitude,
        squint=g.squint,
        reference_range=g.reference_range,
        scene_center=centre,
        mode=p.acquisition.mode,
        aperture_time=_aperture_time(p, wavelength),
        polarization=r.polarization,
        **_reference(p.reference),
    )
    frame, xyz, vel, amp, names = _targets(p, radar, source)
    effects = build_effects(p.effects, p, radar, source)
    keys = {e.key for e in effects}
    if np.any(vel != 0) and "target_motion" not in keys:
        raise InputError(f"{source}: targets: a target has a velocity but effects.target_motion is not declared")
    if p.simulation.waveform == "auto":  # record the waveform simulated, not the rule that chose it
        waveform = "band_limited" if r.range_sampling_rate > 1.01 * r.bandwidth else "continuous"
        p = dataclasses.replace(p, simulation=dataclasses.replace(p.simulation, waveform=waveform))
    if p.simulation.waveform == "band_limited" and not r.range_sampling_rate > 1.01 * r.bandwidth:
        raise InputError(
            f"{source}: simulation.waveform: band_limited needs radar.range_sampling_rate above 1.01 x the "
            f"bandwidth (a transition band for the DAC filter), got {r.range_sampling_rate / r.bandwidth:.3g} x"
        )
    if p.acquisition.mode in ("stripmap", "sliding_spotlight") and "antenna" not in keys:
        raise InputError(f"{source}: acquisition.mode: {p.acquisition.mode} needs effects.antenna (a beam to steer)")
    for e in effects:
        radar = e.update_radar(radar)
    scene = Scene(
        params=p,
        radar=radar,
        effects=effects,
        target_xyz=xyz,
        target_velocity=vel,
        target_amplitude=amp,
        target_names=names,
        target_frame=frame,
        source=source,
        stage_sections=sections,
    )
    _sanity_warnings(scene, declared)
    return scene


# Chains that take out a spotlight scene's total Doppler span before any FFT over azimuth: deramp /
# SPECAN (An 2012), motion compensation to the scene centre then polar format (Nie 2016), and the
# time-domain reference. They need only the instantaneous spread across the scene within the PRF.
UNFOLDING_CHAINS = {
    "coarse_focus": "deramp chain (coarse-focus)",
    "pfa2": "pfa2 (motion compensation to the scene centre)",
    "backproject": "backproject (time domain)",
}


# The folding check's cost is bounded whatever the scene's size: at most this many pulses (evenly
# spaced, first and last included) and this many targets, evaluated in blocks of FOLDING_BLOCK targets.
FOLDING_MAX_PULSES = 512
FOLDING_MAX_TARGETS = 1024
FOLDING_BLOCK = 128


def _folding_pulses(n: int, cap: int) -> np.ndarray:
    """Indices of at most ``cap`` evenly spaced pulses, the first and the last included."""
    return unique_integers(np.round(np.linspace(0, n - 1, min(n, cap))).astype(int))


def _folding_targets(scene: Scene, t_ends: np.ndarray, cap: int) -> np.ndarray:
    """Indices of the targets that decide the Doppler extremes, at most about ``cap`` of them.

    The platform flies along x at height h, so a target's Doppler at time t is
    2 v / lambda * sin of the angle of (x - v t, rho), rho = sqrt(y^2 + (z - h)^2): a function of
    the direction from (v t, 0) in the (x, rho) half-plane, whose level sets are rays. Its largest and
    smallest values over the targets therefore sit on the vertices of their convex hull in (x, rho),
    at every time. Kept besides: the hull (thinned to half the cap when larger), each coordinate's
    extremes, the targets with the widest end-to-end Doppler history (the widest own histories, a
    history being monotonic in time), and an even sample of the rest to fill the cap (for beams,
    whose illumination is not decided by the hull).
    """
    xyz = scene.target_xyz
    n = len(xyz)
    if n <= cap:
        return np.arange(n)
    r = scene.radar
    x, rho = xyz[:, 0], np.hypot(xyz[:, 1], xyz[:, 2] - r.altitude)
    keep = [np.argmin(c) for c in (x, xyz[:, 1], xyz[:, 2], rho)] + [
        np.argmax(c) for c in (x, xyz[:, 1], xyz[:, 2], rho)
    ]
    try:
        from scipy.spatial import ConvexHull, QhullError

        hull = ConvexHull(np.stack([x, rho], axis=1)).vertices
    except (ImportError, QhullError, ValueError):  # all targets on one line: the extremes above are its ends
        hull = np.zeros(0, int)
    if len(hull) > cap // 2:
        hull = hull[_folding_pulses(len(hull), cap // 2)]
    ends = (
        2
        * r.velocity
        / r.wavelength
        * (x[None, :] - r.velocity * t_ends[:, None])
        / np.hypot(x[None, :] - r.velocity * t_ends[:, None], rho[None, :])
    )
    widest = np.argsort(ends[0] - ends[1])[-(cap // 8) :]
    chosen = unique_integers(np.concatenate([np.asarray(keep, int), hull, widest]))
    rest = max(cap - len(chosen), 0)
    return unique_integers(np.concatenate([chosen, _folding_pulses(n, rest) if rest else np.zeros(0, int)]))


def doppler_folding(scene: Scene, max_pulses: int | None = None, max_targets: int | None = None) -> dict | None:
    """Exact-geometry Doppler numbers of the targets over the pulses whose -3 dB beam sees them.

    Returns None without targets, else (all Hz): ``own`` (the widest single target's Doppler
    history), ``spread`` (the widest instantaneous spread across the illuminated targets), ``span``
    (all targets over all pulses), ``rate`` (the azimuth sampling rate: PRF x azimuth channels).
    Evaluated on at most ``max_pulses`` x ``max_targets`` (pulse, target) pairs, in blocks of targets,
    so that loading a scene of any size stays cheap (see :func:`_folding_targets`); smaller scenes
    are evaluated on every pulse and target.
    """
    r = scene.radar
    if not len(scene.target_xyz):
        return None
    max_pulses = max_pulses or FOLDING_MAX_PULSES
    max_targets = max_targets or FOLDING_MAX_TARGETS
    t_all = scene.azimuth_time()
    t = t_all[_folding_pulses(len(t_all), max_pulses)]
    targets = scene.target_xyz[_folding_targets(scene, t[[0, -1]], max_targets)]
    pos = np.stack([r.velocity * t, np.zeros_like(t), np.full_like(t, r.altitude)], axis=1)
    bore = beam.boresight(r, pos) if r.azimuth_beamwidth > 0 else None
    columns = []
    for k0 in range(0, len(targets), FOLDING_BLOCK):
        tg = np.broadcast_to(targets[k0 : k0 + FOLDING_BLOCK], (len(t),) + targets[k0 : k0 + FOLDING_BLOCK].shape)
        d = tg - pos[:, None, :]
        fd = 2 * r.velocity * d[..., 0] / np.linalg.norm(d, axis=-1) / r.wavelength  # (pulses, block)
        if bore is not None:
            az, _ = beam.off_boresight_angles(bore, pos, tg)
            fd = np.where(np.abs(az) <= r.azimuth_beamwidth / 2, fd, np.nan)
        columns.append(fd)
    fd = np.concatenate(columns, axis=1)
    if not np.any(np.isfinite(fd)):
        return None
    with np.errstate(invalid="ignore"):
        lit_t = np.isfinite(fd).any(axis=1)
        lit_k = np.isfinite(fd).any(axis=0)
        own = np.nanmax(fd[:, lit_k], axis=0) - np.nanmin(fd[:, lit_k], axis=0)
        spread = np.nanmax(fd[lit_t], axis=1) - np.nanmin(fd[lit_t], axis=1)
    channels = r.n_channels if any(e.key == "azimuth_channels" for e in scene.effects) else 1
    return {
        "own": float(own.max()),
        "spread": float(spread.max()),
        "span": float(np.nanmax(fd) - np.nanmin(fd)),
        "rate": float(r.prf * channels),
        "channels": int(channels),
    }


def _sanity_warnings(scene: Scene, declared: tuple = ()) -> None:
    """Warn (not fail) on settings that are legal but usually unintended, only when true for the scene.

    Azimuth folding is judged on the targets' exact Doppler histories (:func:`doppler_folding`):
    a target whose own history is wider than the azimuth sampling rate aliases whatever the
    processor; a total span wider than the PRF only folds the spectrum, which the chains in
    ``UNFOLDING_CHAINS`` take out when the instantaneous spread fits (logged at info level then).
    """
    r = scene.radar
    if scene.n_pulses > 200_000:
        raise InputError(f"{scene.source}: acquisition: {scene.n_pulses} pulses is more than this simulator handles")
    dop = doppler_folding(scene)
    if dop is None:
        return
    rate = dop["rate"]
    sampling = f"PRF {r.prf:.4g} Hz" + (f" x {dop['channels']} azimuth channels" if dop["channels"] > 1 else "")
    # What must fit in the sampling rate is what the radar sees at one time: the beam's Doppler band in
    # stripmap (every point of the footprint), the spread across the scene's targets in spotlight.
    if r.mode != "spotlight" and r.azimuth_beamwidth > 0:
        seen, what = 2 * r.velocity * math.cos(r.squint) * r.azimuth_beamwidth / r.wavelength, "the beam's Doppler band"
    else:
        seen, what = dop["spread"], "the targets' instantaneous Doppler spread"
    if seen > rate:
        f_dr = 2 * (r.velocity * math.cos(r.squint)) ** 2 / (r.wavelength * r.reference_range)
        log.warning(
            "%s: %s is %.4g Hz, more than the azimuth sampling rate %.4g Hz (%s): azimuth aliasing by %.4g Hz; "
            "ghosts of each target appear %.4g m away along track (rate / FM rate x v at the reference "
            "range), and no processing chain undoes this (raise the PRF or narrow the beam / scene)",
            scene.source,
            what,
            seen,
            rate,
            sampling,
            seen - rate,
            rate / f_dr * r.velocity,
            extra=IMAGE_DEFECT,
        )
        return
    if dop["span"] <= rate:
        return
    undo = [UNFOLDING_CHAINS[s] for s in declared if s in UNFOLDING_CHAINS]
    text = (
        f"{scene.source}: the scene's azimuth spectrum spans {dop['span']:.4g} Hz over the {sampling} and folds "
        f"by {dop['span'] - rate:.4g} Hz; {what} is at most {seen:.4g} Hz, within the sampling rate"
    )
    if undo:
        log.info("%s: the declared %s unfolds it", text, " and ".join(undo))
    else:
        log.warning(
            "%s, but no declared stage unfolds it (declare one of: %s); an azimuth FFT of the raw data will alias",
            text,
            ", ".join(sorted(UNFOLDING_CHAINS)),
            extra=IMAGE_DEFECT,
        )


def load_scene(path: str | Path) -> Scene:
    """Load and validate a scene YAML file."""
    path = Path(path)
    return scene_from_mapping(load_yaml(path), source=str(path))
