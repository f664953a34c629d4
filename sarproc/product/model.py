"""In-memory product: what every stage takes and returns (no I/O here).

A Product mirrors one HDF5 file of the contract: a kind (``raw``, ``image``, ...), one complex
array with labelled dims and SI coordinates, the radar metadata, the targets table, auxiliary
per-pulse datasets and the processing history.
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING, Any

import numpy as np

from sarproc.product.metadata import RadarMetadata

if TYPE_CHECKING:
    from collections.abc import Mapping, Sequence

    import numpy.typing as npt

PRODUCT_KINDS = ("raw", "raw_multichannel", "raw_array", "preprocessed", "coarse", "image", "image3d")

# Targets table carried through every stage. (x, y, z) is the true scene-frame position at
# azimuth time 0; (azimuth, range, elevation) is the same point in the frame of the product's
# axes (elevation is 0 for 2D frames); velocity is (vx, vy, vz), m/s. irw_<axis> is the target's
# own theoretical IRW along that image axis (same convention as the image attribute
# ``theoretical_irw``), recorded by processors whose resolution varies over the scene; 0: not
# recorded (the image attribute applies). null_<axis> is the null spacing 1/B of the target's own support
# (IRW / null is the weighting's broadening factor, 0.886 unweighted), pslr_<axis> / islr_<axis> its
# theoretical PSLR / ISLR, dB (sarproc.product.theory). ridge_angle: the angle in space between a 2D image target's
# two theoretical side-lobe ridges, degrees (sarproc.product.theory.target_ridge_angle, untapered: what evaluate
# computes from the pulses when it is 0). Files written before these fields read as 0.
TARGET_AXES = ("azimuth", "range", "elevation")
TARGET_IRW_FIELDS = tuple(f"irw_{a}" for a in TARGET_AXES)
TARGET_NULL_FIELDS = tuple(f"null_{a}" for a in TARGET_AXES)
TARGET_SIDELOBE_FIELDS = tuple(f"{m}_{a}" for m in ("pslr", "islr") for a in TARGET_AXES)
TARGET_RIDGE_FIELD = "ridge_angle"
TARGET_THEORY_FIELDS = TARGET_IRW_FIELDS + TARGET_NULL_FIELDS + TARGET_SIDELOBE_FIELDS + (TARGET_RIDGE_FIELD,)
TARGET_DTYPE = np.dtype(
    [
        ("name", "S32"),
        ("x", "f8"),
        ("y", "f8"),
        ("z", "f8"),
        ("azimuth", "f8"),
        ("range", "f8"),
        ("elevation", "f8"),
        ("amplitude", "c16"),
        ("vx", "f8"),
        ("vy", "f8"),
        ("vz", "f8"),
    ]
    + [(f, "f8") for f in TARGET_THEORY_FIELDS]
)
TARGET_NAMES: tuple[str, ...] = TARGET_DTYPE.names or ()  # the field names, typed as never None

UNITS = {"azimuth_time": "s", "range_time": "s", "channel": "1", "azimuth": "m", "range": "m", "elevation": "rad"}

# Dims of the data set of each kind (the reader refuses others).
KIND_DIMS = {
    "raw": ("azimuth_time", "range_time"),
    "preprocessed": ("azimuth_time", "range_time"),
    "coarse": ("azimuth_time", "range_time"),
    "raw_multichannel": ("channel", "azimuth_time", "range_time"),
    "raw_array": ("channel", "azimuth_time", "range_time"),
    "image": ("azimuth", "range"),
    "image3d": ("elevation", "azimuth", "range"),
}

# The moving-target table of ``reconstruct`` (one row per detected mover), carried by every later stage
# like any aux array: aux ``moving_targets`` (mover, moving_target_field), float64, columns in this order.
MOVING_TARGET_COLUMNS = (
    ("id", "1", "mover number"),
    ("snr", "dB", "detection SNR: peak over the mean local background in the detection image"),
    ("v_r", "m/s", "estimated slant-range velocity (zero-Doppler slant-range direction)"),
    ("v_r_sigma", "m/s", "its 1-sigma uncertainty"),
    ("v_a", "m/s", "estimated along-track velocity"),
    ("v_a_sigma", "m/s", "its 1-sigma uncertainty"),
    ("apparent_x", "m", "static-equivalent (apparent) position, scene frame"),
    ("apparent_y", "m", ""),
    ("apparent_z", "m", ""),
    ("relocated_x", "m", "relocated position at azimuth time 0 (apparent position and estimated velocity)"),
    ("relocated_y", "m", ""),
    ("relocated_z", "m", ""),
    ("relocation_sigma", "m", "1-sigma relocation uncertainty along track implied by the velocity uncertainties"),
    ("apparent_time", "s", "beam-centre time of the apparent position"),
    ("range_cell_first", "1", "first walk-corrected range cell of the mover's window"),
    ("range_cell_last", "1", "last range cell of the window (exclusive)"),
    ("leakage", "1", "out-of-band energy fraction at the estimate (eq. 5)"),
    ("truth_index", "1", "row of the matched moving target in the targets table; -1 none or no truth"),
)


def moving_target_table(aux: dict) -> dict[str, np.ndarray]:
    """Columns of aux ``moving_targets`` by name (empty columns when the product has none)."""
    arr = np.asarray(aux.get("moving_targets", np.zeros((0, len(MOVING_TARGET_COLUMNS)))), float)
    arr = arr.reshape(-1, len(MOVING_TARGET_COLUMNS))
    return {name: arr[:, k] for k, (name, _, _) in enumerate(MOVING_TARGET_COLUMNS)}


def moving_target_rows(aux: dict) -> list[dict]:
    """The same table as one dict per mover (column name -> float)."""
    cols = moving_target_table(aux)
    n = len(cols["id"])
    return [{name: float(cols[name][i]) for name in cols} for i in range(n)]


# Auxiliary arrays: named dims (netCDF readers see no phony dims), CF units, description.
# ``pulse`` is the transmit-pulse axis (the raw product's azimuth_time), ``receiver`` the receive
# channels, ``xyz`` the scene-frame components.
AUX_LAYOUT = {
    "platform_position": (("pulse", "xyz"), "m", "platform (antenna phase centre) position per pulse, scene frame"),
    "tx_offset": (("xyz",), "m", "transmitter offset from the platform position"),
    "rx_offset": (("receiver", "xyz"), "m", "receiver offsets from the platform position"),
    "range_gate_offset": (("pulse",), "s", "receive-window start offset per pulse"),
    "doppler_frequency": (("doppler",), "Hz", "Doppler frequency of doppler_power (squint centroid removed)"),
    "doppler_power": (
        ("doppler",),
        "1",
        "azimuth power spectrum summed over range, squint centroid removed (written by reconstruct)",
    ),
    "moving_targets": (
        ("mover", "moving_target_field"),
        "see long_name",
        "moving targets found by reconstruct; columns: " + ", ".join(f"{n} ({u})" for n, u, _ in MOVING_TARGET_COLUMNS),
    ),
}
AUX_DIM_DOC = {
    "pulse": "transmit pulse index",
    "receiver": "receive channel index",
    "xyz": "scene-frame component: 0 = x (along track), 1 = y, 2 = z (up)",
    "doppler": "Doppler bin (ascending frequency)",
}

# Units of the targets table's fields (the table is a compound dataset: one map, no single unit).
TARGET_UNITS = {
    "name": "",
    "x": "m",
    "y": "m",
    "z": "m",
    "azimuth": "m",
    "range": "m",
    "elevation": "rad",
    "amplitude": "1",
    "vx": "m/s",
    "vy": "m/s",
    "vz": "m/s",
    "irw_azimuth": "m",
    "irw_range": "m",
    "irw_elevation": "rad",
    "null_azimuth": "m",
    "null_range": "m",
    "null_elevation": "rad",
    **dict.fromkeys(TARGET_SIDELOBE_FIELDS, "dB"),
    TARGET_RIDGE_FIELD: "deg",
}

# Units of the numeric attributes stages put on the data set, stored as its JSON map
# ``attribute_units`` and type-checked by the reader (a number, or a list of numbers).
DATA_ATTR_UNITS = {
    "azimuth_sampling_rate": "Hz",
    "deramp_rate": "Hz/s",
    "coarse_reference_range": "m",
    "aperture_start": "s",
    "aperture_end": "s",
    "n_pulses": "1",
    "fixed_gate_samples": "1",
    "total_doppler_bandwidth": "Hz",
    "deramp_spread": "Hz",
    "deramp_extent": "Hz",
    "scene_box": "m",
    "theoretical_irw": "axis units (m; rad for elevation)",
    # pfa2, two-step (docs/pfa.md, "Curved tracks")
    "subimages": "1",
    "subimage_core": "m",
    "valid_radius_eq7": "m",
    "track_residual": "m",
    "track_core_limit": "m",
    "track_reference_range": "m",
    "track_k_max": "rad/m",
    "track_pslr_rise": "dB",
}

DATA_NAME = {
    "raw": "signal",
    "raw_multichannel": "signal",
    "raw_array": "signal",
    "preprocessed": "signal",
    "coarse": "signal",
    "image": "image",
    "image3d": "image",
}


@dataclasses.dataclass
class Product:
    """One product. ``data`` has shape ``tuple(len(coords[d]) for d in dims)``.

    ``attrs`` are attributes of the data set (e.g. ``frame`` for images, ``theoretical_irw``);
    ``aux`` holds extra named arrays (``platform_position`` (n_az, 3) m, ``rx_offset``
    (n_channel, 3) m, ``range_gate_offset`` (n_az,) s, ...). ``history`` is a list of dicts.
    """

    kind: str
    data: np.ndarray
    dims: tuple[str, ...]
    coords: dict[str, np.ndarray]
    radar: RadarMetadata
    targets: np.ndarray
    attrs: dict = dataclasses.field(default_factory=dict)
    aux: dict[str, np.ndarray] = dataclasses.field(default_factory=dict)
    history: list[dict] = dataclasses.field(default_factory=list)

    def __post_init__(self) -> None:
        if self.kind not in PRODUCT_KINDS:
            raise ValueError(f"unknown product kind {self.kind!r}")
        shape = tuple(len(self.coords[d]) for d in self.dims)
        if tuple(self.data.shape) != shape:
            raise ValueError(f"data shape {self.data.shape} does not match coords {shape} for dims {self.dims}")

    @property
    def data_name(self) -> str:
        return DATA_NAME[self.kind]

    def derive(
        self, kind: str, data: np.ndarray, dims: Sequence[str], coords: Mapping[str, np.ndarray], **changes: Any
    ) -> Product:
        """New product from this one (targets, radar, aux and history carried forward)."""
        base: dict[str, Any] = dict(
            radar=self.radar, targets=self.targets.copy(), attrs={}, aux=dict(self.aux), history=list(self.history)
        )
        base.update(changes)
        return Product(kind=kind, data=data, dims=tuple(dims), coords=dict(coords), **base)


def make_targets(
    names: Sequence[str],
    xyz: np.ndarray,
    amplitude: npt.ArrayLike,
    velocity: npt.ArrayLike | None = None,
    frame_coords: Sequence[np.ndarray] | None = None,
) -> np.ndarray:
    """Build a TARGET_DTYPE table; ``frame_coords`` is (azimuth, range, elevation) arrays."""
    xyz = np.atleast_2d(np.asarray(xyz, dtype=float))
    n = xyz.shape[0]
    t = np.zeros(n, dtype=TARGET_DTYPE)
    t["name"] = [str(s).encode() for s in names]
    t["x"], t["y"], t["z"] = xyz[:, 0], xyz[:, 1], xyz[:, 2]
    t["amplitude"] = np.asarray(amplitude, dtype=complex)
    if velocity is not None:
        vel = np.atleast_2d(np.asarray(velocity, dtype=float))
        t["vx"], t["vy"], t["vz"] = vel[:, 0], vel[:, 1], vel[:, 2]
    if frame_coords is not None:
        for name, val in zip(("azimuth", "range", "elevation"), frame_coords):
            t[name] = val
    return t


def as_target_table(table: np.ndarray) -> np.ndarray:
    """``table`` as TARGET_DTYPE, field by field; irw_* and ridge_angle fields it lacks (older files) become 0 (not
    recorded)."""
    table = np.asarray(table)
    optional = (*TARGET_IRW_FIELDS, TARGET_RIDGE_FIELD)
    missing = [f for f in TARGET_NAMES if f not in (table.dtype.names or ()) and f not in optional]
    if missing:
        raise ValueError(f"targets table lacks field(s) {missing}")
    out = np.zeros(table.shape, dtype=TARGET_DTYPE)
    for f in TARGET_NAMES:
        if f in (table.dtype.names or ()):
            out[f] = table[f]
    return out


def target_names(targets: np.ndarray) -> list[str]:
    return [n.decode() if isinstance(n, bytes) else str(n) for n in targets["name"]]
