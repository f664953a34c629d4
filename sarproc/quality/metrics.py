"""Point-target quality metrics of focused 2D/3D SAR images (docs/product.md, "Metrics").

Per target and per image axis: IRW (-3 dB width, absolute and relative to theory), PSLR,
ISLR, position error (axis units and resolution cells) and the peak; per image: the
false-target level (strongest response outside every target's neighbourhood).

Conventions. ``theoretical_irw[a]`` is the expected IRW of axis ``a`` in axis units; the
axis' spatial bandwidth is ``B = irw_factor / IRW_theory`` (cycles per axis unit;
``irw_factor`` = 0.886 for unweighted processing), so ``1/B`` is the null spacing of the
unweighted response. Two cell sizes are used and named apart:

* a *resolution cell* is ``IRW_theory``: position errors, the search window and the false-target
  guard are counted in it;
* a *null* is ``1/B``: the ISLR window is ``+-islr_nulls/B`` around the peak (10 by the contract;
  an unweighted sinc then gives ISLR = -10.16 dB exactly) and chips are sized in nulls.

Method. Around the strongest pixel near each truth a chip of ``+-(islr_nulls + margin)`` nulls is
cut (zero-padded where it leaves the image) and Fourier transformed. Focused images have
spectra centred on a carrier/Doppler offset (e.g. exp(j 4 pi R / lambda) ramps) that may wrap
around the Nyquist bin, so each axis' band centre is estimated (circular centroid of the
marginal power spectrum) and the DFT bins are relabelled to frequencies around it; the chip is
then a trigonometric polynomial that can be evaluated anywhere (band-limited interpolation,
equivalent to zero padding in the middle of the guard band). The peak is refined by a zoomed,
separable matrix DFT to about 1e-4 sample, and 1-D cuts through it along each axis are
evaluated at ``upsample`` points per sample (no whole-chip upsampling, so 3D stays cheap).

Principal axes. On a skewed grid (the squint frame (x_n, r_0)) or with a rotated spectral support
(polar-format images) the response is not separable along the image axes: it is the transform of
a parallelogram (parallelepiped in 3D) and its side-lobe ridges run perpendicular to the support's
edges. The edges are found from the chip's own spectrum (Hann-windowed to +-8 nulls so that
neighbours barely enter, gradient of its magnitude, dominant gradient orientations) and each
target is measured along those ridges (:func:`principal_directions`). A ridge belongs to the image
axis it is closest to; it is parametrised by its displacement along that axis, so the theory of the
cut is that axis' ``theoretical_irw`` (the -3 dB extent of the ridge's main lobe along its own axis;
for the squint frame that is 0.886 v / B_d, exactly what the processors record). With a ``metric``
(physical displacement per unit of each axis, e.g. the squint frame's slant-plane basis) widths are
reported as lengths along the cut; ratios to theory do not depend on it. The image-axis cuts are
kept as ``image_axes``.

Neighbours and edges. Other targets whose responses reach into a chip are removed first: each is
modelled as the ideal response of its own measured support (principal directions, band centre,
theoretical widths; unweighted, or Hamming when ``irw_factor`` > 1.1), complex amplitudes fitted
jointly by least squares on the main lobes, and subtracted. A cut whose ISLR window (plus two
nulls) leaves the image is flagged ``truncated``: its figures come from a zero-padded window and are
never counted as a pass.
"""

from __future__ import annotations

import dataclasses
import functools
import itertools
import math
from collections.abc import Callable, Collection, Iterable, Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from sarproc.product import fft as sfft
from sarproc.product.config import param
from sarproc.product.errors import InputError
from sarproc.product.metadata import SINC_IRW_FACTOR
from sarproc.product.model import target_names
from sarproc.product.steps import steps, wrapped
from sarproc.product.theory import cut_metrics as _cut_metrics, window_theory
from sarproc.product.uniform_spline import uniform_cubic_spline
from sarproc.quality import kernels_aot
from sarproc.quality.blas import single_blas
from sarproc.quality.line_moments import line_sums, series_length
from sarproc.quality.linesum import exponential_sums
from sarproc.quality.lstsq import least_squares
from sarproc.quality.residual import (
    COINCIDE_NULLS,
    RESIDUAL_BUDGET,
    CrowdedGroup,
    FalseTargetList,
    FitStart,
    ResidualFloor,
    ResponseModel,
    fit_response_models,
    model_values,
    residual_false_target,
    separated_starts,
    spectral_orders,
    unique_columns,
)
from sarproc.quality.threads import ordered_map

# Samples per null spacing 1/B below which an axis is undersampled. A grid at exactly 1/B is critically sampled
# and measurable (the cut is sinc-interpolated); array3d at elevation padding 1 steps asin(lambda / (N d)), which
# the small-angle null lambda / (N d) puts 2e-6 below one sample: that is rounding of the theory, not aliasing.
CRITICAL_SAMPLING = 1.0 - 1e-5

if TYPE_CHECKING:
    import numpy.typing as npt

    from sarproc.product.model import Product
    from sarproc.quality.moving import MoverReport


@dataclasses.dataclass(frozen=True)
class EvaluateParams:
    """Parameters of the ``evaluate:`` section (all dimensionless)."""

    search_cells: float = param(default=3.0, gt=0, doc="peak search half-window around each truth, resolution cells")
    guard_cells: float = param(
        default=20.0,
        gt=0,
        doc=(
            "half-size of the box around each target excluded from the false-target search, resolution cells; "
            "20 keeps the along-axis sinc side lobes of a target (about -37 dB there) out of the false-target level"
        ),
    )
    upsample: int = param(default=64, ge=16, le=4096, doc="samples per image sample in the 1-D cuts (>= 16)")
    islr_nulls: float = param(default=10.0, gt=1, doc="ISLR/PSLR window half-width, in nulls (1/B)")
    margin_nulls: float = param(default=6.0, ge=1, doc="chip half-width beyond the ISLR window, nulls")
    irw_factor: float = param(
        default=SINC_IRW_FACTOR,
        gt=0,
        doc=(
            "IRW_theory * B of the image's theory; 0.886 for unweighted processing (about 1.30 when theory is a "
            "Hamming-weighted IRW). Targets with their own theory in the targets table (null_<axis>, written by every "
            "processor) do not use it"
        ),
    )
    principal_axes: bool = param(
        default=True,
        doc=(
            "measure along the response's principal axes (side-lobe ridges found from the chip's spectral support); "
            "false: along the image axes only"
        ),
    )
    remove_neighbours: bool = param(
        default=True,
        doc=("fit and subtract the ideal responses of other targets inside a target's chip before measuring it"),
    )
    exact: bool = param(
        default=False,
        doc=(
            "reference numerics: SVD least squares, the full orientation density, cuts as direct Fourier sums and "
            "numpy neighbour responses (slower; the fast path is tested to give the same report)"
        ),
    )
    neighbour_orders: int = param(
        default=2,
        ge=0,
        le=4,
        doc=(
            "where ideal responses fit a crowded group poorly (residual above -30 dB), its members are fitted again as "
            "response models with this many spectral orders per axis (their weight and phase, a spatial chirp) and "
            "those are subtracted if they fit better; 0: ideal responses only"
        ),
    )
    residual: bool = param(
        default=True,
        doc=(
            "search false targets on the residual image (every target's fitted response subtracted, side lobes "
            "included) and gate --expect false_target_db_max on it; the guard-window figure is reported beside it. "
            "2D images only: on 3D cubes the guard-window figure is reported, with a note (see docs/product.md); "
            "false: the guard-window figure only"
        ),
    )
    residual_orders: int = param(
        default=1,
        ge=0,
        le=4,
        doc=(
            "spectral orders per axis of each target's response model (half-null-shifted sincs; 1 fits a linear "
            "taper and phase over the band, 2 a Hamming window)"
        ),
    )
    fold_elevation: bool = param(
        default=False,
        doc=(
            "3D cubes of a uniform array: measure each target where the array images it, sin(elevation) wrapped "
            "into the array's unambiguous period (image attribute elevation_period, lambda / d), so a target "
            "beyond the grating-lobe angle is measured at its fold; targets inside the period are unchanged"
        ),
    )
    fit_nulls: float = param(default=6.0, gt=1, doc="half-width of the box each response model is fitted on, nulls")
    fit_ridge_nulls: float = param(
        default=40.0,
        ge=0,
        doc=(
            "each response model is also fitted on strips +-1 null wide along its side-lobe ridges out to this many "
            "nulls"
        ),
    )
    joint_ridge_lines: bool = param(
        default=False,
        doc=(
            "residual models of sheared targets that share a ridge line are also fitted in pairs, jointly on the "
            "union of their strips: a crowded sheared 3x4's floor -37.45 -> -37.90 dB (uniform), -38.50 -> -40.07 "
            "(Hamming), for 1.8-2.2x evaluate's CPU there (docs/cli.md, 'Session 45: shared ridge lines')"
        ),
    )
    exclusion_cells: float = param(
        default=2.0,
        gt=0,
        doc=(
            "half-size of the box around each target left out of the residual false-target search (its main lobe), "
            "resolution cells"
        ),
    )


@dataclasses.dataclass(frozen=True)
class AxisMetrics:
    """Metrics of one target along one cut (lengths in metres along the cut where the frame gives a metric,
    else in the axis' units)."""

    axis: str
    irw: float  # -3 dB width of the main lobe
    irw_theory: float
    irw_ratio: float  # irw / irw_theory
    pslr_db: float  # highest side lobe within the ISLR window / peak; -inf if none
    islr_db: float  # side-lobe energy in the window / main-lobe energy
    mainlobe_width: float  # distance between the first nulls (local minima)
    position: float  # refined peak position
    truth: float
    position_error: float  # position - truth
    position_error_cells: float  # position_error / irw_theory
    band_center: float  # spectral centre of the chip, cycles per axis unit
    direction: tuple = ()  # cut direction in axis units per unit along its own axis (dims order)
    angle_deg: float = 0.0  # angle between the cut and its image axis (metric if given, else in nulls)
    truncated: bool = False  # the ISLR window (+2 nulls) of this cut leaves the image: unverified
    contaminated_db: float | None = None  # neighbours poorly fitted by ideal responses put this much energy
    # (dB of the main lobe's) in the ISLR window: unverified
    # A contaminated cut measured again on a window shortened to +-shortened_nulls (integer nulls, half-way
    # to the nearest such neighbour on the cut line, so it stops before its main lobe): PSLR over the side
    # lobes inside, ISLR over that window, and an unweighted sinc's ISLR over it. Never a pass (unverified).
    shortened_nulls: float | None = None
    shortened_pslr_db: float | None = None
    shortened_islr_db: float | None = None
    shortened_islr_theory_db: float | None = None
    theory: str = "image"  # whose theoretical IRW: 'image' (the image's per-axis value) or 'target' (its own)
    # the theoretical PSLR / ISLR the cut is judged against: the target's own (targets table pslr_/islr_<axis>),
    # else that of the window irw_factor implies (unweighted sinc, or Hamming above 1.1)
    pslr_theory_db: float | None = None
    islr_theory_db: float | None = None


@dataclasses.dataclass(frozen=True)
class TargetReport:
    name: str
    peak_amplitude: float  # |interpolated peak|, image units
    peak_phase: float  # arg of the interpolated peak, rad
    peak_index: tuple[int, ...]  # strongest pixel in the search window
    chip_clipped: bool  # the chip left the image and was zero-padded
    axes: tuple[AxisMetrics, ...]  # principal-axis cuts, one per image axis (what --expect checks)
    image_axes: tuple[AxisMetrics, ...] = ()  # cuts along the image axes, for comparison
    neighbours_removed: tuple[str, ...] = ()  # targets whose fitted ideal responses were subtracted
    notes: tuple[str, ...] = ()  # what the focusing stage recorded about this target (:func:`focus_limit_notes`)

    @property
    def truncated(self) -> bool:
        return any(m.truncated for m in self.axes)

    def axis(self, name: str) -> AxisMetrics:
        for m in self.axes:
            if m.axis == name:
                return m
        raise KeyError(name)

    @classmethod
    def from_dict(cls, d: dict) -> TargetReport:
        """The report of one target back from its JSON (an element of ``QualityReport.to_dict()["targets"]``,
        as ``sarproc evaluate -o`` writes it): what scripts tabulate and :func:`target_patch` plots. JSON has no
        NaN or infinity, so a plain-float figure written as null reads back as NaN (an -inf PSLR too)."""
        return cls(
            name=d["name"],
            peak_amplitude=_float(d["peak_amplitude"]),
            peak_phase=_float(d["peak_phase"]),
            peak_index=tuple(d["peak_index"]),
            chip_clipped=d["chip_clipped"],
            axes=tuple(_axis_from_dict(a) for a in d["axes"]),
            image_axes=tuple(_axis_from_dict(a) for a in d.get("image_axes", ())),
            neighbours_removed=tuple(d.get("neighbours_removed", ())),
            notes=tuple(d.get("notes", ())),
        )


def _float(v: Any) -> float:
    return math.nan if v is None else float(v)


_AXIS_FIELDS = {f.name: f.type for f in dataclasses.fields(AxisMetrics)}


def _axis_from_dict(d: dict) -> AxisMetrics:
    """AxisMetrics from its JSON: plain-float fields null -> NaN, lists -> tuples, unknown keys left out."""
    kw: dict[str, Any] = {}
    for k, v in d.items():
        if k not in _AXIS_FIELDS:
            continue
        if _AXIS_FIELDS[k] == "float":
            v = _float(v)
        elif isinstance(v, list):
            v = tuple(v)
        kw[k] = v
    return AxisMetrics(**kw)


@dataclasses.dataclass(frozen=True)
class FalseTarget:
    level_db: float  # refined peak of the response / strongest true target peak
    position: dict  # {dim: axis-unit position of the refined peak}
    pixel_level_db: float  # same with the raw pixel magnitude
    reference_target: str  # name of the strongest true target
    # the residual's figure only (None elsewhere): the measured target whose peak is nearest and how far, in
    # resolution cells of the image's theory, and whether it is a ghost: the false-target list's first entry
    # (it stands over the residual's floor + LIST_MARGIN_DB and is no target's residue); False: it is not, so
    # the strongest residual outside the main lobes is the floor itself or the residue of a target's model
    nearest_target: str | None = None
    nearest_cells: float | None = None
    ghost: bool | None = None


@dataclasses.dataclass(frozen=True)
class QualityReport:
    dims: tuple[str, ...]
    targets: tuple[TargetReport, ...]
    false_target: FalseTarget | None  # None: no pixel lies outside every target neighbourhood
    params: EvaluateParams
    movers: tuple = ()  # sarproc.quality.moving.MoverReport per moving truth target measured
    # The residual figures (params.residual): false_target is then the residual's, and false_target_guard
    # the strongest response outside the +-guard_cells windows of the image itself (the older figure).
    false_target_guard: FalseTarget | None = None
    residual: ResidualFloor | None = None
    residual_note: str | None = None  # why the residual figures were not taken, where asked for
    # every false target over the residual's floor (the first is false_target); None without the residual
    false_targets: FalseTargetList | None = None
    # the false-target level the truth predicts (first order), {level_db, source}: filled in by
    # sarproc.focus.multichannel.channels.ghost_predictions (a simulated channel imbalance); not in to_dict when None
    false_target_predicted: dict | None = None

    def target(self, name: str) -> TargetReport:
        for t in self.targets:
            if t.name == name:
                return t
        raise KeyError(name)

    def to_dict(self) -> dict:
        """JSON-able dict: non-finite floats become None (JSON has no NaN/inf); no ``false_target_predicted`` entry
        without a prediction."""
        d = dataclasses.asdict(self)
        if d["false_target_predicted"] is None:
            del d["false_target_predicted"]
        return jsonable(d)


def jsonable(v: Any) -> Any:
    """``v`` for ``json.dumps(..., allow_nan=False)``: dicts, lists and tuples walked, numpy scalars as Python ones,
    non-finite floats as None (JSON has no NaN/inf; evaluate's and ghost-test's reports)."""
    if isinstance(v, dict):
        return {str(k): jsonable(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [jsonable(x) for x in v]
    if isinstance(v, (np.generic,)):
        v = v.item()
    if isinstance(v, float) and not math.isfinite(v):
        return None
    return v


# ----------------------------------------------------------------------------------------------
# Geometry of the sampled axes


@dataclasses.dataclass(frozen=True)
class _Axis:
    name: str
    start: float  # coordinate of sample 0
    step: float  # signed spacing, axis units
    size: int
    irw: float  # theoretical IRW, axis units
    null: float  # null spacing 1/B in samples
    theory: str = "image"  # whose IRW: the image's, or the target's own ('target')
    pslr_theory: float | None = None  # dB
    islr_theory: float | None = None

    def to_index(self, x: npt.ArrayLike) -> np.ndarray:
        return (np.asarray(x, dtype=float) - self.start) / self.step

    def to_coord(self, i: npt.ArrayLike) -> np.ndarray:
        return self.start + np.asarray(i, dtype=float) * self.step

    def cells_to_samples(self, cells: float) -> int:
        return int(math.ceil(cells * self.irw / abs(self.step)))

    def nulls_to_samples(self, nulls: float) -> int:
        return int(math.ceil(nulls * self.null))


def _make_axes(
    shape: tuple[int, ...], dims: Sequence[str], coords: Any, theoretical_irw: npt.ArrayLike, irw_factor: float
) -> list[_Axis]:
    if len(dims) != len(shape):
        raise InputError(f"image has {len(shape)} axes but dims {tuple(dims)}")
    irw = np.asarray(theoretical_irw, dtype=float).ravel()
    if irw.size != len(dims):
        raise InputError(f"theoretical_irw has {irw.size} values; the image has {len(dims)} axes {tuple(dims)}")
    axes = []
    for a, (name, n) in enumerate(zip(dims, shape)):
        c = np.asarray(coords[name], dtype=float) if isinstance(coords, dict) else np.asarray(coords[a], dtype=float)
        if c.ndim != 1 or c.size != n:
            raise InputError(f"coordinate {name!r}: expected {n} values, got shape {c.shape}")
        if n < 2:
            raise InputError(f"axis {name!r} has {n} sample(s); at least 2 are needed")
        if not np.all(np.isfinite(c)):
            raise InputError(f"coordinate {name!r} contains NaN or Inf")
        d = np.diff(c)
        step = (c[-1] - c[0]) / (n - 1)
        if step == 0 or np.max(np.abs(d - step)) > 1e-6 * abs(step):
            raise InputError(f"coordinate {name!r} is not uniformly spaced")
        if not (math.isfinite(irw[a]) and irw[a] > 0):
            raise InputError(f"theoretical_irw[{a}] ({name}) must be positive and finite, got {irw[a]!r}")
        null = irw[a] / (irw_factor * abs(step))  # samples per 1/B
        if null < CRITICAL_SAMPLING:
            raise InputError(
                f"axis {name!r}: spacing {abs(step):.4g} is not finer than the null spacing 1/B = "
                f"{null * abs(step):.4g} (theoretical IRW {irw[a]:.4g}); the image is undersampled for this theory"
            )
        window = window_theory("hamming" if irw_factor > 1.1 else "none")
        axes.append(
            _Axis(
                name,
                float(c[0]),
                float(step),
                int(n),
                float(irw[a]),
                float(null),
                pslr_theory=window.pslr_db,
                islr_theory=window.islr_db,
            )
        )
    return axes


def window_slices(center: Iterable[Any], half: Iterable[Any], shape: Iterable[int]) -> tuple[slice, ...]:
    """Slices of the box ``center +- half`` (integer samples) clipped to ``shape``."""
    out = []
    for c, h, n in zip(center, half, shape):
        lo = min(max(0, int(c) - int(h)), int(n))
        out.append(slice(lo, max(lo, min(int(n), int(c) + int(h) + 1))))  # empty, never negative
    return tuple(out)


def extract_chip(data: np.ndarray, center: Iterable[Any], half: Iterable[Any]) -> tuple[np.ndarray, bool]:
    """Box ``center +- half`` of ``data`` (shape ``2*half+1`` per axis), zero outside the image.

    Returns the chip (a new array, complex128) and whether it was clipped by the image edge.
    """
    center = [int(c) for c in center]
    half = [int(h) for h in half]
    chip = np.zeros([2 * h + 1 for h in half], dtype=np.complex128)
    src = window_slices(center, half, data.shape)
    dst = tuple(slice(s.start - (c - h), s.stop - (c - h)) for s, c, h in zip(src, center, half))
    chip[dst] = data[src]
    clipped = any(s.stop - s.start != 2 * h + 1 for s, h in zip(src, half))
    return chip, clipped


# ----------------------------------------------------------------------------------------------
# Band-limited chip


class _Chip:
    """Trigonometric interpolant of a chip whose spectrum is band-centred per axis.

    ``origin`` is the image index of chip sample 0 per axis; positions passed to
    :meth:`values` are image indices (float).
    """

    def __init__(
        self,
        data: np.ndarray | None,
        center: Iterable[Any],
        half: Iterable[Any],
        chip: tuple[np.ndarray, bool] | None = None,
    ) -> None:
        if chip is None:
            assert data is not None  # the image, when no chip is given
            self.data, self.clipped = extract_chip(data, center, half)
        else:  # an already extracted (e.g. neighbour-cleaned) chip of the same box
            self.data, self.clipped = chip
        self.origin = np.array([int(c) - int(h) for c, h in zip(center, half)])
        self.shape = self.data.shape
        spec = sfft.fftn(self.data, workers=-1)
        power = np.abs(spec)
        np.square(power, out=power)  # |S| ** 2 in place (numpy's float ** 2 is this square)
        self.spec = spec
        self.freqs = []  # unwrapped frequency of each bin, cycles per sample
        self.centers = []  # band centre, cycles per sample
        for a, n in enumerate(self.shape):
            marginal = power.sum(axis=tuple(b for b in range(power.ndim) if b != a))
            m = np.arange(n)
            # Circular centroid of the marginal power: robust to a band wrapped across Nyquist.
            c = int(round(np.angle(np.sum(marginal * np.exp(2j * np.pi * m / n))) * n / (2 * np.pi)))
            # Relabel bin m to the frequency congruent to it within c +- n/2 (band-centred).
            k = (m - c + n // 2) % n - n // 2 + c
            self.freqs.append(k / n)
            self.centers.append(c / n)

    def values(self, positions: Sequence[npt.ArrayLike]) -> np.ndarray:
        """Interpolated values on the outer product of per-axis position arrays (image indices)."""
        grids = [np.atleast_1d(np.asarray(p, dtype=float)) - o for p, o in zip(positions, self.origin)]
        out = self.spec
        # Contract the axes with the fewest output points first (cheapest order).
        for a in sorted(range(len(grids)), key=lambda a: grids[a].size):
            kernel = np.exp(2j * np.pi * np.outer(grids[a], self.freqs[a]))
            out = np.moveaxis(np.tensordot(kernel, out, axes=([1], [a])), 0, a)
        return out / self.data.size

    def values_upsampled(self, pos: npt.ArrayLike, half: Mapping[int, int], upsample: int) -> np.ndarray | None:
        """:meth:`values` at ``pos`` (image indices) but along each axis ``a`` of ``half`` at ``pos[a] + j /
        upsample`` for ``|j| <= half[a]``: each of those axes by one inverse FFT of the chip's bins, phase-shifted
        to ``pos[a]`` and zero-padded to ``upsample`` times the chip's length (the same sums as :meth:`values`'s
        matrix products, equal to rounding, a fraction of their time); None when the grid is longer than that."""
        x0 = np.asarray(pos, dtype=float) - self.origin
        if any(2 * m + 1 > self.shape[a] * upsample for a, m in half.items()):
            return None
        out = self.spec
        for a in sorted(range(out.ndim), key=lambda a: a in half):  # the single positions first (cheapest)
            shape = [1] * out.ndim
            shape[a] = -1
            if a not in half:
                kernel = np.exp(2j * np.pi * np.outer(x0[a : a + 1], self.freqs[a]))
                out = np.moveaxis(np.tensordot(kernel, out, axes=([1], [a])), 0, a)
                continue
            n_fft = self.shape[a] * upsample
            bins = np.rint(self.freqs[a] * self.shape[a]).astype(int) % n_fft
            padded = np.zeros(out.shape[:a] + (n_fft,) + out.shape[a + 1 :], dtype=complex)
            index: list[Any] = [slice(None)] * out.ndim
            index[a] = bins
            padded[tuple(index)] = out * np.exp(2j * np.pi * x0[a] * self.freqs[a]).reshape(shape)
            full = sfft.ifft(padded, axis=a) * n_fft
            out = np.take(full, np.arange(-half[a], half[a] + 1) % n_fft, axis=a)
        return out / self.data.size

    def values_along(self, start: npt.ArrayLike, direction: npt.ArrayLike, offsets: npt.ArrayLike) -> np.ndarray:
        """Interpolated values at ``start + t * direction`` for t in ``offsets`` (image indices).

        Exact band-limited evaluation on a line of any direction: the last axis is contracted by one
        matrix product, the others elementwise (cost about chip size x len(offsets)).
        """
        x0 = np.asarray(start, dtype=float) - self.origin
        v = np.asarray(direction, dtype=float)
        t = np.asarray(offsets, dtype=float)
        n = self.spec.ndim

        def kern(a: int) -> np.ndarray:  # (T, K_a)
            return np.exp(2j * np.pi * np.outer(x0[a] + t * v[a], self.freqs[a]))

        out = (self.spec.reshape(-1, self.shape[-1]) @ kern(n - 1).T).reshape(self.shape[:-1] + (t.size,))
        for a in range(n - 2, -1, -1):
            out = np.einsum("...kt,tk->...t", out, kern(a))
        return out / self.data.size

    def values_on_line(
        self, start: npt.ArrayLike, direction: npt.ArrayLike, first: float, step: float, count: int
    ) -> np.ndarray:
        """:meth:`values_along` at the uniform offsets ``first + j * step`` (j < count), as one type-1
        non-uniform FFT over the chip's bins (:func:`sarproc.quality.kernels.exponential_sums`): about
        chip size x 16 operations instead of chip size x count, equal to rounding (1e-13 of the peak). On a
        cube, a line close to an image axis (a principal cut) by moments of the spectrum instead
        (:func:`sarproc.quality.line_moments.line_sums`: multiply-adds in place of the NUFFT's kernel
        evaluations, a tenth of its time; 1e-15 of the peak)."""
        x0 = np.asarray(start, dtype=float) - self.origin
        v = np.asarray(direction, dtype=float)
        if self.spec.ndim == 3:  # a principal axis of a cube is close to an image axis: moments of the spectrum
            sums = line_sums(self.spec, self.freqs, x0, v, first, step, count)
            if sums is not None:
                return sums / self.data.size
        phase = functools.reduce(np.add.outer, [f * x for f, x in zip(self.freqs, x0)])
        freq = functools.reduce(np.add.outer, [f * d for f, d in zip(self.freqs, v)])
        coef = self.spec * np.exp(2j * np.pi * phase)
        return exponential_sums(coef, freq, first, step, count, compiled=coef.ndim == 3) / self.data.size

    def lines_through(self, start: npt.ArrayLike) -> Callable[[npt.ArrayLike, float, float, int], np.ndarray]:
        """A 2D chip's :meth:`values_on_line` through the one point ``start`` (image indices), as a function of
        (direction, first, step, count), for many directions: the spectrum's phase at ``start`` is applied once,
        then each line is two per-axis tables of exponentials and one matrix product, sum_k0 E0[k0, j]
        sum_k1 coef[k0, k1] E1[k1, j] (chip size x count multiply-adds by BLAS, (n0 + n1) x count / 2 sines and
        cosines: a line's offsets first + centre step + m step, m = -centre .. count - 1 - centre, take the
        tables' m >= 0 half and its conjugate). On 000 and 002 small's chips (69 x 41, 85 x 77; 161 offsets)
        0.23 / 0.37 ms a line against the non-uniform FFT's 0.64 / 1.37 ms, whose spreading of every bin is the
        cost; the two agree to 7e-15 of the peak (the NUFFT's error; this sum is exact to rounding)."""
        if self.spec.ndim != 2:
            raise ValueError("lines_through takes a 2D chip")
        x0 = np.asarray(start, dtype=float) - self.origin
        phase = functools.reduce(np.add.outer, [f * x for f, x in zip(self.freqs, x0)])
        coef = self.spec * np.exp(2j * np.pi * phase)  # values_on_line's coefficients, once
        f0, f1 = self.freqs
        size = self.data.size

        def line(direction: npt.ArrayLike, first: float, step: float, count: int) -> np.ndarray:
            v = np.asarray(direction, dtype=float)
            centre = count // 2
            shift = first + centre * step  # 0 on a line centred on ``start``
            m = np.arange(max(centre, count - 1 - centre) + 1)

            def table(w: np.ndarray) -> np.ndarray:  # exp(2 pi i w_k m step), m = -centre .. count - 1 - centre
                arg = (2 * np.pi * step) * np.outer(w, m)
                half = np.empty(arg.shape, dtype=np.complex128)
                np.cos(arg, out=half.real)
                np.sin(arg, out=half.imag)
                return np.concatenate([half[:, centre:0:-1].conj(), half[:, : count - centre]], axis=1)

            c = coef if shift == 0 else coef * np.exp(2j * np.pi * shift * np.add.outer(f0 * v[0], f1 * v[1]))
            out: np.ndarray = np.einsum("kj,kj->j", table(f0 * v[0]), c @ table(f1 * v[1])) / size
            return out

        return line

    def values_on_axis(self, start: npt.ArrayLike, axis: int, first: float, step: float, count: int) -> np.ndarray:
        """Values at ``start`` moved along image axis ``axis`` by ``first + j * step`` (j < count): the other
        axes contracted at ``start``, then one non-uniform FFT over that axis' bins (no count x bins
        exponentials)."""
        x0 = np.asarray(start, dtype=float) - self.origin
        out = self.spec
        for b in range(self.spec.ndim - 1, -1, -1):
            if b != axis:
                out = np.tensordot(out, np.exp(2j * np.pi * x0[b] * self.freqs[b]), axes=([b], [0]))
        return exponential_sums(out, self.freqs[axis], x0[axis] + first, step, count) / self.data.size

    def refine_peak(
        self, start: npt.ArrayLike, tol: float = 1e-4, fixed: Collection[int] = (), exact: bool = False
    ) -> tuple[np.ndarray, complex]:
        """Local maximum of |f| near ``start`` (image indices) by zooming 9-point grids; the axes ``fixed`` stay
        at ``start``. On a 3D chip (no axis fixed; not ``exact``) the zooms after the first take their grids
        from :class:`_LocalMoments` about the first zoom's maximum (the same values to rounding, the same grid
        points chosen); ``exact``: every zoom by :meth:`values`."""
        pos = np.asarray(start, dtype=float)
        half = 1.0
        best = None
        local: _LocalMoments | None = None
        while True:
            grids = [np.array([p]) if a in fixed else p + np.linspace(-half, half, 9) for a, p in enumerate(pos)]
            vals = self.values(grids) if local is None else local.values(grids)
            idx = np.unravel_index(np.argmax(np.abs(vals)), vals.shape)
            pos = np.array([g[i] for g, i in zip(grids, idx)])
            best = vals[idx]
            if half / 4 < tol:
                return pos, complex(best)
            if local is None and half == 1.0 and self.spec.ndim == 3 and not fixed and not exact:
                # every later grid lies within 1/4 + 1/16 + ... = 1/3 sample of this maximum
                local = _LocalMoments(self, pos, 1.0 / 3.0)
            half /= 4.0


class _LocalMoments:
    """A 3D chip's interpolant near ``centre`` (image indices), within ``reach`` samples of it along every axis,
    as a Taylor series in the offset: with each bin's frequency f = c + g (c the axis' band centre, |g| <= 1/2),
    f(centre + d) = exp(2 pi i c . d) / N sum_m prod_a (2 pi i d_a)^m_a / m_a! M[m], the moments
    M[m] = sum_k S_k exp(2 pi i f_k . x) prod_a g_a,k^m_a read from the spectrum once (P x chip size multiply-adds,
    P = :func:`line_moments.series_length` of the turn 2 pi reach / 2, about 19 terms for a third of a sample);
    each grid after that costs P^3 x 9, not 9 x chip size. The truncation is below 1e-16 of sum |S_k| (the
    bound line_moments keeps), so :meth:`_Chip.refine_peak`'s zooms pick the same grid points: the peak's
    neighbours on the finest grid differ by ~1e-9 of it."""

    def __init__(self, chip: _Chip, centre: np.ndarray, reach: float) -> None:
        self.centre = np.asarray(centre, dtype=float)
        self.size = chip.data.size
        self.band = np.asarray(chip.centers, dtype=float)
        self.terms = series_length(2 * math.pi * reach * 0.5)
        x = self.centre - chip.origin
        out = chip.spec
        for a in range(out.ndim):  # axis 0's product reads the whole spectrum; the others a P-th of what is left
            g = chip.freqs[a] - self.band[a]
            table = np.vander(g, self.terms, increasing=True).T * np.exp(2j * np.pi * chip.freqs[a] * x[a])
            out = np.moveaxis(np.tensordot(table, out, axes=([1], [a])), 0, a)
        self.moments = out

    def values(self, positions: Sequence[npt.ArrayLike]) -> np.ndarray:
        """:meth:`_Chip.values` on the outer product of per-axis positions (image indices) within the reach."""
        out = self.moments
        for a, p in enumerate(positions):
            d = np.atleast_1d(np.asarray(p, dtype=float)) - self.centre[a]
            m = np.arange(self.terms)
            coef = (2j * np.pi * d[:, None]) ** m / np.array([math.factorial(int(k)) for k in m])
            coef = coef * np.exp(2j * np.pi * self.band[a] * d)[:, None]
            out = np.moveaxis(np.tensordot(coef, out, axes=([1], [a])), 0, a)
        return out / self.size


@functools.cache
def _orientation_grid(ndim: int) -> tuple[np.ndarray, float]:
    """Candidate line orientations (unit vectors, one per +-pair) and their spacing-matched kernel width (rad)."""
    if ndim == 2:
        a = np.deg2rad(np.arange(0.0, 180.0, 0.5))
        return np.stack([np.cos(a), np.sin(a)], axis=1), math.radians(1.0)
    # Fibonacci points on the half sphere z >= 0, about 2.3 deg apart
    n = 4000
    i = np.arange(n) + 0.5
    z, phi = i / n, i * math.pi * (3.0 - math.sqrt(5.0))
    r = np.sqrt(1.0 - z**2)
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1), math.radians(3.0)


@functools.cache
def _padded_neighbours(ndim: int) -> np.ndarray:
    """Per candidate of :func:`_orientation_grid`, the indices (ascending) of its neighbours within two kernel
    widths (+-), one row each, padded with its own index (so ``dens[rows].max(axis=1)`` is each candidate's
    neighbourhood maximum).

    A block of 500 rows at a time, against only the candidates whose last coordinate can be near enough: two
    unit vectors within an angle 2 sigma differ by less than that in every coordinate (|c_i - c_j| < 2 sigma),
    and two within 2 sigma of opposite (|c_i + c_j| < 2 sigma) sum to less in every coordinate. The 3D grid
    (4000, sorted by that coordinate) then takes a tenth of the products: the whole 4000 x 4000 took 0.09 s of
    the cube's evaluate."""
    cand, sigma = _orientation_grid(ndim)
    reach = math.cos(2 * sigma)
    band = 2 * sigma + 1e-6  # beyond rounding
    z = cand[:, -1]
    rows_of: list[np.ndarray] = []
    cols_of: list[np.ndarray] = []
    for b in range(0, len(cand), 500):
        lo, hi = float(z[b : b + 500].min()), float(z[b : b + 500].max())
        cols = np.flatnonzero(((z > lo - band) & (z < hi + band)) | ((z > -band - hi) & (z < band - lo)))
        rows, at = np.nonzero(np.abs(cand[b : b + 500] @ cand[cols].T) > reach)  # row-major: columns ascending
        rows_of.append(b + rows)
        cols_of.append(cols[at])
    rows, cols = np.concatenate(rows_of), np.concatenate(cols_of)
    first = np.searchsorted(rows, np.arange(len(cand)))  # where each row's run starts
    place = np.arange(len(rows)) - first[rows]
    out = np.repeat(np.arange(len(cand)), int(place.max()) + 1).reshape(len(cand), -1)
    out[rows, place] = cols
    return out


def _orientation_density(
    cand: np.ndarray, u: np.ndarray, weight: np.ndarray, sigma: float, exact: bool = False
) -> np.ndarray:
    """Sum over unit vectors u (weights ``weight``) of exp((cos^2 - 1) / 2 sigma^2) at each candidate.

    Terms below exp(-40) of their weight (1e-17) are left out unless ``exact`` (in 3D, compiled, those below
    exp(-kernels_aot.DENSITY_PRUNE / 2)): the exponential is then taken on the few pairs within about 9 (3D: 5)
    kernel widths."""
    if not exact and cand.shape[1] == 3:
        cand = kernels_aot.f8(cand)
        blocks = _candidate_blocks(cand.tobytes(), float(sigma))
        return kernels_aot.kernels().orientation_density(
            cand, kernels_aot.f8(u), kernels_aot.f8(weight), float(sigma), *blocks
        )
    if not exact and cand.shape[1] == 2 and _angle_reach(len(cand), sigma) < len(cand) // 2:
        return _orientation_density_2d(cand, u, weight, sigma)
    d2 = (cand @ u.T) ** 2
    if exact:
        return np.exp((d2 - 1.0) / (2 * sigma**2)) @ weight
    near = d2 > 1.0 - 80.0 * sigma**2
    w = np.zeros_like(d2)
    w[near] = np.exp((d2[near] - 1.0) / (2 * sigma**2))
    return w @ weight


# The blocks of 3D candidates the compiled density skips unit vectors by (:func:`_candidate_blocks`): cells of
# about this many radians of polar angle by as many of arc along the parallels (61 blocks of the 4000-point grid:
# 2x faster than 206 blocks of 10 deg or no blocks, on paper 004's chips; the exponentials are left).
BLOCK_RAD = math.radians(20.0)
BLOCK_MARGIN_RAD = 1e-6  # beyond rounding: a block skips only unit vectors this much farther than the reach


@functools.lru_cache(maxsize=4)
def _candidate_blocks(cand_bytes: bytes, sigma: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(order, starts, centre, reach) of the compiled 3D orientation density's blocks of the unit vectors
    ``cand_bytes`` (C-order float64 (n, 3)): block b holds the candidates order[starts[b]:starts[b + 1]], cells
    of :data:`BLOCK_RAD` in polar angle and along the parallels, inside a cone of half-angle r_b about the unit
    vector centre[b]. A unit vector u with |u . centre[b]| < reach[b] = cos(rho + r_b + margin) is farther than
    rho from every candidate of the block, +-u alike, rho = acos(sqrt(1 - DENSITY_PRUNE sigma^2)) the density's pruning
    reach: their terms are all left out (reach -1 where that cone passes 90 deg: the block skips nothing)."""
    cand = np.frombuffer(cand_bytes, dtype=np.float64).reshape(-1, 3)
    theta = np.arccos(np.clip(cand[:, 2], -1.0, 1.0))
    phi = np.arctan2(cand[:, 1], cand[:, 0]) + math.pi
    band = np.floor(theta / BLOCK_RAD).astype(np.int64)
    sectors = np.maximum(1, np.rint(2 * math.pi * np.sin((band + 0.5) * BLOCK_RAD) / BLOCK_RAD)).astype(np.int64)
    sector = np.minimum(sectors - 1, np.floor(phi / (2 * math.pi) * sectors).astype(np.int64))
    cell = band * (sectors.max() + 1) + sector
    order = np.argsort(cell, kind="stable")
    ids, starts = np.unique(cell[order], return_index=True)
    starts = np.append(starts, len(order)).astype(np.int64)
    rho = math.acos(math.sqrt(max(0.0, 1.0 - kernels_aot.DENSITY_PRUNE * sigma**2)))
    centre = np.zeros((len(ids), 3))
    reach = np.full(len(ids), -1.0)
    for b in range(len(ids)):
        members = cand[order[starts[b] : starts[b + 1]]]
        mean = members.sum(axis=0)
        if np.linalg.norm(mean) == 0:
            continue
        centre[b] = mean / np.linalg.norm(mean)
        cone = rho + float(np.arccos(np.clip(members @ centre[b], -1.0, 1.0)).max()) + BLOCK_MARGIN_RAD
        if cone < math.pi / 2:
            reach[b] = math.cos(cone)
    return order.astype(np.int64), starts, centre, reach


def _angle_reach(n: int, sigma: float) -> int:
    """Candidates on either side of its own that a 2D unit vector reaches in the pruned density: those within
    acos(sqrt(1 - 80 sigma^2)) of its angle, ``n`` candidates spread over 180 deg."""
    return int(math.ceil(math.acos(math.sqrt(max(0.0, 1.0 - 80.0 * sigma**2))) / (math.pi / n))) + 1


def _orientation_density_2d(cand: np.ndarray, u: np.ndarray, weight: np.ndarray, sigma: float) -> np.ndarray:
    """The pruned density of 2D candidates equally spaced in angle over 180 deg: each u only reaches the
    candidates within :func:`_angle_reach` of its own angle (mod 180 deg), so only those pairs (a tenth of
    them) are formed; the same terms as the dense pruned sum."""
    n = len(cand)
    reach = _angle_reach(n, sigma)
    floor = 1.0 - 80.0 * sigma**2
    nearest = np.rint((np.arctan2(u[:, 1], u[:, 0]) - math.atan2(cand[0, 1], cand[0, 0])) / (math.pi / n))
    idx = (nearest.astype(np.int64)[:, None] + np.arange(-reach, reach + 1)) % n  # (len(u), 2 reach + 1)
    d2 = (cand[idx, 0] * u[:, 0, None] + cand[idx, 1] * u[:, 1, None]) ** 2
    w = np.where(d2 > floor, np.exp((np.maximum(d2, floor) - 1.0) / (2 * sigma**2)), 0.0)
    return np.bincount(idx.ravel(), weights=(w * weight[:, None]).ravel(), minlength=n)


def principal_directions(
    chip: np.ndarray, centers: Sequence[float], nulls: npt.ArrayLike, window_nulls: float = 8.0, exact: bool = False
) -> tuple[np.ndarray, np.ndarray]:
    """``(V, f_c)`` of :func:`principal_support`."""
    support = principal_support(chip, centers, nulls, window_nulls, exact)
    return support.ridges, support.band_centre


@dataclasses.dataclass(frozen=True)
class Support:
    """What the spectral support says of a response: its ridges (:func:`principal_directions`' V), band centre
    (cycles/sample) and the axes whose ridge crosses a curved edge pair (a fan of side lobes, :func:`_Arcs`)."""

    ridges: np.ndarray
    band_centre: np.ndarray
    fanned: tuple[int, ...] = ()
    oblique: bool = False  # straight edges oblique in null-normalised frequency: refine in space (_ridges_in_space)


def principal_support(
    chip: np.ndarray,
    centers: Sequence[float],
    nulls: npt.ArrayLike,
    window_nulls: float = 8.0,
    exact: bool = False,
    gram: np.ndarray | None = None,
    ridge_angle: float = math.nan,
) -> Support:
    """Side-lobe ridge directions of the response centred in ``chip``, from its spectral support.

    ``centers``: band centre per axis (cycles/sample); ``nulls``: null spacing 1/B per axis (samples).
    The chip is Hann-windowed to +-``window_nulls`` (neighbours fade, no truncation ripple), its
    spectrum magnitude differentiated in null-normalised frequency, and the dominant orientations of
    the gradient (the normals of the support's edges) are found as the peaks of an orientation
    density, refined by the gradient sum of each cluster (unbiased for a grid-staircased edge). A
    ridge is parallel to the normal of the edge pair it crosses (the response is the product of sincs
    of the support's dual coordinates). Returns ``(V, f_c)``: V (ndim, ndim), row a the ridge that
    belongs to image axis a, in image samples per sample along axis a (V[a, a] = 1); f_c the power
    centroid of the band, cycles/sample (both in a :class:`Support`, with the axes whose ridge is the centre of a
    fan). Falls back to the image axes when no edge is found. ``gram`` (2D, optional): the physical Gram matrix
    of the image's sample steps (:func:`_sample_gram`); a SAR support's two ridges then make ``ridge_angle``
    degrees in space (NaN: 90, the slant plane's; :func:`target_ridge_angles`), :func:`_perpendicular_second`.
    """
    ndim = chip.ndim
    nulls = np.asarray(nulls, dtype=float)
    eye = np.eye(ndim)
    mag, freqs = _support_spectrum(chip, centers, nulls, window_nulls)
    power = mag**2
    total = power.sum()
    if not total > 0:
        return Support(eye, np.asarray(centers, dtype=float))
    f_c = np.array(
        [np.sum(power.sum(axis=tuple(b for b in range(ndim) if b != a)) * freqs[a]) / total for a in range(ndim)]
    )
    if ndim == 1:
        return Support(eye, f_c)
    # d|S| / d(frequency in cycles per null): each axis' band is about one unit wide.
    spacing = [nu / n for nu, n in zip(nulls, mag.shape)]
    g, norm, where = _strong_gradients(mag, spacing, exact)
    u = g / norm[:, None]
    cand, peaks, dens = _orientation_peaks(u, norm, ndim, exact)
    arcs = None
    if ndim == 2:  # the curved edges' plateaus, checked against where their gradients lie
        arcs = _Arcs(_plateaus(dens, peaks), where, norm)
    found, curved = _edge_normals(cand, peaks, u, g, ndim, arcs, exact)
    oblique = False
    if gram is not None and len(found) == 2:
        found[1] = _perpendicular_second(found[0], found[1], nulls, gram, ridge_angle)
        oblique = not any(curved) and _obliqueness_deg(found[0], found[1]) > OBLIQUE_EDGE_DEG
    if len(found) < ndim or abs(np.linalg.det(np.array(found))) < 0.2:
        return Support(eye, f_c)
    best = _assignment(np.array(found))
    fanned = tuple(a for a in range(ndim) if curved[best[a]])
    return Support(_ridges(np.array(found), nulls), f_c, fanned, oblique)


# A SAR image's 2D support is the pulses' lines of sight (each its range band) swept over the aperture: the
# range edges run along the sweep and the azimuth edges along the lines of sight, so the two edge pairs, and
# with them the ridges, are perpendicular in space (bp_beam_edge's A: 89.7 deg, backproject's theory). A
# second edge normal further than this from the perpendicular to the first (the strongest) is not an edge: a
# smooth taper along that axis (a Gaussian or rect antenna under a Hamming window) has none, and the density's
# second peak is then a mix of the taper's gradients and the first edge's (ridges 35-65 deg off in
# scripts/evaluate_campaign.py, IRW/theory 1.13, residual floors -33 dB). Edges found agree within a degree or two.
PERPENDICULAR_EDGE_DEG = 10.0


# A support whose straight edges are oblique in null-normalised frequency (a squinted aperture in a zero-Doppler
# or ground frame; a wide-angle one whose range null is tens of azimuth nulls) and tapered (Hamming windows, a
# Gaussian or sinc beam) has no sharp edge for the gradients to be normal to: each gradient mixes the two tapers'
# slopes, a cone about one normal takes more of them on one side where the other is oblique, and the chip's Hann
# window along the image axes does the same. The cluster mean leans: a 25 deg squinted stripmap under Hamming had
# its range ridge cut at 27.27 deg (range PSLR / ISLR 1.9 / 2.9 dB under its own theory), the 60 deg hard case of
# tests/focus/test_squint_deramp.py at 1.29 deg where its range side lobes lie at 0.0 (docs/product.md). Beyond
# this obliqueness (deg from perpendicular) the ridge is refined in space (:func:`_ridges_in_space`).
OBLIQUE_EDGE_DEG = 2.0
RIDGE_SEARCH_DEG = 4.0  # the refined ridge lies within this of the spectral one (its bias: 2.3 and 1.3 deg above)
RIDGE_SCAN_DEG = 1.0  # first a scan at this step, then golden sections about its best to RIDGE_TOL_DEG
RIDGE_TOL_DEG = 0.01
# The scan's fall off its maximum, on each side, must be at least this fraction of a straight ridge's
# (:func:`_fall_against_a_ridge`): 0.86-1.58 on the tapered, skewed and wide-angle responses the search is for,
# 0.28 (0.46 on its other side) on the backprojected polar sector whose ridges it turned 1.5 deg wrong
RIDGE_FALL_MIN = 0.6
# The side-lobe energy on the two sides of the peak, along the turned ridge, must agree within this: 0.00-0.05
# dB on those responses, 12.4 dB on campaign scene 17's unresolved pair (the line took the other's main lobe)
RIDGE_BALANCE_DB = 1.0
GOLDEN = (math.sqrt(5.0) - 1.0) / 2.0


def _obliqueness_deg(first: np.ndarray, second: np.ndarray) -> float:
    """How far two edge normals (null-normalised frequency) are from perpendicular there, deg."""
    c = abs(float(first @ second)) / float(np.linalg.norm(first) * np.linalg.norm(second))
    return math.degrees(math.asin(min(1.0, c)))


def _ridges_in_space(
    chip: _Chip,
    pos: np.ndarray,
    ridges: np.ndarray,
    nulls: np.ndarray,
    gram: np.ndarray,
    window_nulls: float,
    angle: float = math.nan,
) -> np.ndarray:
    """The ridges ``ridges`` (V of :func:`principal_support`: rows in samples, V[a, a] = 1) of the 2D response at
    ``pos`` (image indices) in ``chip``, refined in space: the ridge of the axis with the longer null in metres is
    turned, within RIDGE_SEARCH_DEG of where it is, to the direction along which the response's side lobes hold
    the most energy (the sum of |h|^2 on the line through the peak, from the main lobe's first nulls to
    +-``window_nulls`` of that axis, as the cut measures them); the other is set at ``angle`` degrees to it in
    space (NaN: 90, perpendicular; of the two such directions, the one nearer the other spectral ridge).

    The objective is one fixed function of one angle, evaluated on the band-limited interpolant (exact), so a
    scan at RIDGE_SCAN_DEG and golden sections about its maximum converge to RIDGE_TOL_DEG. Along the ridge of
    the longer null the objective is sharp: a line turned by d leaves the other axis' main lobe after (its null)
    / d, so that line's side lobes fade; along the shorter one it is flat (a line 1 deg off an azimuth ridge 35
    times narrower than its range lobe stays inside that lobe). The main lobe is left out: its energy is 40 dB
    over a Hamming cut's side lobes and its axis need not be theirs."""
    lower = np.linalg.cholesky(gram).T  # a step in samples -> its components along orthonormal axes in space
    k = int(np.argmax([nulls[a] * math.sqrt(gram[a, a]) for a in range(2)]))
    e0 = lower @ ridges[k]
    theta0 = math.atan2(e0[1], e0[0])

    # the line's samples in metres, the same for every direction (a window fixed in samples of an image axis
    # would lengthen with the angle on a skewed grid, and its extra side lobes pull the maximum)
    step = nulls[k] * float(np.linalg.norm(e0)) / 8.0  # |h|^2 has twice the band: oversampled fourfold
    count = int(math.ceil(window_nulls * 8.0))
    through = chip.lines_through(pos)  # every line passes through the peak
    line = lambda theta: through(_turned(lower, theta), -count * step, step, 2 * count + 1)  # noqa: E731
    # the main lobe's first nulls along the spectral ridge (the mean of the two sides' first minima)
    mag = np.abs(line(theta0))
    edge = []
    for side in (mag[count:], mag[count::-1]):
        mins = np.flatnonzero((side[1:-1] <= side[:-2]) & (side[1:-1] <= side[2:])) + 1
        edge.append(float(mins[0]) if mins.size else 8.0)
    lobes = np.abs(np.arange(-count, count + 1)) >= float(np.mean(edge))

    def energy(theta: float) -> float:
        return float(np.sum(np.abs(line(theta)[lobes]) ** 2))

    span = math.radians(RIDGE_SEARCH_DEG)
    d = math.radians(RIDGE_SCAN_DEG)
    grid = theta0 + np.arange(-span, span + d / 2, d)
    profile = np.array([energy(t) for t in grid])
    best = int(np.argmax(profile))
    if not 0 < best < len(grid) - 1 or not _single_peak(profile, best):
        return ridges  # no maximum inside the span, or more than one (side lobes under noise): not determined
    lo, hi = grid[max(best - 1, 0)], grid[min(best + 1, len(grid) - 1)]
    a, b = hi - GOLDEN * (hi - lo), lo + GOLDEN * (hi - lo)
    fa, fb = energy(a), energy(b)
    while hi - lo > math.radians(RIDGE_TOL_DEG):
        if fa >= fb:
            hi, b, fb = b, a, fa
            a = hi - GOLDEN * (hi - lo)
            fa = energy(a)
        else:
            lo, a, fa = a, b, fb
            b = lo + GOLDEN * (hi - lo)
            fb = energy(b)
    theta = (lo + hi) / 2
    # The search's premises, checked; where either fails, the maximum is not the ridge and the spectral ridges
    # stay. (1) The line holds side lobes only: a real-weighted support's response has |h(-r)| = |h(r)| about its
    # peak, so the line's two sides hold equal energy; another response's lobes on one side (an unresolved
    # neighbour) break that. (2) The energy falls off the maximum as a straight ridge's does; where it falls
    # less, the side lobes are spread over the angles (a polar sector's), not on one line.
    along = np.abs(line(theta)) ** 2
    if abs(_side_balance_db(along, lobes)) > RIDGE_BALANCE_DB:
        return ridges
    offsets = np.arange(-count, count + 1) * step
    other = _turned(lower, theta + _other_ridge_turn(lower, ridges[1 - k], theta, angle))
    across = through(other, -count * step, step, 2 * count + 1)
    if _fall_against_a_ridge(grid, profile, theta, along, np.abs(across) ** 2, offsets, lobes) < RIDGE_FALL_MIN:
        return ridges
    out = np.empty((2, 2))
    ridge = _turned(lower, theta)
    out[k] = ridge / ridge[k]
    out[1 - k] = other / other[1 - k]
    return out


def _other_ridge_turn(lower: np.ndarray, spectral: np.ndarray, theta: float, angle: float) -> float:
    """The turn (rad) from the ridge at ``theta`` (space) to the other: +-``angle`` degrees (NaN: 90), the sign
    whose direction lies nearer the ``spectral`` ridge (samples; ``lower``: the sample Gram's Cholesky factor)."""
    if not math.isfinite(angle) or abs(angle - 90.0) < 1e-9:
        return math.pi / 2
    e = lower @ spectral
    seen = math.atan2(e[1], e[0])

    def off(turn: float) -> float:  # lines: directions modulo pi
        return abs((seen - theta - turn + math.pi / 2) % math.pi - math.pi / 2)

    return min((math.radians(angle), -math.radians(angle)), key=off)


def _turned(lower: np.ndarray, theta: float) -> np.ndarray:
    """Samples per metre along the direction ``theta`` in space (``lower``: the sample Gram's Cholesky factor)."""
    return np.linalg.solve(lower, np.array([math.cos(theta), math.sin(theta)]))


def _side_balance_db(along: np.ndarray, lobes: np.ndarray) -> float:
    """The side-lobe energy of ``along`` (|h|^2 on a line centred on the peak) before the peak over after it, dB."""
    c = along.size // 2
    before, after = float(np.sum(along[:c][lobes[:c]])), float(np.sum(along[c + 1 :][lobes[c + 1 :]]))
    return 10.0 * math.log10(before / after) if before > 0 and after > 0 else math.inf


def _fall_against_a_ridge(
    grid: np.ndarray,
    profile: np.ndarray,
    theta: float,
    along: np.ndarray,
    across: np.ndarray,
    offsets: np.ndarray,
    lobes: np.ndarray,
) -> float:
    """How far the line energy ``profile`` (at the angles ``grid``) falls off its maximum at ``theta``, against
    how far a straight ridge's would: the lesser of the two sides' ratios (sum of measured falls over sum of
    predicted falls, the scan's angles on that side).

    A response separable along the ridge and across it, h(x, y) = a(x) b(y) / h(0), puts the line turned by d
    from the ridge at the offset x tan d across it at x along it: its energy is sum a(x)^2 |b(x tan d)|^2 /
    |h(0)|^2 over the side lobes. ``along`` and ``across`` are |h|^2 on the two lines through the peak at
    ``theta`` (samples at ``offsets``, metres; ``lobes`` the side-lobe samples of ``along``), so the prediction
    is the image's own. A support whose side lobes are spread over angles (the unweighted polar sector of a
    backprojected spotlight: radial edges, arcs) falls far less, and its maximum is no ridge's."""
    total = float(np.sum(along[lobes]))
    across = across / across[np.argmin(np.abs(offsets))]
    ratios = []
    for side in (grid < theta, grid > theta):
        turns = grid[side] - theta
        predicted = [np.sum(along[lobes] * np.interp(offsets[lobes] * math.tan(t), offsets, across)) for t in turns]
        predicted_fall = float(np.sum(1.0 - np.array(predicted) / total))
        measured_fall = float(np.sum(1.0 - profile[side] / total))
        ratios.append(measured_fall / predicted_fall if predicted_fall > 0 else math.inf)
    return min(ratios)


def _single_peak(profile: np.ndarray, best: int) -> bool:
    """Whether ``profile`` falls steadily from its maximum at ``best`` on both sides down to half of it (or to the
    span's ends): one maximum, not the highest of the many that noise along the lines makes."""
    half = 0.5 * profile[best]
    for side in (profile[best:], profile[best::-1]):
        top = side[: int(np.argmax(side < half)) or side.size]
        if np.any(np.diff(top) > 0):
            return False
    return True


def _sample_gram(axes: Sequence[_Axis], metric: np.ndarray | None) -> np.ndarray | None:
    """Physical Gram matrix of one sample step per axis (``metric`` rows: displacement per axis unit), or None
    without a metric or outside 2D."""
    if metric is None or len(axes) != 2:
        return None
    steps = np.array([ax.step for ax in axes])[:, None] * np.asarray(metric, dtype=float)
    return steps @ steps.T


def _perpendicular_second(
    first: np.ndarray, second: np.ndarray, nulls: np.ndarray, gram: np.ndarray, angle: float = math.nan
) -> np.ndarray:
    """``second`` (edge normal, null-normalised frequency) where its ridge is within PERPENDICULAR_EDGE_DEG of
    making ``angle`` degrees in space (NaN: 90, perpendicular) with ``first``'s, else the normal whose ridge
    does (of the two, the one nearer ``second``'s). A ridge is parallel to its edge normal (:func:`_ridges`):
    normal n is the ridge n * nulls in samples."""
    r1, r2 = first * nulls, second * nulls
    perp = np.array([-(gram @ r1)[1], (gram @ r1)[0]])  # r1' G perp = 0: perpendicular in space
    if math.isfinite(angle) and abs(angle - 90.0) > 1e-9:
        # in space, r1 and perp are orthogonal: the ridges at +-angle from r1 are cos r1/|r1| +- sin perp/|perp|
        n1, n_p = math.sqrt(float(r1 @ gram @ r1)), math.sqrt(float(perp @ gram @ perp))
        c, s = math.cos(math.radians(angle)), math.sin(math.radians(angle))
        options = [c * r1 / n1 + sign * s * perp / n_p for sign in (1.0, -1.0)]
        n2 = math.sqrt(float(r2 @ gram @ r2))
        perp = max(options, key=lambda o: abs(float(o @ gram @ r2)) / (math.sqrt(float(o @ gram @ o)) * n2))
    cos = abs(float(perp @ gram @ r2)) / math.sqrt(float(perp @ gram @ perp) * float(r2 @ gram @ r2))
    if cos >= math.cos(math.radians(PERPENDICULAR_EDGE_DEG)):
        return second
    n = perp / nulls
    return n / np.linalg.norm(n)


def _support_spectrum(
    chip: np.ndarray, centers: Sequence[float], nulls: np.ndarray, window_nulls: float
) -> tuple[np.ndarray, list[np.ndarray]]:
    """(|S|, frequencies per axis in cycles/sample) of the Hann-windowed ``chip`` (+-``window_nulls`` nulls),
    zero-padded 2x (1x in 3D) and rolled so each axis' band centre ``centers`` sits mid-array."""
    ndim = chip.ndim
    w = np.ones(())
    box = []  # the window's nonzero samples per axis: only they are transformed (sfft.fftn_of_box)
    for a, n in enumerate(chip.shape):
        x = np.arange(n) - (n - 1) / 2
        hw = min(window_nulls * nulls[a], (n + 1) / 2)
        inside = np.flatnonzero(np.abs(x) < hw)
        lo, hi = (int(inside[0]), int(inside[-1]) + 1) if inside.size else (0, 0)
        box.append(slice(lo, hi))
        w = np.multiply.outer(w, np.cos(np.pi * x[lo:hi] / (2 * hw)) ** 2)
    nfft = [(2 if ndim <= 2 else 1) * n for n in chip.shape]
    spec = sfft.fftn_of_box(chip[tuple(box)] * w, [s.start for s in box], nfft, workers=-1)
    shift = [n // 2 - int(round(c * n)) for c, n in zip(centers, nfft)]
    mag = rolled_abs(spec, shift)
    freqs = [(np.arange(n) - n // 2) / n + (round(c * n) / n) for c, n in zip(centers, nfft)]
    return mag, freqs


def rolled_abs(spec: np.ndarray, shift: Sequence[int]) -> np.ndarray:
    """``np.roll(np.abs(spec), shift, axis=all)``, each magnitude written once where the roll puts it (no rolled
    copy of the whole magnitude array: on paper 004's chips the roll was a fifth of the windowed spectrum's time
    beside its transform); the same values, bit for bit."""
    mag = np.empty(spec.shape, dtype=spec.real.dtype)
    pieces = []
    for n, k in zip(spec.shape, shift):
        k %= n
        # source -> destination slices of this axis: [0, n - k) -> [k, n) and [n - k, n) -> [0, k)
        pieces.append([(slice(0, n - k), slice(k, n)), (slice(n - k, n), slice(0, k))])
    for combo in itertools.product(*pieces):
        src = tuple(c[0] for c in combo)
        dst = tuple(c[1] for c in combo)
        if all(d.stop > d.start for d in dst):
            np.abs(spec[src], out=mag[dst])
    return mag


def _strong_gradients(
    mag: np.ndarray, spacing: Sequence[float], exact: bool
) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """(gradients (m, ndim), their norms (m,), their positions (m, ndim), null units) of ``mag`` at sample
    ``spacing``, those over 5 % of the largest; the compiled 3D path gives no positions (None)."""
    if mag.ndim == 3 and not exact:  # compiled: the strong gradients only, no full gradient arrays
        g, norm = kernels_aot.strong_gradients(mag, np.array(spacing), 0.05)
        return g, norm, None
    grads = np.gradient(mag, *spacing)
    g = np.stack([gi.ravel() for gi in grads], axis=1)
    norm = np.linalg.norm(g, axis=1)
    keep = np.flatnonzero(norm > 0.05 * norm.max())
    where = np.stack(np.unravel_index(keep, mag.shape), axis=1) * np.asarray(spacing)
    return g[keep], norm[keep], where


def _orientation_peaks(u: np.ndarray, norm: np.ndarray, ndim: int, exact: bool) -> tuple[np.ndarray, list, np.ndarray]:
    """(candidate orientations, the indices of the peaks of the orientation density of unit vectors ``u`` weighted
    by ``norm``, strongest first, the density at every candidate)."""
    cand, sigma = _orientation_grid(ndim)
    sub = slice(None, None, max(1, len(u) // 4000))  # the density only locates the peaks
    if ndim == 3 and not exact:  # compiled: one launch over every candidate (each one's sum is the same)
        dens = _orientation_density(cand, u[sub], norm[sub], sigma)
    else:
        dens = np.concatenate(
            [
                _orientation_density(c, u[sub], norm[sub], sigma, exact)
                for c in np.array_split(cand, max(1, len(cand) // 500))
            ]
        )
    peak = dens >= dens[_padded_neighbours(ndim)].max(axis=1)
    return cand, [i for i in np.argsort(dens)[::-1] if peak[i] and dens[i] > 0], dens


# An edge whose normals spread more than this either side, turning steadily along it (a curved one), is refined
# over its whole spread; "steadily": the normals' angle and their position along the edge correlate beyond
# ARC_CORRELATION (a narrowband aperture's arcs: 0.73; straight edges, crowded chips' fringes: |r| < 0.11).
CURVED_EDGE_DEG = 4.0
ARC_CORRELATION = 0.5


@dataclasses.dataclass(frozen=True)
class _Arcs:
    """What :func:`_edge_normals` needs to recognise a curved edge: the density plateaus (middle and half-width,
    deg, per peak), the strong gradients' positions (null units; None when unknown) and their norms."""

    plateaus: dict[int, tuple[float, float]]
    positions: np.ndarray | None
    norm: np.ndarray

    def curved(self, peak: int, u: np.ndarray) -> tuple[np.ndarray, float] | None:
        """(starting normal, cone half-angle in deg) for the whole plateau of ``peak`` if it is a curved edge."""
        middle, half = self.plateaus[peak]
        if half <= CURVED_EDGE_DEG or self.positions is None:
            return None
        a = math.radians(middle)
        normal, tangent = np.array([math.cos(a), math.sin(a)]), np.array([-math.sin(a), math.cos(a)])
        c = u @ normal
        sel = np.abs(c) > math.cos(math.radians(half + CURVED_EDGE_DEG))
        if np.count_nonzero(sel) < 8:
            return None
        turn = np.sign(c[sel]) * (u[sel] @ tangent)  # sine of each normal's angle from the middle
        along = self.positions[sel] @ tangent
        w = self.norm[sel]
        cov = np.cov(turn, along, aweights=w)
        if not cov[0, 0] > 0 or not cov[1, 1] > 0:
            return None
        if abs(cov[0, 1]) / math.sqrt(cov[0, 0] * cov[1, 1]) < ARC_CORRELATION:
            return None
        return normal, half + CURVED_EDGE_DEG


def _plateaus(dens: np.ndarray, peaks: Sequence[int], level: float = 0.5) -> dict[int, tuple[float, float]]:
    """Per 2D density peak (candidates every 180 / n deg), the middle and half-width (deg) of the run of
    candidates around it whose density stays above ``level`` of the peak's (at most 45 deg either side)."""
    n = len(dens)
    step = 180.0 / n
    reach = int(45.0 / step)
    out = {}
    for i in peaks:
        floor = level * dens[i]
        lo = next((k for k in range(1, reach + 1) if dens[(i - k) % n] < floor), reach + 1) - 1
        hi = next((k for k in range(1, reach + 1) if dens[(i + k) % n] < floor), reach + 1) - 1
        out[i] = ((i + (hi - lo) / 2) * step, (hi + lo) / 2 * step)
    return out


def _edge_normals(
    cand: np.ndarray,
    peaks: Sequence[int],
    u: np.ndarray,
    g: np.ndarray,
    ndim: int,
    arcs: _Arcs | None = None,
    exact: bool = False,
) -> tuple[list[np.ndarray], list[bool]]:
    """Up to ``ndim`` edge normals (and whether each is a curved edge's): each density peak (``cand[peaks]``) more
    than 20 deg from those kept, refined to the sign-aligned mean of the raw gradients ``g`` (unit vectors ``u``)
    within 8 deg of it.

    A curved edge (the range edges of a narrowband, wide-angle aperture's support are arcs) spreads its normals
    over the aperture's angles and the density over a plateau whose ends are its highest points (the normals
    crowd where the arc bends least in null-normalised frequency): its normal is the mean over the whole
    plateau (``arcs``: the plateaus and where their gradients lie), the side-lobe fan's centre, not one end.
    In 3D, unless ``exact``, each mean is one compiled pass (:func:`sarproc.quality.kernels.cone_sum`, the same
    sum)."""
    found: list[np.ndarray] = []
    curved: list[bool] = []
    compiled = ndim == 3 and not exact
    if compiled:
        u, g = kernels_aot.f8(u), kernels_aot.f8(g)
    for i in peaks:
        if all(abs(cand[i] @ f) < math.cos(math.radians(20.0)) for f in found):
            f, cone = cand[i], 8.0
            arc = arcs.curved(i, u) if arcs is not None else None
            if arc is not None:
                f, cone = arc
            curved.append(arc is not None)
            for _ in range(4):  # cluster mean of the raw gradients, signs aligned
                if compiled:  # one pass, the same sum (kernels.cone_sum)
                    total = kernels_aot.kernels().cone_sum(u, g, kernels_aot.f8(f), math.cos(math.radians(cone)))
                    if total[3] == 0:
                        break
                    f = total[:3]
                else:
                    c = u @ f
                    sel = np.abs(c) > math.cos(math.radians(cone))
                    if not sel.any():
                        break
                    f = (np.sign(c[sel])[:, None] * g[sel]).sum(axis=0)
                f = f / np.linalg.norm(f)
            found.append(f)
        if len(found) == ndim:
            break
    return found, curved


def _ridges(directions: np.ndarray, nulls: np.ndarray) -> np.ndarray:
    """V of :func:`principal_directions` from the edge normals ``directions`` (rows, null-normalised frequency):
    each given to one image axis (the assignment with the largest product of their components along their axes),
    in samples, V[a, a] = 1."""
    best = _assignment(directions)
    V = np.array([directions[best[a]] * nulls for a in range(len(directions))])  # nulls -> samples
    return V / np.diag(V)[:, None]


def _assignment(directions: np.ndarray) -> tuple[int, ...]:
    """Which edge normal (row of ``directions``) belongs to each image axis: the assignment with the largest
    product of their components along their axes."""
    ndim = len(directions)
    return max(
        itertools.permutations(range(ndim)),
        key=lambda perm: np.prod([abs(directions[perm[a], a]) for a in range(ndim)]),
    )


def _ideal_response(
    points: npt.ArrayLike,
    position: npt.ArrayLike,
    V: np.ndarray,
    nulls: npt.ArrayLike,
    f_c: npt.ArrayLike,
    hamming: bool,
    exact: bool = False,
    chirp: npt.ArrayLike | None = None,
    shapes: ResponseShapes | None = None,
) -> np.ndarray:
    """Ideal response at ``points`` ((ndim, N) image indices) of a target at ``position``, peak 1.

    The support is the parallelogram (parallelepiped) whose ridges are the rows of V (see
    :func:`principal_directions`) with null spacing ``nulls[a]`` along ridge a (measured along axis
    a); the spectrum is flat (or Hamming) over it and centred on ``f_c`` (cycles/sample). ``chirp``
    (cycles/sample^2 per axis; default none): the response is also multiplied by exp(j pi sum_a chirp_a
    d_a^2), d = x - position (a processor's matched filter longer than the aperture, as array3d's). ``shapes``
    (:class:`ResponseShapes`; default none): known shapes along the ridges, periodic sincs and tabulated shapes.
    """
    k = _zero_or(chirp, np.shape(points)[0])
    per, table, rate = _shape_args(shapes, np.shape(points)[0])
    if not exact and len(V) == 3:
        kernels = kernels_aot.kernels()
        ridge = np.linalg.inv(np.asarray(V, dtype=float).T) / np.asarray(nulls, dtype=float)[:, None]
        kernel = kernels.ideal_response if np.shape(points)[1] > 20000 else kernels.ideal_response_serial
        return kernel(
            kernels_aot.f8(points),
            kernels_aot.f8(position),
            kernels_aot.f8(ridge),
            kernels_aot.f8(f_c),
            kernels_aot.f8(k),
            *map(kernels_aot.f8, (per, table, rate)),
            bool(hamming),
        )
    x = points - np.asarray(position, dtype=float)[:, None]
    c = np.linalg.solve(V.T, x) / np.asarray(nulls, dtype=float)[:, None]  # ridge coordinates, nulls
    amp = np.prod([_axis_shape_np(c[a], per[a], table[a], rate[a], hamming) for a in range(len(c))], axis=0)
    phase = np.asarray(f_c) @ x
    if np.any(k != 0):
        phase = phase + 0.5 * (k @ x**2)
    return amp * np.exp(2j * np.pi * phase)


def _periodic_sinc(q: np.ndarray, period: float) -> np.ndarray:
    """np.sinc(q), or with period > 0 (nulls) sin(pi q) / (P sin(pi q / P)) (its limit at the grating lobes)."""
    if not period > 0:
        return np.sinc(q)
    den = period * np.sin(np.pi * q / period)
    near = np.abs(den) < 1e-12
    safe = np.where(near, 1.0, den)
    return np.where(near, np.cos(np.pi * q) / np.cos(np.pi * q / period), np.sin(np.pi * q) / safe)


def _axis_shape_np(q: np.ndarray, period: float, row: np.ndarray, rate: float, hamming: bool) -> np.ndarray:
    """The shape along one ridge at q nulls: the tabulated ``row`` (``rate`` > 0, centred, linearly interpolated as
    the compiled kernels do) inside the table, else the (periodic) sinc or its Hamming sum."""
    base = _shape_np(q, period, hamming)
    if not rate > 0:
        return base
    value = _tabled_np(q, row, rate)
    return np.where(~np.isnan(value), value, base)


@dataclasses.dataclass(frozen=True)
class ResponseShapes:
    """Known shapes of the responses along each axis (ridge), beyond the sinc: ``period`` (ndim,) the periodic
    sinc's period in nulls (0: none); ``table`` (ndim, n) centred tabulated shapes, ``rate`` (ndim,) their points
    per null (0: none)."""

    period: np.ndarray
    table: np.ndarray
    rate: np.ndarray


def _shape_args(shapes: ResponseShapes | None, ndim: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(period, table, rate) for the compiled kernels (zeros: sincs)."""
    if shapes is None:
        return np.zeros(ndim), np.zeros((ndim, 2)), np.zeros(ndim)
    return shapes.period, shapes.table, shapes.rate


def _shape_np(q: np.ndarray, period: float, hamming: bool) -> np.ndarray:
    if hamming:
        return 0.54 * _periodic_sinc(q, period) + 0.23 * (_periodic_sinc(q - 1, period) + _periodic_sinc(q + 1, period))
    return _periodic_sinc(q, period)


# ----------------------------------------------------------------------------------------------
# Public entry points

# evaluate's matrices are small (chips of a few thousand to a few hundred thousand samples contracted with
# 9-row kernels, least squares of tens of columns): threaded BLAS only adds its start-up and, on a loaded
# machine, threads spinning for each other (the 002 small image: 5.5 s of CPU with two threads, 1.8 s with
# one). Threaded BLAS also rounds differently, which the residual fits carry into the figures' last digits:
# one thread keeps a Dask sweep's table equal to the serial one (:mod:`sarproc.quality.blas`).


@single_blas
def evaluate_image(
    data: np.ndarray,
    dims: Sequence[str],
    coords: Any,
    theoretical_irw: npt.ArrayLike,
    truth: Any,
    names: Sequence[str] | None = None,
    params: EvaluateParams | None = None,
    metric: Any = None,
    progress: Callable[[Iterable[Any]], Iterable[Any]] | None = None,
    target_irw: npt.ArrayLike | None = None,
    target_null: npt.ArrayLike | None = None,
    target_sidelobes: npt.ArrayLike | None = None,
    other_truth: np.ndarray | Sequence[Sequence[float]] | None = None,
    target_chirp: npt.ArrayLike | None = None,
    response_period: npt.ArrayLike | None = None,
    response_table: Sequence[tuple[np.ndarray, float] | None] | None = None,
    measure: npt.ArrayLike | None = None,
    ridge_angles: npt.ArrayLike | None = None,
) -> QualityReport:
    """Measure every target of a 2D (azimuth, range) or 3D (elevation, azimuth, range) image.

    data: complex image, shape ``tuple(len(coords[d]) for d in dims)``; dims: axis names;
    coords: {dim: 1-D uniformly spaced coordinates} (or a sequence in dims order), axis units;
    theoretical_irw: expected IRW per axis (dims order, axis units; for a skewed or rotated
    response, the -3 dB extent along that axis of the ridge that belongs to it); truth:
    (n_targets, ndim) true positions (axis units, dims order); names: n_targets labels;
    metric: optional (ndim, k) matrix, row a the physical displacement per unit of axis a (e.g.
    the slant-plane basis of a skewed frame): cut widths are then lengths along the cut;
    progress: optional callable wrapping an iterable (one bar over the targets' passes);
    target_irw: optional (n_targets, ndim) per-target theoretical IRW (same convention as
    theoretical_irw; NaN: use the image's), for images whose resolution varies with position: a
    target's cuts (IRW ratio, position in cells, ISLR/PSLR window in its own nulls) then use it and
    say so (``theory``). Chips are sized for the widest theory; supports and neighbour models keep
    the image's; the residual's response models start from each target's own null spacing where it fits
    better. target_null: optional (n_targets, ndim) null spacings 1/B of each target's own support
    (NaN: its IRW / irw_factor), so a weighted target's ISLR window is +-islr_nulls of its bandwidth;
    target_sidelobes: optional (n_targets, ndim, 2) its theoretical PSLR and ISLR, dB (NaN: not
    recorded). other_truth: (n, ndim) positions of targets not measured (a subset was asked for):
    their neighbourhoods are kept out of the false-target search like the measured ones'. target_chirp:
    optional (n_targets, ndim) chirp rate k of each target's response per axis, axis units^-2: the response
    is its ideal one times exp(j pi sum_a k_a (x_a - x0_a)^2) about its own peak (array3d's azimuth matched
    filter, longer than the aperture, leaves k = 2 / (lambda r)); the neighbour models carry it (0 or NaN:
    none). response_period: optional (ndim,) period of the responses along each axis, axis units (0 or NaN:
    none): their shape there is the periodic sinc of that period, the array factor of uniform receivers (array3d's
    elevation, period lambda / d); the neighbour models carry it. response_table: optional, per axis None or
    (values, step): the responses' shape along that axis tabulated (real, centred on the peak, value 1 there) at
    ``step`` axis units (array3d's range response, the autocorrelation of the chirp under its matched filter); the
    neighbour models take it inside the table, their sinc beyond. measure: optional (n_targets,) booleans,
    the targets to report (a subset was asked for): the others are still found and subtracted from their
    neighbours' chips (so a measured target's figures are those of the run over every target), then kept out of
    the false-target search like ``other_truth``. ridge_angles: optional (n_targets,) angle in space between each
    target's two theoretical ridges, degrees (NaN: 90, the slant plane's; :func:`target_ridge_angles`): with a
    ``metric``, a second support edge whose ridge is further than PERPENDICULAR_EDGE_DEG from it is replaced by
    it. Raises InputError.

    Steps: :func:`_locate_targets` (pass 1, :func:`_find_peak` per target: peak and support on the image's chip;
    pass 2, :func:`_subtract_neighbours`: the groups' fitted responses off each chip, peak and support again),
    :func:`_measure` per measured target (the cuts), then :func:`_false_targets` away from
    :func:`_guarded_positions`.
    """
    params = params or EvaluateParams()
    data = np.asarray(data)
    axes, metric, truth, names = _checked_inputs(data, dims, coords, theoretical_irw, truth, names, metric, params)
    own_axes = _target_axes(axes, target_irw, truth.shape[0], params.irw_factor, target_null, target_sidelobes)
    measured = _measured_flags(measure, len(names))
    half = _chip_half_widths(axes, own_axes, params)
    nulls = [ax.null for ax in axes]
    if len(axes) == 3 and not params.exact:  # a cube's kernels: compiled ahead of time where all of them pay
        kernels_aot.reserve(len(names), math.prod(2 * h + 1 for h in half))
    # One bar over the whole evaluation: each target's pass 1, pass 2 (when neighbours are removed) and
    # measurement, then the false-target search.
    done = steps(progress, len(names) * (2 if params.remove_neighbours else 1) + int(measured.sum()) + 1)
    mag = np.abs(data)
    gram = _sample_gram(axes, metric)
    angles = np.full(len(names), np.nan) if ridge_angles is None else np.asarray(ridge_angles, float).ravel()
    if angles.shape != (len(names),):
        raise InputError(f"ridge_angles has {angles.size} values for {len(names)} targets")
    coinciding = coinciding_indices(truth, axes)  # one response each: neither refitted nor residual-modelled
    peaks = _locate_targets(
        data,
        mag,
        axes,
        names,
        truth,
        half,
        nulls,
        params,
        done,
        target_chirp,
        response_period,
        response_table,
        gram,
        frozenset(k for g in coinciding for k in g),
        angles,
    )
    # only the measured targets from here on; the others (and other_truth) guard their neighbourhoods
    order = [int(i) for i in np.flatnonzero(measured)]
    peaks, own_axes = [peaks[i] for i in order], [own_axes[i] for i in order]
    reports = list(
        wrapped(
            done,
            ordered_map(
                lambda a: _measure(a[0], a[1], truth[a[2]], names[a[2]], params, metric),
                zip(peaks, own_axes, order),
                params.exact,
            ),
        )
    )
    guarded = _guarded_positions(truth, measured, other_truth, len(axes))
    note = None
    if params.residual and data.ndim == 3:
        note = RESIDUAL_3D_NOTE
    elif params.residual:
        note = coinciding_note([[str(names[k]) for k in g] for g in coinciding])
    false, guard, floor, listed, crowded = _false_targets(
        data,
        mag,
        axes,
        guarded,
        peaks,
        reports,
        half,
        nulls,
        dataclasses.replace(params, residual=False) if note else params,
        own_axes,
        truth[order],
        (np.abs(angles[order] - 90.0) > CUBIC_SHEAR_DEG).tolist(),  # NaN (the slant plane): False
    )
    note = note or crowded
    done()
    return QualityReport(
        dims=tuple(ax.name for ax in axes),
        targets=tuple(reports),
        false_target=false,
        params=params,
        false_target_guard=guard,
        residual=floor,
        residual_note=note,
        false_targets=listed,
    )


def coinciding_targets(truth: np.ndarray, axes: Sequence[_Axis], names: Sequence[str]) -> list[list[str]]:
    """Groups of targets (names, two or more) whose true positions lie within :data:`COINCIDE_NULLS` of the
    image's null spacing of each other on every axis (``truth``: (n, ndim) in axis units; single linkage): one
    response in this image, their sum, however the scene places them apart in other coordinates (paper 004's
    receiver images before elevation compression hold targets 3, 6 and 7, 2 deg apart in elevation, on one
    pixel)."""
    return [[str(names[k]) for k in g] for g in coinciding_indices(truth, axes)]


def coinciding_indices(truth: np.ndarray, axes: Sequence[_Axis]) -> list[list[int]]:
    """:func:`coinciding_targets` as target indices."""
    index = np.array([[ax.to_index(x) for ax, x in zip(axes, row)] for row in np.asarray(truth, dtype=float)])
    nulls = np.array([ax.null for ax in axes])
    groups: list[list[int]] = []
    for j in range(len(index)):
        near = [g for g in groups if any(np.all(np.abs(index[k] - index[j]) <= COINCIDE_NULLS * nulls) for k in g)]
        groups = [g for g in groups if g not in near] + [sorted([j] + [k for g in near for k in g])]
    return [g for g in groups if len(g) > 1]


def coinciding_note(groups: Sequence[Sequence[str]]) -> str | None:
    """The report's residual note for :func:`coinciding_targets`' groups (None: none coincide)."""
    if not groups:
        return None
    said = "; ".join(", ".join(g[:-1]) + " and " + g[-1] for g in groups)
    return (
        f"the residual false-target level is not taken: targets {said} coincide in this image (true positions "
        f"within {COINCIDE_NULLS:g} of a null on every axis), one response that a model per target cannot be "
        "fitted to; the false target is the guard-window figure"
    )


def _measured_flags(measure: npt.ArrayLike | None, n_targets: int) -> np.ndarray:
    """(n_targets,) booleans: the targets to report (evaluate_image's ``measure``; None: all of them)."""
    measured = np.ones(n_targets, dtype=bool) if measure is None else np.asarray(measure, dtype=bool)
    if measured.shape != (n_targets,) or not measured.any():
        raise InputError(f"measure must flag at least one of the {n_targets} targets, got shape {measured.shape}")
    return measured


def _chip_half_widths(axes: Sequence[_Axis], own_axes: Sequence[Sequence[_Axis]], params: EvaluateParams) -> list[int]:
    """Half-widths of every chip per axis (samples): wide enough for every target's own ISLR window."""
    return [
        max(x[a].nulls_to_samples(params.islr_nulls + params.margin_nulls) for x in [axes] + list(own_axes))
        for a in range(len(axes))
    ]


def _locate_targets(
    data: np.ndarray,
    mag: np.ndarray,
    axes: Sequence[_Axis],
    names: Sequence[str],
    truth: np.ndarray,
    half: Sequence[int],
    nulls: Sequence[float],
    params: EvaluateParams,
    done: Callable[[], None],
    target_chirp: npt.ArrayLike | None,
    response_period: npt.ArrayLike | None,
    response_table: Sequence[tuple[np.ndarray, float] | None] | None,
    gram: np.ndarray | None = None,
    coinciding: frozenset[int] = frozenset(),
    ridge_angles: np.ndarray | None = None,
) -> list[_Peak]:
    """Every target's :class:`_Peak`: pass 1 (:func:`_find_peak` on the image ``data``, magnitude ``mag``), then
    with ``params.remove_neighbours`` pass 2 (:func:`_subtract_neighbours`; the responses' known chirps and shapes
    are evaluate_image's ``target_chirp``, ``response_period`` and ``response_table``). ``done``: the progress
    steps, one per target and pass; ``gram``: :func:`_sample_gram`; ``coinciding``: the targets that coincide with
    another (:func:`coinciding_indices`); ``ridge_angles``: evaluate_image's."""
    angles = np.full(len(names), np.nan) if ridge_angles is None else ridge_angles
    peaks = list(
        wrapped(
            done,
            ordered_map(
                lambda a: _find_peak(data, mag, axes, a[0], a[1], half, nulls, params, gram, float(a[2])),
                zip(names, truth, angles),
                params.exact,
            ),
        )
    )
    if params.remove_neighbours:
        chirps = _chirps_in_samples(target_chirp, axes, len(names))
        shapes = _response_shapes(response_period, response_table, axes)
        peaks = _subtract_neighbours(
            data, peaks, names, nulls, half, params, done, chirps, shapes, gram, coinciding, angles
        )
    return peaks


def _guarded_positions(
    truth: np.ndarray, measured: np.ndarray, other_truth: np.ndarray | Sequence[Sequence[float]] | None, ndim: int
) -> np.ndarray:
    """(n, ndim) positions kept out of the false-target search: the measured targets first, then the unmeasured
    ones and ``other_truth`` (targets not evaluated)."""
    others = [truth[~measured]] + ([] if other_truth is None else [np.asarray(other_truth, dtype=float)])
    return np.concatenate([truth[measured]] + [o.reshape(-1, ndim) for o in others])


def _chirps_in_samples(target_chirp: npt.ArrayLike | None, axes: Sequence[_Axis], n_targets: int) -> np.ndarray | None:
    """target_chirp (axis units^-2) in cycles/sample^2, NaN as 0; None where absent or all zero."""
    if target_chirp is None:
        return None
    k = np.asarray(target_chirp, dtype=float)
    if k.shape != (n_targets, len(axes)):
        raise InputError(f"target_chirp has shape {k.shape}; expected ({n_targets}, {len(axes)})")
    k = np.where(np.isnan(k), 0.0, k)
    if not np.all(np.isfinite(k)):
        raise InputError("target_chirp values must be finite (or NaN: none)")
    k = k * np.array([ax.step**2 for ax in axes])[None, :]
    return k if np.any(k != 0) else None


def _response_shapes(
    response_period: npt.ArrayLike | None,
    response_table: Sequence[tuple[np.ndarray, float] | None] | None,
    axes: Sequence[_Axis],
) -> ResponseShapes | None:
    """evaluate_image's response_period and response_table in nulls (ResponseShapes); None where both are absent."""
    period = _period_in_nulls(response_period, axes)
    if response_table is None or all(t is None for t in response_table):
        return None if period is None else ResponseShapes(period, np.zeros((len(axes), 2)), np.zeros(len(axes)))
    if len(response_table) != len(axes):
        raise InputError(f"response_table has {len(response_table)} entries; expected one per axis ({len(axes)})")
    rows = [np.zeros(1) if t is None else np.asarray(t[0], dtype=float).ravel() for t in response_table]
    n = max(len(r) for r in rows)
    table = np.zeros((len(axes), n + (n + 1) % 2))
    rate = np.zeros(len(axes))
    for a, (t, row) in enumerate(zip(response_table, rows)):
        if t is None:
            continue
        if len(row) < 3 or len(row) % 2 == 0 or not (np.all(np.isfinite(row)) and np.isfinite(t[1]) and t[1] > 0):
            raise InputError(f"response_table[{a}]: expected an odd number (>= 3) of finite values and a positive step")
        pad = (table.shape[1] - len(row)) // 2
        table[a, pad : pad + len(row)] = row
        table[a, :pad] = np.nan  # beyond this axis' table: the sinc (the kernels' NaN)
        table[a, pad + len(row) :] = np.nan
        rate[a] = axes[a].null * abs(axes[a].step) / float(t[1])
    return ResponseShapes(np.zeros(len(axes)) if period is None else period, table, rate)


def _period_in_nulls(response_period: npt.ArrayLike | None, axes: Sequence[_Axis]) -> np.ndarray | None:
    """response_period (axis units) in each axis' nulls, NaN as 0; None where absent or all zero."""
    if response_period is None:
        return None
    p = np.asarray(response_period, dtype=float)
    if p.shape != (len(axes),):
        raise InputError(f"response_period has shape {p.shape}; expected ({len(axes)},)")
    p = np.where(np.isnan(p), 0.0, p)
    if not np.all(np.isfinite(p) & (p >= 0)):
        raise InputError("response_period values must be positive and finite, 0 or NaN (none)")
    p = p / np.array([abs(ax.step) * ax.null for ax in axes])
    return p if np.any(p != 0) else None


def _checked_inputs(
    data: np.ndarray,
    dims: Sequence[str],
    coords: Any,
    theoretical_irw: npt.ArrayLike,
    truth: Any,
    names: Sequence[str] | None,
    metric: Any,
    params: EvaluateParams,
) -> tuple:
    """(axes, metric, truth, names) of evaluate_image's arguments, checked; raises InputError."""
    if data.ndim not in (1, 2, 3):
        raise InputError(f"image must have 1 to 3 axes, got shape {data.shape}")
    if not np.all(np.isfinite(data)):
        raise InputError(f"image contains {int(np.count_nonzero(~np.isfinite(data)))} NaN or Inf value(s)")
    dims = tuple(dims)
    axes = _make_axes(data.shape, dims, coords, theoretical_irw, params.irw_factor)
    if metric is not None:
        metric = np.atleast_2d(np.asarray(metric, dtype=float))
        if (
            metric.shape[0] != len(dims)
            or not np.all(np.isfinite(metric))
            or abs(np.linalg.det(metric @ metric.T)) < 1e-12
        ):
            raise InputError(f"metric must hold one finite, independent row per axis {dims}, got shape {metric.shape}")
    truth = np.atleast_2d(np.asarray(truth, dtype=float))
    if truth.shape[1] != len(dims):
        raise InputError(f"truth has {truth.shape[1]} coordinates per target, the image has {len(dims)} axes")
    if truth.shape[0] == 0:
        raise InputError("no targets to evaluate")
    names = [f"T{i}" for i in range(truth.shape[0])] if names is None else [str(n) for n in names]
    if len(names) != truth.shape[0]:
        raise InputError(f"{len(names)} names for {truth.shape[0]} targets")
    if not np.all(np.isfinite(truth)):
        raise InputError("target positions contain NaN or Inf")
    return axes, metric, truth, names


@dataclasses.dataclass(frozen=True)
class _Peak:
    """A target's response as found in the image: its strongest pixel, the chip around it, the chip it is
    measured on (``raw`` minus the neighbours' fitted responses), and the refined peak and support there."""

    index: tuple[int, ...]  # strongest pixel in the search window
    raw: _Chip  # the image's chip
    chip: _Chip  # the chip measured: raw, or raw minus the neighbours' fitted responses
    position: np.ndarray  # refined peak, image indices
    value: complex  # interpolated peak value
    ridges: np.ndarray  # side-lobe ridge directions (rows; principal_directions' V)
    band_centre: np.ndarray  # power centroid of the band, cycles/sample
    removed: tuple[str, ...] = ()  # neighbours subtracted from the chip
    contaminating: tuple = ()  # the subtracted neighbours (_NeighbourModel) that ideal responses fitted poorly
    fanned: tuple[int, ...] = ()  # axes whose side lobes fan out (curved support edges): cut through the centre

    def fit_start(self, nulls: np.ndarray | None = None) -> FitStart:
        """The start of its response-model fit (:func:`fit_response_models`); ``nulls``: its own null spacing."""
        return FitStart(
            position=self.position, ridges=self.ridges, band_centre=self.band_centre, value=self.value, nulls=nulls
        )


def _find_peak(
    data: np.ndarray,
    mag: np.ndarray,
    axes: Sequence[_Axis],
    name: str,
    truth: np.ndarray,
    half: Sequence[int],
    nulls: Sequence[float],
    params: EvaluateParams,
    gram: np.ndarray | None = None,
    ridge_angle: float = math.nan,
) -> _Peak:
    """Pass 1: the strongest pixel within +-search_cells of the truth, the chip around it, its refined peak
    and support."""
    idx = np.array([ax.to_index(x) for ax, x in zip(axes, truth)])
    for ax, i, x in zip(axes, idx, truth):
        if not (-0.5 <= i <= ax.size - 0.5):
            lo, hi = sorted((ax.start, float(ax.to_coord(ax.size - 1))))
            raise InputError(f"target {name!r}: {ax.name} = {x:.6g} lies outside the image extent [{lo:.6g}, {hi:.6g}]")
    center = np.rint(idx).astype(int)
    win = window_slices(center, [ax.cells_to_samples(params.search_cells) for ax in axes], data.shape)
    local = mag[win]
    k = np.unravel_index(np.argmax(local), local.shape)
    peak_index = tuple(int(s.start + i) for s, i in zip(win, k))
    chip = _Chip(data, peak_index, half)
    pos, value = chip.refine_peak(peak_index, exact=params.exact)
    support = _support(chip, pos, nulls, params, gram, ridge_angle)
    return _Peak(peak_index, chip, chip, pos, value, support.ridges, support.band_centre, fanned=support.fanned)


def _subtract_neighbours(
    data: np.ndarray,
    peaks: list,
    names: Sequence[str],
    nulls: Sequence[float],
    half: Sequence[int],
    params: EvaluateParams,
    done: Callable[[], None],
    chirps: np.ndarray | None = None,
    shapes: ResponseShapes | None = None,
    gram: np.ndarray | None = None,
    coinciding: frozenset[int] = frozenset(),
    ridge_angles: np.ndarray | None = None,
) -> list:
    """Pass 2: the ideal responses of every group of targets whose chips overlap are fitted jointly to the
    image; each target's chip loses the other members' fitted responses, and its peak and support are found
    again on it. ``done``: the progress steps (one per target); ``chirps``: each target's known chirp
    and the responses' known shapes, ``coinciding`` (:func:`_neighbour_models`)."""
    models = _neighbour_models(data, peaks, nulls, half, params, chirps, shapes, coinciding)
    hamming = params.irw_factor > 1.1
    period = _period_in_samples(shapes, nulls)
    out = list(peaks)
    others = {}
    for i, peak in enumerate(peaks):
        shape = np.array(peak.raw.shape)
        centre = peak.raw.origin + (shape - 1) / 2
        reach = (shape - 1) / 2 + np.asarray(nulls)
        near = [
            j
            for j, m in models.items()
            if j != i and i in m.group and np.all(np.abs(_nearest_offset(centre, m.position, period)) <= reach)
        ]
        if near and abs(peak.value) > 0:
            others[i] = near
    fitted = _neighbours_on_chips(data.shape, [p.raw for p in peaks], models, others, hamming, params.exact)

    def found_again(i: int) -> tuple[_Chip, np.ndarray, complex, Support]:
        peak = peaks[i]
        chip = _Chip(None, peak.index, half, chip=(peak.raw.data - fitted[i], peak.raw.clipped))
        pos, value = chip.refine_peak(peak.position, exact=params.exact)
        angle = math.nan if ridge_angles is None else float(ridge_angles[i])
        return chip, pos, value, _support(chip, pos, nulls, params, gram, angle)

    again = ordered_map(found_again, [i for i in range(len(peaks)) if i in others], params.exact)
    for i, peak in wrapped(done, list(enumerate(peaks))):
        if i not in others:
            continue
        chip, pos, value, support = next(again)
        out[i] = dataclasses.replace(
            peak,
            chip=chip,
            position=pos,
            value=value,
            ridges=support.ridges,
            band_centre=support.band_centre,
            fanned=support.fanned,
            removed=tuple(names[j] for j in others[i]),
            contaminating=tuple(models[j] for j in others[i] if models[j].misfit > NEIGHBOUR_MISFIT),
        )
    return out


def _neighbours_on_chips(
    image_shape: Sequence[int], chips: Sequence[_Chip], models: dict, others: dict, hamming: bool, exact: bool
) -> dict:
    """{chip index i: the sum, in ``others[i]``'s order, of those neighbours' models on chip i's box (zero beyond
    the image edge, where a periodic model would repeat)}. Each model is evaluated once, on the box spanning
    every chip it is subtracted from (inside the image), where that is smaller than those chips together:
    crowded chips overlap, and the values at a sample do not depend on the box (the same operations)."""
    sums = {i: np.zeros(chips[i].shape, dtype=np.complex128) for i in others}
    inside = {
        i: window_slices(chips[i].origin + np.array(chips[i].shape) // 2, np.array(chips[i].shape) // 2, image_shape)
        for i in others
    }
    for j, model in models.items():
        users = [i for i in others if j in others[i]]
        if not users:
            continue
        lo = np.min([[s.start for s in inside[i]] for i in users], axis=0)
        hi = np.max([[s.stop for s in inside[i]] for i in users], axis=0)
        union = math.prod((hi - lo).tolist()) < sum(math.prod(s.stop - s.start for s in inside[i]) for i in users)
        span = model.values_on_box(lo, hi - lo, hamming, exact).reshape(tuple(hi - lo)) if union else None
        for i in users:
            box = inside[i]
            values = (
                span[tuple(slice(s.start - a, s.stop - a) for s, a in zip(box, lo.tolist()))]
                if span is not None
                else model.values_on_box(
                    np.array([s.start for s in box]), np.array([s.stop - s.start for s in box]), hamming, exact
                ).reshape(tuple(s.stop - s.start for s in box))
            )
            sums[i][tuple(slice(s.start - o, s.stop - o) for s, o in zip(box, chips[i].origin.tolist()))] += values
    return sums


SINC_PSLR_DB = -13.26  # unweighted sinc: what a cut with no recorded theory is judged against
WEIGHTED_PSLR_DB = -30.0  # a theoretical PSLR below this: a weighting window (Hamming -42.7 dB), not a taper
# A theory deeper than two steps (a Gaussian beam under Hamming: -48 to -55 dB) takes this many orders, not
# three: three left -46.0..-48.3 dB residue on the campaign's fully lit Gaussian-x-Hamming targets (scenes 1, 4
# and 15 of scripts/evaluate_campaign.py --seed 1, docs/product.md), four bring 1 and 4 under -50 dB.
DEEP_TAPER_ORDERS = 4  # also the deepest order the theory picks


def theory_residual_orders(reports: Sequence[TargetReport], requested: int) -> int:
    """The response models' spectral orders for an image whose targets' theories are ``reports``: one more
    order per (SINC_PSLR_DB - WEIGHTED_PSLR_DB) dB that the deepest theoretical PSLR lies under the
    unweighted sinc's, never under ``requested``. A smoother weighting (a window, the
    antenna pattern over the aperture a target sees) needs more of the half-null-shifted sincs to follow:
    Hamming (-42.7 dB) takes 2; anything deeper than two steps (a Gaussian beam under Hamming, -48 to -55 dB)
    :data:`DEEP_TAPER_ORDERS`, as three do not follow the bell on the cosine."""
    theory = [m.pslr_theory_db for r in reports for m in r.axes if m.pslr_theory_db is not None]
    if not theory:
        return requested
    step = SINC_PSLR_DB - WEIGHTED_PSLR_DB
    auto = 1 + math.floor(max(SINC_PSLR_DB - min(theory), 0.0) / step)
    return max(requested, DEEP_TAPER_ORDERS if auto > 2 else auto)


# The residual is not taken on 3D cubes (measured on paper 004's du2010 cube: its response models leave a
# -15.6 dB floor beside the coinciding targets, and the residual took 268 s against array3d's 6.8 s):
# the guard-window figure is the cube's false target, and the report says so.
RESIDUAL_3D_NOTE = (
    "the residual false-target level is not available on 3D cubes (the cube's response models do not yet fit "
    "its crowded targets: -15.6 dB floor on paper 004's cube, at 40x the stage's time); the false target is "
    "the guard-window figure"
)


def _false_targets(
    data: np.ndarray,
    mag: np.ndarray,
    axes: Sequence[_Axis],
    guarded: np.ndarray,
    peaks: list,
    reports: list[TargetReport],
    half: Sequence[int],
    nulls: Sequence[float],
    params: EvaluateParams,
    own_axes: Sequence[Sequence[_Axis]] | None = None,
    truth: np.ndarray | None = None,
    sheared: Sequence[bool] = (),
) -> tuple:
    """(false target, guard-window false target, residual floor, false-target list, note): the strongest
    response outside every target's +-guard_cells window, and with ``params.residual`` the strongest on the
    residual image (then the reported one) with the residual's floor and every false target over it.
    ``own_axes``: each target's axes (:func:`_target_axes`); its response model starts from their null spacing
    (its own theory's where it has one, else the image's). ``sheared``: per target, whether its ridges lie more
    than :data:`CUBIC_SHEAR_DEG` off perpendicular in space: those models take a cubic carrier
    (:func:`fit_response_models`). The note (else None) says why the residual was not taken where a group of
    crowded targets is too large to fit jointly (:data:`residual.RESIDUAL_BUDGET`)."""
    indices = [p.index for p in peaks]
    guard = _false_target(data, mag, axes, guarded, indices, reports, half, params)
    if not params.residual or data.ndim == 3:  # cubes: RESIDUAL_3D_NOTE
        return guard, guard, None, None, None
    # a weighting's taper (Hamming: the band's cosine; times a Gaussian beam) needs more spectral orders
    params = dataclasses.replace(params, residual_orders=theory_residual_orders(reports, params.residual_orders))
    starts = [
        p.fit_start(None if own_axes is None else np.array([ax.null for ax in own]))
        for p, own in zip(peaks, own_axes or [axes] * len(peaks))
    ]
    if truth is not None:  # a close pair found on one peak: the weaker one moved to its own (separated_starts)
        starts = separated_starts(starts, [[ax.to_index(x) for ax, x in zip(axes, t)] for t in truth], nulls, data)
    try:
        models = fit_response_models(
            data, starts, nulls, params, support_shape=True, sheared=sheared, budget=RESIDUAL_BUDGET
        )
    except CrowdedGroup as crowded:
        return guard, guard, None, None, crowded_note([reports[k].name for k in crowded.members], crowded)
    fanned = [i for i, p in enumerate(peaks) if p.fanned]
    own_nulls = None if own_axes is None else [np.array([ax.null for ax in own]) for own in own_axes]
    false, floor, listed = residual_false_target(
        data, models, axes, guarded, indices, reports, half, params, fanned, own_nulls or ()
    )
    return false, guard, floor, listed, None


def crowded_note(members: Sequence[str], crowded: CrowdedGroup) -> str:
    """The report's residual note where a group of crowded targets is over :data:`residual.RESIDUAL_BUDGET`."""
    shown = ", ".join(members[:6]) + (f" and {len(members) - 6} more" if len(members) > 6 else "")
    return (
        f"the residual false-target level is not taken: {len(members)} targets ({shown}) lie close enough to be "
        f"fitted jointly, a least squares of {crowded.rows} rows x {crowded.columns} columns, over the "
        f"{RESIDUAL_BUDGET:.0e} rows x columns^2 its time allows; the false target is the guard-window figure"
    )


def _target_axes(
    axes: list[_Axis],
    target_irw: npt.ArrayLike | None,
    n_targets: int,
    irw_factor: float,
    target_null: npt.ArrayLike | None = None,
    target_sidelobes: npt.ArrayLike | None = None,
) -> list[list[_Axis]]:
    """Each target's axes: the image's, with its own theoretical IRW, null spacing and side lobes where it has them."""
    if target_irw is None:
        return [axes] * n_targets
    irw = np.asarray(target_irw, dtype=float)
    if irw.shape != (n_targets, len(axes)):
        raise InputError(
            f"target_irw has shape {irw.shape}; expected ({n_targets}, {len(axes)}): one IRW per "
            f"target and axis, NaN where the image's applies"
        )
    nulls = np.full(irw.shape, np.nan) if target_null is None else np.asarray(target_null, dtype=float)
    lobes = np.full(irw.shape + (2,), np.nan) if target_sidelobes is None else np.asarray(target_sidelobes, float)
    if nulls.shape != irw.shape or lobes.shape != irw.shape + (2,):
        raise InputError(
            f"target_null / target_sidelobes have shapes {nulls.shape} / {lobes.shape}; expected "
            f"{irw.shape} / {irw.shape + (2,)}"
        )
    if np.any(~np.isnan(nulls) & ~(np.isfinite(nulls) & (nulls > 0))):
        raise InputError("target_null values must be positive and finite, or NaN (IRW / irw_factor applies)")
    if np.any(~np.isnan(irw) & ~(np.isfinite(irw) & (irw > 0))):
        raise InputError("target_irw values must be positive and finite, or NaN (the image's theory applies)")
    out = []
    for row, row_null, row_lobes in zip(irw, nulls, lobes):
        own = []
        for ax, v, own_null, (pslr, islr) in zip(axes, row, row_null, row_lobes):
            if np.isnan(v):
                own.append(ax)
                continue
            null = float(v) / (irw_factor * abs(ax.step)) if np.isnan(own_null) else float(own_null) / abs(ax.step)
            if null < CRITICAL_SAMPLING:
                raise InputError(
                    f"axis {ax.name!r}: spacing {abs(ax.step):.4g} is not finer than a target's null "
                    f"spacing {null * abs(ax.step):.4g} (its theoretical IRW {v:.4g})"
                )
            sides: dict[str, Any] = {} if np.isnan(pslr) else {"pslr_theory": float(pslr), "islr_theory": float(islr)}
            own.append(dataclasses.replace(ax, irw=float(v), null=null, theory="target", **sides))
        out.append(own)
    return out


def _support(
    chip: _Chip,
    pos: np.ndarray,
    nulls: npt.ArrayLike,
    params: EvaluateParams,
    gram: np.ndarray | None = None,
    ridge_angle: float = math.nan,
) -> Support:
    if params.principal_axes and chip.data.ndim > 1:
        support = principal_support(
            chip.data, chip.centers, nulls, exact=params.exact, gram=gram, ridge_angle=ridge_angle
        )
        if support.oblique and gram is not None:
            ridges = _ridges_in_space(
                chip, pos, support.ridges, np.asarray(nulls, float), gram, params.islr_nulls, ridge_angle
            )
            support = dataclasses.replace(support, ridges=ridges)
        return support
    return Support(np.eye(chip.data.ndim), np.asarray(chip.centers, dtype=float))


@dataclasses.dataclass(frozen=True)
class _NeighbourModel:
    """A target's response fitted jointly with the rest of its group, subtracted from the other members' chips."""

    position: np.ndarray  # image indices
    band_centre: np.ndarray  # cycles/sample
    ridges: np.ndarray  # side-lobe ridge directions (rows)
    amplitude: complex  # of the ideal response (peak 1)
    group: frozenset  # indices of the targets fitted together
    misfit: float  # the group fit's residual energy / the fitted samples' energy
    nulls: np.ndarray  # null spacing 1/B per axis, samples
    rich: ResponseModel | None = None  # the response model (fit_response_models) where it fitted better
    chirp: np.ndarray | None = None  # its known chirp, cycles/sample^2 per axis (_ideal_response); None: none
    shapes: ResponseShapes | None = None  # known shapes along the ridges (_ideal_response); None: sincs

    def values(self, points: npt.ArrayLike, hamming: bool, exact: bool = False) -> np.ndarray:
        """The fitted neighbour at ``points`` ((ndim, N) image indices)."""
        if self.rich is not None:
            return model_values(points, self.rich)
        return self.amplitude * _ideal_response(
            points, self.position, self.ridges, self.nulls, self.band_centre, hamming, exact, self.chirp, self.shapes
        )

    def values_on_box(
        self, origin: Sequence[int], shape: Sequence[int], hamming: bool, exact: bool = False
    ) -> np.ndarray:
        """:meth:`values` on the image box ``origin + index`` of ``shape``, raveled (C order); an ideal 3D
        response from per-axis tables (compiled), the others at the box's points."""
        if self.rich is None and not exact and len(shape) == 3:
            ridge = np.linalg.inv(np.asarray(self.ridges, dtype=float).T) / np.asarray(self.nulls, dtype=float)[:, None]
            box = kernels_aot.kernels().ideal_response_box(
                kernels_aot.f8(origin),
                np.ones(3),
                kernels_aot.i8(shape),
                kernels_aot.f8(self.position),
                kernels_aot.f8(ridge),
                kernels_aot.f8(self.band_centre),
                kernels_aot.f8(_zero_or(self.chirp, 3)),
                *map(kernels_aot.f8, _shape_args(self.shapes, 3)),
                bool(hamming),
            )
            # the kernel's fresh array scaled in place, amplitude first as in amplitude * box (box * amplitude rounds
            # otherwise: numpy's complex products are not symmetric)
            flat = box.ravel()
            return np.multiply(self.amplitude, flat, out=flat)
        grid = np.meshgrid(*[np.arange(n) + o for n, o in zip(shape, origin)], indexing="ij")
        return self.values(np.stack([g.ravel() for g in grid], axis=0).astype(float), hamming, exact)


def _zero_or(values: npt.ArrayLike | None, ndim: int) -> np.ndarray:
    return np.zeros(ndim) if values is None else np.asarray(values, dtype=float)


def _neighbour_models(
    data: np.ndarray,
    peaks: list,
    nulls: npt.ArrayLike,
    half: Sequence[int],
    params: EvaluateParams,
    chirps: np.ndarray | None = None,
    shapes: ResponseShapes | None = None,
    coinciding: frozenset[int] = frozenset(),
) -> dict:
    """Ideal responses fitted jointly to every group of targets whose chips overlap.

    Each member gets a complex amplitude, and its position, band centre and ridge directions (first
    estimated on its own chip, where the others' side lobes bias them) are refined by joint Gauss-Newton
    steps on the samples within 3 nulls of every member's peak (about two per null); groups that ideal
    responses fit poorly are refitted as response models (:func:`_refit_rich`). ``chirps``: (n_targets, ndim)
    each target's known chirp, cycles/sample^2 (:func:`_ideal_response`; rows of zeros: none); ``shapes``: the
    responses' known shapes (None: sincs); ``coinciding``: the targets that coincide with another
    (:func:`coinciding_indices`), whose groups are not refitted.
    Returns {target index: _NeighbourModel} for members of groups of two or more.
    """
    nulls = np.asarray(nulls, dtype=float)
    models = {}
    period = _period_in_samples(shapes, nulls)

    def group_fit(members: list[int]) -> tuple[list, tuple | None]:  # reads no other group's fit
        points, y, boxes = _group_samples(data, [peaks[k].position for k in members], nulls)
        own = None if chirps is None else [chirps[k] if np.any(chirps[k] != 0) else None for k in members]
        fit = _fit_ideal_group(points, y, [peaks[k] for k in members], nulls, params, boxes, own, shapes)
        # a group holding coinciding targets (coinciding_targets) has their sum on one peak, not one member's
        # response: the refit cannot explain it (paper 004's receiver 14 image: 4 s CPU, refused), nor is it tried
        tried = not coinciding.intersection(members)
        return fit, _refit_rich(data, points, y, fit, members, nulls, params) if tried else None

    groups = _overlapping_groups(peaks, np.asarray(half, dtype=float) + nulls, nulls, period)
    for members, (fit, rich) in zip(groups, ordered_map(group_fit, groups, params.exact)):
        for q, k in enumerate(members):
            models[k] = dataclasses.replace(fit[q], group=frozenset(members))
            if rich is not None:
                models[k] = dataclasses.replace(models[k], rich=rich[0][q], misfit=rich[1])
    return models


def _period_in_samples(shapes: ResponseShapes | None, nulls: npt.ArrayLike) -> np.ndarray:
    """The responses' period along each axis in samples (0: none), from the shapes' period in nulls."""
    if shapes is None:
        return np.zeros(np.shape(nulls))
    return np.asarray(shapes.period, dtype=float) * np.asarray(nulls, dtype=float)


def _nearest_offset(origin: np.ndarray, position: np.ndarray, period: np.ndarray) -> np.ndarray:
    """position - origin per axis, where the responses are periodic (``period`` > 0, samples) the offset of
    the nearest repetition: a uniform array's response repeats every lambda / d, so a target near one edge of
    the elevation period puts its side lobes on targets near the other edge."""
    d = np.asarray(position, dtype=float) - np.asarray(origin, dtype=float)
    p = np.asarray(period, dtype=float)
    return np.where(p > 0, d - p * np.round(d / np.where(p > 0, p, 1.0)), d)


def _overlapping_groups(peaks: list, reach: np.ndarray, nulls: np.ndarray, period: np.ndarray | None = None) -> list:
    """Index lists (ascending) of the groups of two or more targets linked by peaks within ``reach`` (samples
    per axis; along a periodic axis, ``period`` > 0 samples, the nearest repetition). Two truths that found the
    same peak (within half a null: a weaker target inside a stronger one's search window) are one response:
    fitting it twice is singular, and subtracting the copy would remove the target itself, so only the first
    is kept."""
    period = np.zeros(len(nulls)) if period is None else period
    live: list[int] = []
    for j, p in enumerate(peaks):
        if abs(p.value) > 0 and not any(np.all(np.abs(p.position - peaks[k].position) < 0.5 * nulls) for k in live):
            live.append(j)
    group = {j: {j} for j in live}
    for j in live:
        for k in live:
            near = np.all(np.abs(_nearest_offset(peaks[j].position, peaks[k].position, period)) <= reach)
            if k > j and near and group[j] is not group[k]:
                merged = group[j] | group[k]
                for q in merged:
                    group[q] = merged
    out = []
    for j in live:
        members = sorted(group[j])
        if len(members) >= 2 and members[0] == j:
            out.append(members)
    return out


def _group_samples(data: np.ndarray, positions: list, nulls: np.ndarray) -> tuple:
    """(points (ndim, N) float image indices, complex samples, boxes) within 3 nulls of every position, about
    two per null. ``boxes`` (:class:`_SampleBoxes`) says which box each point came from, so a response can be
    evaluated box by box."""
    stride = np.maximum(1, np.floor(nulls / 2)).astype(int)
    r = np.ceil(3 * nulls).astype(int)
    boxes, layout = [], []
    for p in positions:
        c = np.rint(p).astype(int)
        axes_pts = [
            np.arange(max(0, ci - ri), min(n, ci + ri + 1), st) for ci, ri, n, st in zip(c, r, data.shape, stride)
        ]
        g = np.meshgrid(*axes_pts, indexing="ij")
        boxes.append(np.stack([x.ravel() for x in g], axis=0))
        layout.append((np.array([a[0] if a.size else 0 for a in axes_pts]), np.array([a.size for a in axes_pts])))
    points, inverse = unique_columns(np.concatenate(boxes, axis=1), data.shape)
    y = data[tuple(points)].astype(complex)
    return points.astype(float), y, _SampleBoxes(stride, layout, inverse, points.shape[1])


@dataclasses.dataclass(frozen=True)
class _SampleBoxes:
    """The strided boxes a group's samples were drawn from: per box (origin, shape), and each box point's
    index among the (deduplicated) samples, boxes in order."""

    stride: np.ndarray
    layout: list
    inverse: np.ndarray
    count: int

    def ideal_response(
        self,
        position: npt.ArrayLike,
        V: npt.ArrayLike,
        nulls: npt.ArrayLike,
        f_c: npt.ArrayLike,
        hamming: bool,
        chirp: npt.ArrayLike | None = None,
        shapes: ResponseShapes | None = None,
    ) -> np.ndarray:
        """A 3D ideal response (:func:`_ideal_response`) at the samples, from per-axis tables box by box
        (compiled; equal to rounding)."""
        return self._call("ideal_response_boxes", position, V, nulls, f_c, hamming, chirp, shapes)

    def ideal_slopes(
        self,
        position: npt.ArrayLike,
        V: npt.ArrayLike,
        nulls: npt.ArrayLike,
        f_c: npt.ArrayLike,
        hamming: bool,
        chirp: npt.ArrayLike | None = None,
        shapes: ResponseShapes | None = None,
    ) -> np.ndarray:
        """(4, N): :meth:`ideal_response` and its derivatives along each ridge coordinate (nulls), the other
        ridges' shapes and the carrier held (:func:`sarproc.quality.kernels.ideal_response_boxes_slopes`)."""
        return self._call("ideal_response_boxes_slopes", position, V, nulls, f_c, hamming, chirp, shapes)

    def _call(
        self,
        kernel: str,
        position: npt.ArrayLike,
        V: npt.ArrayLike,
        nulls: npt.ArrayLike,
        f_c: npt.ArrayLike,
        hamming: bool,
        chirp: npt.ArrayLike | None,
        shapes: ResponseShapes | None,
    ) -> np.ndarray:
        ridge = np.linalg.inv(np.asarray(V, dtype=float).T) / np.asarray(nulls, dtype=float)[:, None]
        return getattr(kernels_aot.kernels(), kernel)(
            np.array([o for o, _ in self.layout], dtype=float),
            kernels_aot.f8(self.stride),
            np.array([n for _, n in self.layout], dtype=np.int64),
            kernels_aot.i8(self.inverse),
            int(self.count),
            kernels_aot.f8(position),
            kernels_aot.f8(ridge),
            kernels_aot.f8(f_c),
            kernels_aot.f8(_zero_or(chirp, 3)),
            *map(kernels_aot.f8, _shape_args(shapes, 3)),
            bool(hamming),
        )


def _fit_ideal_group(
    points: np.ndarray,
    y: np.ndarray,
    starts: list,
    nulls: np.ndarray,
    params: EvaluateParams,
    boxes: _SampleBoxes | None = None,
    chirps: Sequence[np.ndarray | None] | None = None,
    shapes: ResponseShapes | None = None,
) -> list:
    """Every member's ideal response fitted jointly to the samples ``y`` at ``points``: position, band centre
    and ridge skews by Gauss-Newton (at most 8 steps; linear convergence, about halving, on skewed supports),
    then the complex amplitudes by least squares; ``boxes``: where the samples came from (3D responses are then
    evaluated box by box); ``chirps``: each member's known chirp (cycles/sample^2 per axis, None: none), carried
    by its response, not fitted; ``shapes``: the responses' known shapes (None: sincs).
    Returns one _NeighbourModel per member (group unset)."""
    hamming = params.irw_factor > 1.1
    ndim = points.shape[0]
    skew = [(a, b) for a in range(ndim) for b in range(ndim) if a != b]  # free entries of V
    pos = [np.array(p.position, dtype=float) for p in starts]
    f_c = [np.array(p.band_centre, dtype=float) for p in starts]
    V = [np.array(p.ridges, dtype=float) for p in starts]
    chirp = list(chirps) if chirps is not None else [None] * len(starts)

    def model(q: int, p: np.ndarray | None = None, v: np.ndarray | None = None) -> np.ndarray:
        if boxes is not None and ndim == 3 and not params.exact:
            return boxes.ideal_response(
                pos[q] if p is None else p, V[q] if v is None else v, nulls, f_c[q], hamming, chirp[q], shapes
            )
        return _ideal_response(
            points,
            pos[q] if p is None else p,
            V[q] if v is None else v,
            nulls,
            f_c[q],
            hamming,
            params.exact,
            chirp[q],
            shapes,
        )

    for _ in range(8):
        cols = []
        for q in range(len(starts)):
            offs = points - pos[q][:, None]
            if ndim == 3:  # closed-form columns (one kernel pass on the boxes)
                fast = None if params.exact else boxes
                m, *more = _ideal_columns(fast, offs, pos[q], V[q], nulls, f_c[q], hamming, chirp[q], shapes, skew)
                cols += [m] + [2j * np.pi * offs[a] * m for a in range(ndim)] + more
                continue
            m = model(q)
            cols += [m] + [2j * np.pi * offs[a] * m for a in range(ndim)]
            for a in range(ndim):
                d = np.zeros(ndim)
                d[a] = 0.05
                cols.append((model(q, p=pos[q] + d) - model(q, p=pos[q] - d)) / 0.1)
            for a, b in skew:
                d = np.zeros((ndim, ndim))
                d[a, b] = 0.002
                cols.append((model(q, v=V[q] + d) - model(q, v=V[q] - d)) / 0.004)
        sol = least_squares(np.stack(cols, axis=1), y, params.exact).reshape(len(starts), -1)
        largest = 0.0
        for q in range(len(starts)):
            if sol[q, 0] == 0:
                continue
            step = (sol[q, 1:] / sol[q, 0]).real
            largest = max(largest, float(np.abs(step[:ndim]).max() * 100), float(np.abs(step[ndim:]).max()))
            f_c[q] = f_c[q] + np.clip(step[:ndim], -0.02, 0.02)
            pos[q] = pos[q] + np.clip(step[ndim : 2 * ndim], -0.3, 0.3)
            for (a, b), dv in zip(skew, np.clip(step[2 * ndim :], -0.05, 0.05)):
                V[q][a, b] += dv
        if largest < 1e-3:  # band centres within 1e-5 cycles/sample, positions and skews within 1e-3
            break
    basis = np.stack([model(q) for q in range(len(starts))], axis=1)
    amp = least_squares(basis, y, params.exact)
    # How well ideal responses explain the group: a poor fit leaves the neighbours' side lobes in.
    misfit = float(np.sum(np.abs(y - basis @ amp) ** 2) / max(np.sum(np.abs(y) ** 2), 1e-300))
    return [
        _NeighbourModel(pos[q], f_c[q], V[q], amp[q], frozenset(), misfit, nulls, chirp=chirp[q], shapes=shapes)
        for q in range(len(starts))
    ]


def _ideal_columns(
    boxes: _SampleBoxes | None,
    offs: np.ndarray,
    position: np.ndarray,
    V: np.ndarray,
    nulls: np.ndarray,
    f_c: np.ndarray,
    hamming: bool,
    chirp: np.ndarray | None,
    shapes: ResponseShapes | None,
    skew: Sequence[tuple[int, int]],
) -> list[np.ndarray]:
    """A 3D ideal response at the samples (``offs``: their offsets from ``position``, (3, N)) and its derivatives
    with respect to the position (3) and the ``skew`` entries of V, in closed form from the derivatives G_a along
    each ridge coordinate c = R (x - p) / nulls, R = V^-T: with H_b = sum_a G_a R[a, b] / nulls[a],
    dm/dp_b = -H_b - 2 pi i (f_c[b] + chirp[b] d_b) m and dm/dV[a, b] = -nulls[a] c_a H_b (dR = -R dV^T R).
    ``boxes``: the samples' boxes (the compiled kernel); None: the numpy reference."""
    ridge = np.linalg.inv(np.asarray(V, dtype=float).T) / np.asarray(nulls, dtype=float)[:, None]
    c = ridge @ offs
    if boxes is not None:
        out = boxes.ideal_slopes(position, V, nulls, f_c, hamming, chirp, shapes)
        m, G = out[0], out[1:]
    else:
        m, G = _ideal_slopes_np(c, offs, f_c, hamming, chirp, shapes)
    H = ridge.T @ G
    k = _zero_or(chirp, 3)
    d_pos = [-H[b] - 2j * np.pi * (f_c[b] + k[b] * offs[b]) * m for b in range(3)]
    return [m, *d_pos, *[-nulls[a] * c[a] * H[b] for a, b in skew]]


def _ideal_slopes_np(
    c: np.ndarray,
    offs: np.ndarray,
    f_c: np.ndarray,
    hamming: bool,
    chirp: np.ndarray | None,
    shapes: ResponseShapes | None,
) -> tuple[np.ndarray, np.ndarray]:
    """(m, G (3, N)): the ideal response at ridge coordinates ``c`` (offsets ``offs`` from its position) and its
    derivatives along each ridge coordinate, the reference of the compiled kernel's: a sinc's or its Hamming sum's
    slope in closed form, a tabulated (inside its table) or periodic shape's by central differences of 1e-5 nulls."""
    per, table, rate = _shape_args(shapes, 3)
    amps, slopes = [], []
    h = 1e-5
    for a in range(3):
        q = c[a]
        amps.append(_axis_shape_np(q, per[a], table[a], rate[a], hamming))
        fd = (
            _axis_shape_np(q + h, per[a], table[a], rate[a], hamming)
            - _axis_shape_np(q - h, per[a], table[a], rate[a], hamming)
        ) / (2 * h)
        if per[a] > 0:
            slopes.append(fd)
            continue
        closed = _sinc_slope_np(q)
        if hamming:
            closed = 0.54 * closed + 0.23 * (_sinc_slope_np(q - 1) + _sinc_slope_np(q + 1))
        tabled = ~np.isnan(_tabled_np(q, table[a], rate[a])) if rate[a] > 0 else np.zeros(q.shape, dtype=bool)
        slopes.append(np.where(tabled, fd, closed))
    phase = np.asarray(f_c) @ offs + 0.5 * (_zero_or(chirp, 3) @ offs**2)
    carrier = np.exp(2j * np.pi * phase)
    G = np.stack([slopes[a] * amps[(a + 1) % 3] * amps[(a + 2) % 3] * carrier for a in range(3)])
    return amps[0] * amps[1] * amps[2] * carrier, G


def _sinc_slope_np(q: np.ndarray) -> np.ndarray:
    """d sinc(q) / dq; near q = 0 from its series."""
    small = np.abs(q) < 1e-3
    safe = np.where(small, 1.0, q)
    return np.where(small, -(np.pi**2) * q / 3 + np.pi**4 * q**3 / 30, (np.cos(np.pi * safe) - np.sinc(safe)) / safe)


def _tabled_np(q: np.ndarray, row: np.ndarray, rate: float) -> np.ndarray:
    """The tabulated shape ``row`` at q nulls (linear), NaN beyond the table (the compiled kernels' _tabled)."""
    t = q * rate + (row.shape[0] - 1) / 2.0
    i = np.floor(t).astype(np.int64)
    inside = (i >= 0) & (i < row.shape[0] - 1)
    j = np.where(inside, i, 0)
    return np.where(inside, row[j] + (t - j) * (row[j + 1] - row[j]), np.nan)


def _refit_rich(
    data: np.ndarray,
    points: np.ndarray,
    y: np.ndarray,
    fit: list,
    members: list,
    nulls: np.ndarray,
    params: EvaluateParams,
) -> tuple | None:
    """Where ideal responses leave more than NEIGHBOUR_MISFIT of a group's energy, the members' own spectral
    weight, phase and chirp fitted instead (the residual image's response models, ridges as far as a chip
    reaches). Returns (one ResponseModel or None per member, their misfit) where they explain the group within
    NEIGHBOUR_MISFIT, else None (the ideal models stay and the cuts say contaminated)."""
    if not (
        fit[0].misfit > NEIGHBOUR_MISFIT
        and params.neighbour_orders > 0
        and _refit_size(members, nulls, params) <= REFIT_BUDGET
    ):
        return None
    start = [FitStart(position=m.position, ridges=m.ridges, band_centre=m.band_centre, value=m.amplitude) for m in fit]
    fitted = fit_response_models(
        data,
        start,
        nulls,
        dataclasses.replace(
            params, residual_orders=params.neighbour_orders, fit_ridge_nulls=params.islr_nulls + params.margin_nulls
        ),
    )
    pred = sum(model_values(points, m) for m in fitted if m is not None)
    misfit = float(np.sum(np.abs(y - pred) ** 2) / max(np.sum(np.abs(y) ** 2), 1e-300))
    return (fitted, misfit) if misfit <= NEIGHBOUR_MISFIT else None


REFIT_BUDGET = 1e9  # rows x columns^2 of a crowded group's response-model fit above which it is not tried


def _refit_size(members: Sequence[int], nulls: npt.ArrayLike, params: EvaluateParams) -> float:
    """Rows x columns^2 of the least squares that refits a crowded group as response models (its cost)."""
    nulls = np.asarray(nulls, dtype=float)
    ndim = len(nulls)
    stride = np.maximum(1, np.floor(nulls / 2))
    box = np.prod(2 * np.ceil(params.fit_nulls * nulls) / stride + 1)
    reach = params.islr_nulls + params.margin_nulls
    strips = sum(
        2
        * reach
        * nulls[a]
        / stride[a]
        * np.prod([2 * math.ceil(nulls[b]) / stride[b] + 1 for b in range(ndim) if b != a])
        for a in range(ndim)
    )
    columns = (
        len(spectral_orders(ndim, params.neighbour_orders, params.neighbour_orders + (1 if ndim == 2 else 0)))
        + ndim
        + ndim * (ndim + 1) // 2
    )
    return float(len(members) * (box + strips) * (len(members) * columns) ** 2)


def _measure(
    peak: _Peak, axes: Sequence[_Axis], truth: np.ndarray, name: str, params: EvaluateParams, metric: np.ndarray | None
) -> TargetReport:
    """A target's report: its cuts along the image axes and along its principal axes (ridges), the latter
    checked for contamination by poorly fitted neighbours."""
    chip, pos, V = peak.chip, peak.position, peak.ridges
    peak2 = abs(peak.value) ** 2
    if peak2 == 0:
        pos = np.full(len(axes), np.nan)
    eye = np.eye(len(axes))
    image_axes = [_cut(chip, axes, a, eye[a], pos, peak2, truth, params, metric) for a in range(len(axes))]
    principal = [
        image_axes[a] if np.array_equal(V[a], eye[a]) else _cut(chip, axes, a, V[a], pos, peak2, truth, params, metric)
        for a in range(len(axes))
    ]
    if peak.contaminating and peak2 > 0:
        principal = [
            _contamination(m, chip, axes, a, V[a], pos, peak2, peak.contaminating, truth, params, metric)
            for a, m in enumerate(principal)
        ]
    return TargetReport(
        name=name,
        peak_amplitude=abs(peak.value),
        peak_phase=float(np.angle(peak.value)),
        peak_index=tuple(peak.index),
        chip_clipped=chip.clipped,
        axes=tuple(principal),
        image_axes=tuple(image_axes),
        neighbours_removed=tuple(peak.removed),
        notes=tuple(fan_note(axes[a].name) for a in peak.fanned),
    )


def fan_note(axis: str) -> str:
    """The note of a target whose ``axis`` side lobes fan out."""
    return (
        f"its {axis} side lobes fan out over the aperture's look angles (the support's {axis} edges are arcs: a "
        "narrowband, wide-angle aperture); the cut runs through the fan's centre, and the ideal point-target "
        "response the residual subtracts does not describe a fan (its fit box is left out of the false-target "
        "search)"
    )


NEIGHBOUR_MISFIT = 1e-3  # group fit residual (energy ratio) above which subtracted neighbours may leave side lobes
CONTAMINATION = 0.01  # neighbours' modelled energy in a cut's ISLR window / the main lobe's: flag above


def _contamination(
    m: AxisMetrics,
    chip: _Chip,
    axes: Sequence[_Axis],
    a: int,
    v: np.ndarray,
    pos: np.ndarray,
    peak2: float,
    models: Sequence[_NeighbourModel],
    truth: np.ndarray,
    params: EvaluateParams,
    metric: np.ndarray | None,
) -> AxisMetrics:
    """Flag a cut whose ISLR window holds more than CONTAMINATION of its main-lobe energy from neighbours
    that ideal responses did not fit well (so their subtraction leaves an unknown residual), and measure
    it again on a window shortened to stop half-way to the nearest of them (see AxisMetrics)."""
    ax = axes[a]
    window = params.islr_nulls * ax.null
    t = np.arange(-int(math.ceil(window * 4)), int(math.ceil(window * 4)) + 1) / 4.0
    points = pos[:, None] + np.outer(v, t)
    hamming = params.irw_factor > 1.1
    nulls = [x.null for x in axes]
    main = peak2 * 0.903 * ax.null  # unweighted main-lobe energy along the cut (0.903 of the total)
    ratios = [float(np.sum(np.abs(mod.values(points, hamming, params.exact)) ** 2) / 4.0 / main) for mod in models]
    ratio = sum(ratios)
    if ratio <= CONTAMINATION:
        return m
    m = dataclasses.replace(m, contaminated_db=float(10 * np.log10(ratio)))
    # Where each contaminating neighbour on the cut line (within two nulls of it on every axis) meets the
    # cut: its projection on pos + t v (t in samples of axis a), in nulls; the window ends on one of the
    # target's own nulls at half that distance. Neighbours off the line cannot be cut away by shortening.
    v = np.asarray(v, dtype=float)
    reach = []
    for mod, r in zip(models, ratios):
        d = np.asarray(mod.position, dtype=float) - pos
        t_n = float(d @ v / (v @ v))
        if r > CONTAMINATION / 10 and np.all(np.abs(d - t_n * v) <= 2 * np.asarray(nulls)):
            reach.append(abs(t_n) / ax.null)
    half = min(params.islr_nulls, math.floor(min(reach) / 2)) if reach else params.islr_nulls
    if half < 2 or half >= params.islr_nulls:  # no side lobe left to measure, or nothing to shorten
        return m
    short = _cut(chip, axes, a, v, pos, peak2, truth, dataclasses.replace(params, islr_nulls=float(half)), metric)
    return dataclasses.replace(
        m,
        shortened_nulls=float(half),
        shortened_pslr_db=short.pslr_db,
        shortened_islr_db=short.islr_db,
        shortened_islr_theory_db=None if hamming else sinc_islr_db(half),
    )


def sinc_islr_db(window_nulls: float) -> float:
    """ISLR of an unweighted sinc over +-``window_nulls`` (an integer number of nulls), dB.

    The integral of sinc^2 from 0 to an integer X is Si(2 pi X) / pi, so the side-lobe energy over
    the main lobe's is (Si(2 pi X) - Si(2 pi)) / Si(2 pi): -10.16 dB for X = 10.
    """
    import scipy.special

    def si(x: float) -> float:
        return float(scipy.special.sici(x)[0])

    return 10 * math.log10((si(2 * math.pi * window_nulls) - si(2 * math.pi)) / si(2 * math.pi))


def _cut(
    chip: _Chip,
    axes: Sequence[_Axis],
    a: int,
    v: np.ndarray,
    pos: np.ndarray,
    peak2: float,
    truth: np.ndarray,
    params: EvaluateParams,
    metric: np.ndarray | None,
) -> AxisMetrics:
    """Metrics of the cut through ``pos`` along ``v`` (image samples per sample of axis a, v[a] = 1)."""
    ax = axes[a]
    window = params.islr_nulls * ax.null  # samples of axis a
    reach = window + 2 * ax.null
    m = int(math.ceil(reach * params.upsample))
    offsets = np.arange(-m, m + 1) / params.upsample
    if peak2 > 0:
        if np.count_nonzero(v) == 1 and not params.exact:  # along an image axis: separable evaluation
            vals = chip.values_on_axis(pos, a, offsets[0], 1.0 / params.upsample, offsets.size)
        elif np.count_nonzero(v) == 1:
            grids = [np.array([p]) for p in pos]
            grids[a] = pos[a] + offsets
            vals = chip.values(grids).reshape(-1)
        else:  # exact on a 16x grid along the line, then a cubic spline (error ~1e-5 of the peak)
            ex = min(params.upsample, 16)
            lo = -int(math.ceil(reach * ex)) - 2
            te = np.arange(lo, -lo + 1) / ex
            ve = (
                chip.values_along(pos, v, te)
                if params.exact
                else chip.values_on_line(pos, v, lo / ex, 1.0 / ex, te.size)
            )
            vals = (
                ve[np.searchsorted(te, offsets)]
                if ex == params.upsample
                else uniform_cubic_spline(te[0], te[1] - te[0], ve, offsets)
            )
        p = np.abs(vals) ** 2 / peak2
        irw, pslr, islr, main = _cut_metrics(p, 1.0 / params.upsample, m, window)
    else:  # no response at all around the truth: every metric is undefined (fails any --expect check)
        irw = pslr = islr = main = np.nan
    steps = np.array([x.step for x in axes])
    direction = v * steps / ax.step  # axis units per unit along axis a
    if metric is not None:
        factor = float(np.linalg.norm(direction @ metric))  # length along the cut per unit of axis a
        e, d = metric[a], direction @ metric
    else:
        factor = 1.0
        e, d = np.eye(len(axes))[a], v / np.array([x.null for x in axes])
    angle = math.degrees(math.acos(min(1.0, abs(float(d @ e)) / float(np.linalg.norm(d) * np.linalg.norm(e)))))
    ends = np.array([pos + (window + ax.null) * v, pos - (window + ax.null) * v])
    sizes = np.array([x.size - 1 for x in axes])
    truncated = bool(np.all(np.isfinite(ends)) and (np.any(ends < 0) or np.any(ends > sizes)))
    length = abs(ax.step) * factor  # axis-a extent of one sample -> length along the cut
    x = float(ax.to_coord(pos[a]))
    err = x - float(truth[a])
    return AxisMetrics(
        axis=ax.name,
        irw=irw * length,
        irw_theory=ax.irw * factor,
        irw_ratio=irw * abs(ax.step) / ax.irw,
        pslr_db=pslr,
        islr_db=islr,
        mainlobe_width=main * length,
        position=x,
        truth=float(truth[a]),
        position_error=err,
        position_error_cells=err / ax.irw,
        band_center=chip.centers[a] / ax.step,
        direction=tuple(float(c) for c in direction),
        angle_deg=angle,
        truncated=truncated,
        theory=ax.theory,
        pslr_theory_db=ax.pslr_theory,
        islr_theory_db=ax.islr_theory,
    )


def _false_target(
    data: np.ndarray,
    mag: np.ndarray,
    axes: Sequence[_Axis],
    truth: np.ndarray,
    peaks: Sequence[np.ndarray],
    reports: list[TargetReport],
    half: Sequence[int],
    params: EvaluateParams,
) -> FalseTarget | None:
    outside = np.ones(data.shape, dtype=bool)
    guard = [ax.cells_to_samples(params.guard_cells) for ax in axes]
    centres = [np.rint([ax.to_index(x) for ax, x in zip(axes, t)]).astype(int) for t in truth] + list(peaks)
    for c in centres:
        outside[window_slices(c, guard, data.shape)] = False
    if not outside.any():
        return None
    ref = max(reports, key=lambda r: r.peak_amplitude)
    masked = np.where(outside, mag, -1.0)
    k = np.unravel_index(np.argmax(masked), masked.shape)
    pixel = float(mag[k])
    if pixel == 0.0 or ref.peak_amplitude == 0.0:
        return FalseTarget(
            level_db=-np.inf,
            position={ax.name: float(ax.to_coord(i)) for ax, i in zip(axes, k)},
            pixel_level_db=-np.inf,
            reference_target=ref.name,
        )
    # Refine like a target so the level is free of the pixel-grid scalloping loss.
    pos, value = refine_false_target(data, k, half)
    return FalseTarget(
        level_db=float(20 * np.log10(max(abs(value), pixel) / ref.peak_amplitude)),
        position={ax.name: float(ax.to_coord(p)) for ax, p in zip(axes, pos)},
        pixel_level_db=float(20 * np.log10(pixel / ref.peak_amplitude)),
        reference_target=ref.name,
    )


def refine_false_target(data: np.ndarray, k: npt.ArrayLike, half: Sequence[int]) -> tuple[np.ndarray, complex]:
    """(position, value): the peak about a false target's strongest pixel ``k`` (image indices), free of the pixel
    grid's scalloping. Where ``k`` lies on the image's edge along an axis the chip's interpolant is not used along
    it: the chip is zero beyond the edge, and the band-limited interpolant of a response cut there overshoots
    (Gibbs; a -40.00 dB ghost on the last range cell read -39.35 dB, 0.2 samples inside it -39.22). Along such an
    axis the peak is a parabola through the edge sample and the two inside it (:func:`_edge_parabola`), its vertex
    kept within the half cell inside the edge (the pixel is the strongest: the peak lies no farther in; beyond
    the edge the image does not say, and the edge pixel is taken)."""
    k = [int(i) for i in np.ravel(k)]
    edges = [a for a, (i, n) in enumerate(zip(k, data.shape)) if n >= 3 and i in (0, n - 1)]
    chip = _Chip(data, k, half)
    pos, value = chip.refine_peak(k, fixed=edges)
    for a in edges:
        inward = 1 if k[a] == 0 else -1
        grids = [np.array([p]) for p in pos]
        samples = []
        for step in range(3):  # integer positions along the axis: the chip's interpolant there is the samples
            grids[a] = np.array([k[a] + inward * step], dtype=float)
            samples.append(complex(chip.values(grids).ravel()[0]))
        shift, level = _edge_parabola([abs(v) for v in samples])
        if level > abs(value):
            pos = pos.copy()
            pos[a] = k[a] + inward * shift
            value = samples[0] / abs(samples[0]) * level if samples[0] else complex(level)
    return pos, complex(value)


def _edge_parabola(m: Sequence[float]) -> tuple[float, float]:
    """(shift, level): the vertex of the parabola through magnitudes ``m`` at 0, 1, 2 samples inside an edge, its
    shift kept within [0, 1/2] (0: the edge sample)."""
    m0, m1, m2 = m
    a = 0.5 * (m2 - 2 * m1 + m0)
    b = m1 - m0 - a
    if a >= 0:
        return 0.0, m0
    shift = min(max(-b / (2 * a), 0.0), 0.5)
    return shift, m0 + b * shift + a * shift * shift


def target_patch(
    data: np.ndarray,
    dims: Sequence[str],
    coords: Any,
    theoretical_irw: npt.ArrayLike,
    target: TargetReport,
    pair: tuple[int, int] = (0, 1),
    half_width_nulls: float = 4.0,
    upsample: int = 8,
    params: EvaluateParams | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Upsampled 2-D slice through a target's refined peak, for contour plots.

    ``pair`` picks two axes (indices into dims); other axes are fixed at the peak. Returns
    (offsets along pair[0], offsets along pair[1], complex values normalised to the peak),
    offsets in axis units relative to the refined peak, values of shape (n0, n1).
    """
    params = params or EvaluateParams()
    data = np.asarray(data)
    axes = _make_axes(data.shape, tuple(dims), coords, theoretical_irw, params.irw_factor)
    half = [ax.nulls_to_samples(params.islr_nulls + params.margin_nulls) for ax in axes]
    chip = _Chip(data, target.peak_index, half)
    pos = np.array([float(ax.to_index(target.axis(ax.name).position)) for ax in axes])
    grids = [np.array([p]) for p in pos]
    offsets, half_grid = [], {}
    for a in pair:
        m = int(math.ceil(half_width_nulls * axes[a].null * upsample))
        off = np.arange(-m, m + 1) / upsample
        grids[a] = pos[a] + off
        offsets.append(off * axes[a].step)
        half_grid[a] = m
    vals = chip.values_upsampled(pos, half_grid, upsample)
    if vals is None:
        vals = chip.values(grids)
    vals = (
        vals.reshape(len(offsets[0]), len(offsets[1]))
        if pair[0] < pair[1]
        else vals.reshape(len(offsets[1]), len(offsets[0])).T
    )
    peak = chip.values([np.array([p]) for p in pos]).reshape(())
    return offsets[0], offsets[1], vals / peak


def frame_metric(product: Product) -> np.ndarray | None:
    """The image frame's local basis (:meth:`sarproc.product.frames.Frame.metric`), or None."""
    from sarproc.product.frames import frame_from_spec

    spec = product.attrs.get("frame")
    if spec is None:
        return None
    try:
        frame = frame_from_spec(spec)
    except (InputError, TypeError, ValueError):
        return None
    m = frame.metric()
    return None if m is None or tuple(getattr(frame, "axes", ())) != tuple(product.dims) else m


def target_ridge_angles(product: Product) -> np.ndarray:
    """(n_targets,) the angle in space between each target's two theoretical ridges, degrees
    (:func:`sarproc.product.theory.image_ridge_angles`: as its targets table records it, else from the product's
    pulses and its targets table's frame coordinates), for a 2D image whose frame has a metric and whose pulses
    are recorded; NaN elsewhere (evaluate then takes the slant plane's 90), and for a polar-format image
    (``support_rectangle``: pfa2 resamples the pulses' support onto a rectangle of the frame's k axes, whose edges
    are perpendicular)."""
    from sarproc.product.theory import image_ridge_angles

    out = image_ridge_angles(product)
    out[np.abs(out - 90.0) < SLANT_RIDGE_ANGLE_TOL_DEG] = np.nan  # the slant plane's 90, as before
    return out


# A target's residual model takes a cubic carrier (:func:`sarproc.quality.residual._fit_cubics`) where its ridges
# lie more than this many degrees off perpendicular in space: a sheared support (the trial's 45 deg squint at 800 m
# over 1.2 km: 36.9 deg, 53 off). Partly lit targets of a slant frame come within a degree of 90 (bp_beam_edge's:
# 89.90, 89.68) and keep their models as they were.
CUBIC_SHEAR_DEG = 10.0


# Slant-plane frames (squint, zero_doppler, los) put the theory's ridges within 0.003 deg of 90 (the frame axes
# are finite differences; demo 0.0027, an2012_exp1_small 0.0007, bp_squint30 0.0002): taken as 90, so their
# reports stay those pinned; ground frames at a squint move by degrees (demo in a ground frame 86.8, nie2016_small
# 88.4-88.8, 45 deg squint at 800 m over 1.2 km 36.9).
SLANT_RIDGE_ANGLE_TOL_DEG = 0.1


def evaluate_product(
    product: Product,
    params: EvaluateParams | None = None,
    source: str = "",
    progress: Callable[[Iterable[Any]], Iterable[Any]] | None = None,
    names: Collection[str] | None = None,
) -> QualityReport:
    """Evaluate an ``image``/``image3d`` :class:`sarproc.product.model.Product` against its targets table.

    Truth per target is the targets field named like each dim; a moving target (nonzero velocity)
    is measured at its static-equivalent position, where a static-scene image focuses it, and
    reported with its velocity and relocation errors (:mod:`sarproc.quality.moving`); theory is the target's own
    ``irw_<dim>``, ``null_<dim>``, ``pslr_<dim>`` and ``islr_<dim>`` fields where recorded (not 0; every
    processor records them from the target's own illumination and weighting), else
    ``product.attrs['theoretical_irw']`` with ``irw_factor``. ``names``: report only these
    targets (the others inside the image are still found and subtracted as neighbours, so the named targets'
    figures are those of the run over all; every other's neighbourhood stays out of the false-target search).
    ``source`` (the file name) prefixes error messages.
    """
    from sarproc.quality.moving import mover_reports

    where = f"{source}: " if source else ""
    all_names = _checked_product(product, names, where)
    table = _truth_table(product, params, source, where)
    chosen = _chosen_targets(product, table, all_names, names)
    keep = chosen.keep
    theory = _recorded_theory(product, table, keep)
    try:
        report = evaluate_image(
            product.data,
            product.dims,
            product.coords,
            product.attrs["theoretical_irw"],
            chosen.truth[keep],
            [n for n, k in zip(all_names, keep) if k],
            params,
            metric=frame_metric(product),
            progress=progress,
            target_irw=theory.irw if np.any(~np.isnan(theory.irw)) else None,
            target_null=theory.null,
            target_sidelobes=theory.sidelobes,
            other_truth=chosen.truth[~keep],
            target_chirp=target_chirp(product, chosen.truth[keep], where),
            response_period=response_period(product, where),
            response_table=response_table(product, where),
            measure=chosen.measured[keep],
            ridge_angles=target_ridge_angles(product)[keep],
        )
    except InputError as exc:
        raise InputError(f"{where}{exc}") from None
    notes = focus_limit_notes(
        product.attrs.get("focus_limits"),
        report.params.search_cells,
        product.attrs.get("valid_radius", math.nan),
        product.attrs.get("theoretical_irw", (math.nan,) * 2),
    )
    targets = tuple(dataclasses.replace(t, notes=t.notes + notes.get(t.name, ())) for t in report.targets)
    return dataclasses.replace(report, targets=targets, movers=mover_reports(product, table, report, source))


def focus_limit_notes(
    limits: Mapping[str, Any] | None, search_cells: float, valid_radius: float, irw: Sequence[float]
) -> dict[str, tuple[str, ...]]:
    """Per target, what the focusing stage's ``focus_limits`` attribute says makes its figures other than a
    focused response at its truth (pfa2 plain: beyond eq. (7)'s ``valid_radius``; the planar-wavefront
    distortion left in, with its predicted displacement, also in cells of the image's theoretical ``irw``)."""
    if not limits:
        return {}
    notes: dict[str, list[str]] = {}
    radius = float(valid_radius)
    for name, dist in limits.get("beyond_valid_radius", {}).items():
        notes.setdefault(name, []).append(
            f"beyond plain PFA's valid radius: {dist:.4g} m = {dist / radius:.2f} x {radius:.4g} m (eq. 7), its "
            "response defocused: the figures are not those of a focused target"
        )
    for name, shift in limits.get("distortion_uncorrected", {}).items():
        cells = [x / w for x, w in zip(shift, irw)]
        if max(abs(c) for c in cells) < 0.01:  # the reference point itself: nothing to say
            continue
        text = (
            "its position error includes plain PFA's planar-wavefront distortion, left in (pfa2 "
            f"correct_distortion: false), predicted displacement azimuth {shift[0]:+.3g} m ({cells[0]:+.2f} cells), "
            f"range {shift[1]:+.3g} m ({cells[1]:+.2f} cells)"
        )
        if max(abs(c) for c in cells) > search_cells:
            text += (
                f": beyond the +-{search_cells:g}-cell peak search around the truth, so the figures measure "
                "what lies there (side lobes), not the target's response"
            )
        notes.setdefault(name, []).append(text)
    return {k: tuple(v) for k, v in notes.items()}


def _checked_product(product: Product, names: Collection[str] | None, where: str) -> list[str]:
    """Every target's name, once the product has what evaluate_product needs: theoretical_irw, a targets field per
    image axis, a target, and every one of ``names`` (None: all). Raises InputError prefixed with ``where``."""
    if product.attrs.get("theoretical_irw") is None:
        raise InputError(
            f"{where}image attribute 'theoretical_irw' is missing (expected one IRW per axis {product.dims})"
        )
    fields = product.targets.dtype.names or ()
    missing = [d for d in product.dims if d not in fields]
    if missing:
        raise InputError(f"{where}targets table has no field(s) {missing} for the image axes {product.dims}")
    if len(product.targets) == 0:
        raise InputError(f"{where}targets table is empty; nothing to evaluate")
    all_names = target_names(product.targets)
    if names is not None:
        unknown = [n for n in names if n not in all_names]
        if unknown:
            raise InputError(
                f"{where}--targets: no target(s) {', '.join(map(repr, unknown))} in the targets table "
                f"(targets: {', '.join(all_names)})"
            )
    return all_names


def _truth_table(product: Product, params: EvaluateParams | None, source: str, where: str) -> np.ndarray:
    """The targets table where the image shows them: each mover at its static equivalent
    (:func:`sarproc.quality.moving.apparent_truth`), with ``params.fold_elevation`` the elevation folded
    (:func:`folded_truth`)."""
    from sarproc.quality.moving import apparent_truth

    table = apparent_truth(product, source)
    if params is not None and params.fold_elevation:
        table = folded_truth(product, table, where)
    return table


@dataclasses.dataclass(frozen=True)
class _ChosenTargets:
    """Which of a product's targets evaluate_image gets (``keep``) and which of those it reports (``measured``)."""

    truth: np.ndarray  # (n_targets, ndim) every target's position in the image, dims order
    measured: np.ndarray  # (n_targets,) named (every one without names)
    keep: np.ndarray  # (n_targets,) measured, or within the image: modelled as a neighbour


def _chosen_targets(
    product: Product, table: np.ndarray, all_names: Sequence[str], names: Collection[str] | None
) -> _ChosenTargets:
    """The targets named (``names``; None: all) and the others modelled as neighbours: those the image holds."""
    truth = np.stack([table[d].astype(float) for d in product.dims], axis=1)
    measured = np.array([names is None or n in names for n in all_names])
    inside = _within_extent(product, truth)
    if names is None and not inside.all():
        raise InputError(outside_extent_message(product, truth, all_names, inside))
    # the targets left out of a subset are still modelled as neighbours where they lie in the image
    return _ChosenTargets(truth, measured, measured | inside)


def outside_extent_message(product: Product, truth: np.ndarray, names: Sequence[str], inside: np.ndarray) -> str:
    """Every target outside the image's extent (an image cropped to some targets), with the extent and the
    targets it holds, which evaluate measures alone when named (``names`` / evaluate --targets)."""
    out = [n for n, k in zip(names, inside) if not k]
    extent = ", ".join(
        f"{d} [{float(np.min(product.coords[d])):.6g}, {float(np.max(product.coords[d])):.6g}]" for d in product.dims
    )
    where = ", ".join(
        f"{n!r} (" + ", ".join(f"{d} = {x:.6g}" for d, x in zip(product.dims, truth[i])) + ")"
        for i, n in enumerate(names)
        if not inside[i]
    )
    held = [n for n, k in zip(names, inside) if k]
    hint = f"measure those it holds alone with --targets {','.join(held)}" if held else "it holds no target"
    verb = "target {} lies" if len(out) == 1 else f"{len(out)} of {len(names)} targets {{}} lie"
    return f"{verb.format(where)} outside the image extent ({extent}); {hint}"


@dataclasses.dataclass(frozen=True)
class _RecordedTheory:
    """The targets table's own theory for each target evaluate_image gets, per axis (dims order); NaN where not
    recorded (0 in the table, or no such field): evaluate_image's target_irw, target_null and target_sidelobes."""

    irw: np.ndarray  # (n, ndim) IRW, axis units
    null: np.ndarray  # (n, ndim) null spacing 1/B, axis units
    sidelobes: np.ndarray  # (n, ndim, 2) PSLR and ISLR, dB (both NaN where either is not recorded)


def _recorded_theory(product: Product, table: np.ndarray, keep: np.ndarray) -> _RecordedTheory:
    """The ``keep`` targets' recorded theory: IRW from ``table`` (the targets where the image shows them), null
    spacing and side lobes from ``product.targets``."""
    lobes = np.stack(
        [_theory_field(product.targets, "pslr", product.dims), _theory_field(product.targets, "islr", product.dims)],
        axis=-1,
    )
    lobes[np.isnan(lobes).any(axis=-1)] = np.nan
    return _RecordedTheory(
        irw=_theory_field(table, "irw", product.dims)[keep],
        null=_theory_field(product.targets, "null", product.dims)[keep],
        sidelobes=lobes[keep],
    )


def _theory_field(targets: np.ndarray, prefix: str, dims: Sequence[str]) -> np.ndarray:
    """(n_targets, ndim) a theory field ``<prefix>_<dim>`` per target and axis; 0 (not recorded) or absent: NaN."""
    fields = targets.dtype.names or ()
    v = np.stack(
        [targets[f"{prefix}_{d}"].astype(float) if f"{prefix}_{d}" in fields else np.zeros(len(targets)) for d in dims],
        axis=1,
    )
    v[v == 0] = np.nan
    return v


def _within_extent(product: Product, truth: np.ndarray) -> np.ndarray:
    """(n_targets,) whether each truth position lies within the image's extent (half a sample beyond the
    first and last coordinates, as :func:`_find_peak` requires)."""
    inside = np.ones(len(truth), dtype=bool)
    for a, d in enumerate(product.dims):
        c = np.asarray(product.coords[d], dtype=float)
        half = abs(c[1] - c[0]) / 2 if len(c) > 1 else 0.0
        inside &= (truth[:, a] >= c.min() - half) & (truth[:, a] <= c.max() + half)
    return inside


CHIRP_ATTR = "azimuth_chirp_times_range"  # 1/m: the azimuth response of a target at slant range r carries
# exp(j pi (value / r) (x - x0)^2), x along track in m (array3d: 2 / lambda; see its attribute's note)


def target_chirp(product: Product, truth: np.ndarray, where: str = "") -> np.ndarray | None:
    """(n_targets, ndim) chirp rate of each target's response per axis, axis units^-2 (evaluate_image's
    target_chirp), from the image attribute CHIRP_ATTR and each target's slant range; None without it."""
    value = product.attrs.get(CHIRP_ATTR)
    if value is None:
        return None
    dims = list(product.dims)
    if "azimuth" not in dims or "range" not in dims or not (np.isfinite(value) and value > 0):
        raise InputError(
            f"{where}image attribute {CHIRP_ATTR!r} = {value!r} needs azimuth and range axes and a positive value"
        )
    out = np.zeros(truth.shape)
    out[:, dims.index("azimuth")] = float(value) / truth[:, dims.index("range")]
    return out


PERIOD_ATTR = "elevation_period"  # rad: the elevation response is the periodic sinc of this period (array3d's
# uniform array: its array factor, period lambda / d in sin(theta), taken as theta near nadir)


def folded_elevation(elevation: npt.ArrayLike, period: float) -> np.ndarray:
    """Elevation angle(s) (rad) where a uniform array whose response is periodic in sin(theta) with ``period``
    (lambda / d) images a target at ``elevation``: sin(theta) wrapped into [-period / 2, period / 2); angles
    inside that interval are returned unchanged (bit for bit)."""
    theta = np.asarray(elevation, dtype=float)
    s = np.sin(theta)
    outside = np.abs(s) >= period / 2
    return np.where(outside, np.arcsin(np.mod(s + period / 2, period) - period / 2), theta)


def folded_truth(product: Product, table: np.ndarray, where: str = "") -> np.ndarray:
    """The targets table with each target's elevation where the cube's array images it (:func:`folded_elevation`
    with the image attribute PERIOD_ATTR), for ``evaluate.fold_elevation``."""
    period = product.attrs.get(PERIOD_ATTR)
    if "elevation" not in product.dims or period is None or not (np.isfinite(period) and period > 0):
        raise InputError(
            f"{where}evaluate.fold_elevation needs a 3D cube with an elevation axis and the image attribute "
            f"{PERIOD_ATTR!r} (a uniform array's lambda / d); this image has dims {product.dims} and {PERIOD_ATTR}="
            f"{period!r}"
        )
    out = table.copy()
    out["elevation"] = folded_elevation(table["elevation"], float(period))
    return out


def response_period(product: Product, where: str = "") -> np.ndarray | None:
    """(ndim,) period of the responses per axis, axis units (evaluate_image's response_period), from the image
    attribute PERIOD_ATTR; None without it."""
    value = product.attrs.get(PERIOD_ATTR)
    if value is None:
        return None
    dims = list(product.dims)
    if "elevation" not in dims or not (np.isfinite(value) and value > 0):
        raise InputError(
            f"{where}image attribute {PERIOD_ATTR!r} = {value!r} needs an elevation axis and a positive value"
        )
    out = np.zeros(len(dims))
    out[dims.index("elevation")] = float(value)
    return out


TABLE_ATTR = "range_response"  # the range response tabulated (real, centred, 1 at the peak), at TABLE_STEP_ATTR m


TABLE_STEP_ATTR = "range_response_step"


def response_table(product: Product, where: str = "") -> list | None:
    """Per axis None or (values, step): the tabulated responses (evaluate_image's response_table), from the image
    attributes TABLE_ATTR and TABLE_STEP_ATTR (array3d's range response); None without them."""
    values = product.attrs.get(TABLE_ATTR)
    if values is None:
        return None
    step = product.attrs.get(TABLE_STEP_ATTR)
    dims = list(product.dims)
    if "range" not in dims or step is None:
        raise InputError(f"{where}image attribute {TABLE_ATTR!r} needs a range axis and {TABLE_STEP_ATTR!r}")
    return [(np.asarray(values, dtype=float), float(step)) if d == "range" else None for d in dims]


# ----------------------------------------------------------------------------------------------
# Tolerances (--expect): typed model, every key optional, and the checks


@dataclasses.dataclass(frozen=True)
class AxisBounds:
    """Tolerances on one axis' metrics; None (the default) skips that check."""

    irw_ratio_max: float | None = param(default=None, gt=0, doc="largest allowed IRW / theory")
    irw_ratio_min: float | None = param(default=None, gt=0, doc="smallest allowed IRW / theory")
    pslr_db: tuple[float, ...] | None = param("decibel", default=None, doc="allowed PSLR interval [lo, hi], dB")
    islr_db: tuple[float, ...] | None = param("decibel", default=None, doc="allowed ISLR interval [lo, hi], dB")
    position_cells_max: float | None = param(default=None, ge=0, doc="largest |position error|, resolution cells")
    pslr_vs_theory_db: tuple[float, ...] | None = param(
        "decibel", default=None, doc=("allowed interval [lo, hi] of PSLR minus the target's own theoretical PSLR, dB")
    )
    islr_vs_theory_db: tuple[float, ...] | None = param(
        "decibel", default=None, doc=("allowed interval [lo, hi] of ISLR minus the target's own theoretical ISLR, dB")
    )

    def validate(self) -> None:
        for key in ("pslr_db", "islr_db", "pslr_vs_theory_db", "islr_vs_theory_db"):
            v = getattr(self, key)
            if v is not None and (len(v) != 2 or v[0] > v[1]):
                raise InputError(f"{key}: expected an interval [lo, hi] with lo <= hi, got {list(v)}")


@dataclasses.dataclass(frozen=True)
class TargetBounds(AxisBounds):
    """Per-target override; ``axes`` maps an axis name to AxisBounds for this target only."""

    axes: dict = param(default={}, doc="per-axis overrides for this target")


@dataclasses.dataclass(frozen=True)
class Expectations(AxisBounds):
    """Whole ``--expect`` file: defaults for every target and axis, then overrides.

    Precedence, most specific first: targets.<T>.axes.<a>, targets.<T>, axes.<a>, top level.
    """

    false_target_db_max: float | None = param(
        "decibel",
        default=None,
        doc=(
            "largest false-target level, dB: on 2D images the residual figure (every target's fitted response "
            "subtracted), on 3D cubes or with evaluate.residual false the guard-window figure"
        ),
    )
    v_r_error_max: float | None = param(
        "velocity",
        default=None,
        ge=0,
        doc=("largest |estimated - true| slant-range velocity of a moving target, m/s (no estimate: fail)"),
    )
    v_a_error_max: float | None = param(
        "velocity",
        default=None,
        ge=0,
        doc=("largest |estimated - true| along-track velocity of a moving target, m/s (no estimate: fail)"),
    )
    relocation_error_max: float | None = param(
        "length",
        default=None,
        ge=0,
        doc=("largest distance between a moving target's relocated and true position, m (not relocated: fail)"),
    )
    axes: dict = param(default={}, doc="per-axis overrides: {axis: AxisBounds}")
    targets: dict = param(default={}, doc="per-target overrides: {name: TargetBounds}")


METRIC_KEYS = tuple(f.name for f in dataclasses.fields(AxisBounds))


def expectations_from_mapping(mapping: dict | None, source: str = "") -> Expectations:
    """Build :class:`Expectations` from a YAML mapping; errors name ``source`` and the key."""
    from sarproc.product.config import build

    allowed = [f.name for f in dataclasses.fields(Expectations)]
    unknown = sorted(set(mapping or {}) - set(allowed))
    if unknown:  # checked here too so the message needs no section prefix
        raise InputError(
            f"{source}: unknown key(s) {', '.join(map(repr, unknown))}; allowed: {', '.join(sorted(allowed))}"
        )
    top = build(Expectations, mapping, source=source)

    def sub(cls: type, value: object, key: str) -> Any:
        if not isinstance(value, dict):
            raise InputError(f"{source}: {key}: expected a mapping, got {type(value).__name__}")
        return build(cls, value, source=source, section=key)

    axes = {str(a): sub(AxisBounds, v, f"axes.{a}") for a, v in top.axes.items()}
    targets = {}
    for name, v in top.targets.items():
        tb = sub(TargetBounds, v, f"targets.{name}")
        tb_axes = {str(a): sub(AxisBounds, w, f"targets.{name}.axes.{a}") for a, w in tb.axes.items()}
        targets[str(name)] = dataclasses.replace(tb, axes=tb_axes)
    return dataclasses.replace(top, axes=axes, targets=targets)


@dataclasses.dataclass(frozen=True)
class CheckFailure:
    target: str | None  # None for the image-wide false-target check
    axis: str | None
    metric: str
    value: float
    bound: str  # e.g. "<= 1.05" or "in [-13.76, -12.76]"

    def __str__(self) -> str:
        where = (
            "false target"
            if self.target is None
            else f"target {self.target} axis {self.axis}"
            if self.axis is not None
            else f"moving target {self.target}"
        )
        if self.metric in ("truncated", "contaminated"):
            return f"FAIL {where}: unverified, {self.bound}"
        return f"FAIL {where}: {self.metric} = {self.value:.4g}, expected {self.bound}"


def check_report(
    report: QualityReport, expect: Expectations, source: str = "", all_names: Sequence[str] | None = None
) -> list[CheckFailure]:
    """Every failed tolerance of ``report``; names in ``expect`` that match nothing raise InputError.

    ``all_names``: every target of the image when ``report`` measured a subset (their tolerances are
    then not checked, and not refused)."""
    names = list(all_names) if all_names is not None else [t.name for t in report.targets]
    _check_names(expect, report.dims, names, f"{source}: " if source else "")
    failures = []
    for t in report.targets:
        for m in t.axes:
            failures += _cut_failures(t.name, m, _axis_bounds(expect, t.name, m.axis))
    for mv in report.movers:
        failures += _mover_failures(mv, expect)
    failures += _false_target_failures(report.false_target, expect)
    return failures


def _check_names(expect: Expectations, dims: Sequence[str], names: Sequence[str], where: str) -> None:
    """InputError for an axis or target of ``expect`` that the image does not have (a typo would
    otherwise silently check nothing)."""
    for a in expect.axes:
        if a not in dims:
            raise InputError(f"{where}axes.{a}: the image has no axis {a!r} (axes: {', '.join(dims)})")
    for n, tb in expect.targets.items():
        if n not in names:
            raise InputError(f"{where}targets.{n}: the image has no target {n!r} (targets: {', '.join(names)})")
        for a in tb.axes:
            if a not in dims:
                raise InputError(f"{where}targets.{n}.axes.{a}: the image has no axis {a!r}")


def _axis_bounds(expect: Expectations, target: str, axis: str) -> AxisBounds:
    """The tolerances of ``target``'s cut along ``axis``: each key from the most specific layer that sets it
    (targets.<T>.axes.<a>, targets.<T>, axes.<a>, top level)."""
    tb = expect.targets.get(target)
    layers = [expect, expect.axes.get(axis), tb, tb.axes.get(axis) if tb else None]
    return AxisBounds(
        **{
            k: next((getattr(b, k) for b in reversed(layers) if b is not None and getattr(b, k) is not None), None)
            for k in METRIC_KEYS
        }
    )


def _cut_failures(target: str, m: AxisMetrics, bound: AxisBounds) -> list[CheckFailure]:
    """The failed tolerances of one cut: its position, then either why its lobes are unverified or each
    lobe figure out of bounds."""
    failures = _position_failures(target, m, bound)
    unverified = _unverified_failure(target, m, bound)
    if unverified is not None:
        return [*failures, unverified]
    return failures + _irw_failures(target, m, bound) + _lobe_failures(target, m, bound)


def _position_failures(target: str, m: AxisMetrics, bound: AxisBounds) -> list[CheckFailure]:
    limit = bound.position_cells_max
    if limit is not None and not abs(m.position_error_cells) <= limit:  # written to fail on NaN
        return [CheckFailure(target, m.axis, "position_error_cells", m.position_error_cells, f"|.| <= {limit:g}")]
    return []


def _unverified_failure(target: str, m: AxisMetrics, bound: AxisBounds) -> CheckFailure | None:
    """A failure when any lobe tolerance is set on a cut whose figures cannot be trusted: truncated or
    contaminated (never counted as a pass); None otherwise."""
    if not any(getattr(bound, k) is not None for k in METRIC_KEYS if k != "position_cells_max"):
        return None
    if m.truncated:  # a cut measured on a window that leaves the image
        return CheckFailure(
            target, m.axis, "truncated", math.nan, "the cut's ISLR window reaches the image edge (truncated)"
        )
    if m.contaminated_db is not None:  # a shortened window is not the contract's: its figures are reported only
        short = "" if m.shortened_nulls is None else f"; measured on +-{m.shortened_nulls:g} nulls only (shortened)"
        return CheckFailure(
            target,
            m.axis,
            "contaminated",
            m.contaminated_db,
            f"neighbours that ideal responses do not fit put "
            f"{m.contaminated_db:.1f} dB of the main-lobe energy in the ISLR window (contaminated){short}",
        )
    return None


# NaN compares False everywhere, so each test below is written to fail on NaN.


def _irw_failures(target: str, m: AxisMetrics, bound: AxisBounds) -> list[CheckFailure]:
    failures = []
    if bound.irw_ratio_max is not None and not m.irw_ratio <= bound.irw_ratio_max:
        failures.append(CheckFailure(target, m.axis, "irw_ratio", m.irw_ratio, f"<= {bound.irw_ratio_max:g}"))
    if bound.irw_ratio_min is not None and not m.irw_ratio >= bound.irw_ratio_min:
        failures.append(CheckFailure(target, m.axis, "irw_ratio", m.irw_ratio, f">= {bound.irw_ratio_min:g}"))
    return failures


def _lobe_failures(target: str, m: AxisMetrics, bound: AxisBounds) -> list[CheckFailure]:
    """PSLR and ISLR outside their intervals, then their differences from the target's theory outside theirs
    (no theory recorded: the difference is NaN and fails)."""
    failures = []
    for key in ("pslr_db", "islr_db"):
        lo_hi = getattr(bound, key)
        value = getattr(m, key)
        if lo_hi is not None and not lo_hi[0] <= value <= lo_hi[1]:
            failures.append(CheckFailure(target, m.axis, key, value, f"in [{lo_hi[0]:g}, {lo_hi[1]:g}]"))
    for key, theory in (("pslr", m.pslr_theory_db), ("islr", m.islr_theory_db)):
        lo_hi = getattr(bound, f"{key}_vs_theory_db")
        value = getattr(m, f"{key}_db") - (np.nan if theory is None else theory)
        if lo_hi is not None and not lo_hi[0] <= value <= lo_hi[1]:
            told = "none recorded" if theory is None else f"{theory:.2f} dB"
            text = f"in [{lo_hi[0]:g}, {lo_hi[1]:g}] (theory {told})"
            failures.append(CheckFailure(target, m.axis, f"{key}_vs_theory_db", value, text))
    return failures


def _mover_failures(mv: MoverReport, expect: Expectations) -> list[CheckFailure]:
    """A moving target's velocity and relocation errors over their bounds; a bound without an estimate fails."""
    failures = []
    for key, value, unit in (
        ("v_r_error", mv.v_r_error, "m/s"),
        ("v_a_error", mv.v_a_error, "m/s"),
        ("relocation_error", mv.relocation_error, "m"),
    ):
        bound = getattr(expect, f"{key}_max")
        if bound is None:
            continue
        if value is None:
            text = f"|.| <= {bound:g} {unit}; the product holds no estimate for it"
            failures.append(CheckFailure(mv.name, None, key, math.nan, text))
        elif not abs(value) <= bound:
            failures.append(CheckFailure(mv.name, None, key, value, f"|.| <= {bound:g} {unit}"))
    return failures


def _false_target_failures(false_target: FalseTarget | None, expect: Expectations) -> list[CheckFailure]:
    limit = expect.false_target_db_max
    if limit is None or false_target is None or false_target.level_db <= limit:
        return []
    return [CheckFailure(None, None, "false_target_db", false_target.level_db, f"<= {limit:g}")]
