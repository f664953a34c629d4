"""Point-target quality metrics of focused 2D/3D SAR images (ARCHITECTURE.md, "Metric definitions").

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
"""

from __future__ import annotations

import dataclasses
import math
from typing import Optional

import numpy as np
import scipy.fft

from sarproc.product.config import param
from sarproc.product.errors import InputError

SINC_IRW_FACTOR = 0.886  # -3 dB width of sinc^2 times the bandwidth (0.8859 exactly)


@dataclasses.dataclass(frozen=True)
class EvaluateParams:
    """Parameters of the ``evaluate:`` section (all dimensionless)."""

    search_cells: float = param(default=3.0, gt=0, doc="peak search half-window around each truth, resolution cells")
    guard_cells: float = param(default=20.0, gt=0, doc=(
        "half-size of the box around each target excluded from the false-target search, resolution cells; "
        "20 keeps the along-axis sinc side lobes of a target (about -37 dB there) out of the false-target level"))
    upsample: int = param(default=64, ge=16, le=4096, doc="samples per image sample in the 1-D cuts (>= 16)")
    islr_nulls: float = param(default=10.0, gt=1, doc="ISLR/PSLR window half-width, in nulls (1/B)")
    margin_nulls: float = param(default=6.0, ge=1, doc="chip half-width beyond the ISLR window, nulls")
    irw_factor: float = param(default=SINC_IRW_FACTOR, gt=0, doc=(
        "IRW_theory * B; 0.886 for unweighted processing (about 1.30 when theory is a Hamming-weighted IRW)"))


@dataclasses.dataclass(frozen=True)
class AxisMetrics:
    """Metrics of one target along one image axis (lengths in the axis' units)."""

    axis: str
    irw: float                  # -3 dB width of the main lobe
    irw_theory: float
    irw_ratio: float            # irw / irw_theory
    pslr_db: float              # highest side lobe within the ISLR window / peak; -inf if none
    islr_db: float              # side-lobe energy in the window / main-lobe energy
    mainlobe_width: float       # distance between the first nulls (local minima)
    position: float             # refined peak position
    truth: float
    position_error: float       # position - truth
    position_error_cells: float  # position_error / irw_theory
    band_center: float          # spectral centre of the chip, cycles per axis unit


@dataclasses.dataclass(frozen=True)
class TargetReport:
    name: str
    peak_amplitude: float       # |interpolated peak|, image units
    peak_phase: float           # arg of the interpolated peak, rad
    peak_index: tuple[int, ...]  # strongest pixel in the search window
    chip_clipped: bool          # the chip left the image and was zero-padded
    axes: tuple[AxisMetrics, ...]

    def axis(self, name: str) -> AxisMetrics:
        for m in self.axes:
            if m.axis == name:
                return m
        raise KeyError(name)


@dataclasses.dataclass(frozen=True)
class FalseTarget:
    level_db: float             # refined peak of the response / strongest true target peak
    position: dict              # {dim: axis-unit position of the refined peak}
    pixel_level_db: float       # same with the raw pixel magnitude
    reference_target: str       # name of the strongest true target


@dataclasses.dataclass(frozen=True)
class QualityReport:
    dims: tuple[str, ...]
    targets: tuple[TargetReport, ...]
    false_target: Optional[FalseTarget]   # None: no pixel lies outside every target neighbourhood
    params: EvaluateParams

    def target(self, name: str) -> TargetReport:
        for t in self.targets:
            if t.name == name:
                return t
        raise KeyError(name)

    def to_dict(self) -> dict:
        """JSON-able dict: non-finite floats become None (JSON has no NaN/inf)."""
        return _jsonable(dataclasses.asdict(self))


def _jsonable(v):
    if isinstance(v, dict):
        return {str(k): _jsonable(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_jsonable(x) for x in v]
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
    start: float     # coordinate of sample 0
    step: float      # signed spacing, axis units
    size: int
    irw: float       # theoretical IRW, axis units
    null: float      # null spacing 1/B in samples

    def to_index(self, x):
        return (np.asarray(x, dtype=float) - self.start) / self.step

    def to_coord(self, i):
        return self.start + np.asarray(i, dtype=float) * self.step

    def cells_to_samples(self, cells: float) -> int:
        return int(math.ceil(cells * self.irw / abs(self.step)))

    def nulls_to_samples(self, nulls: float) -> int:
        return int(math.ceil(nulls * self.null))


def _make_axes(shape, dims, coords, theoretical_irw, irw_factor) -> list[_Axis]:
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
        if null <= 1.0:
            raise InputError(
                f"axis {name!r}: spacing {abs(step):.4g} is not finer than the null spacing 1/B = "
                f"{null * abs(step):.4g} (theoretical IRW {irw[a]:.4g}); the image is undersampled for this theory")
        axes.append(_Axis(name, float(c[0]), float(step), int(n), float(irw[a]), float(null)))
    return axes


def window_slices(center, half, shape):
    """Slices of the box ``center +- half`` (integer samples) clipped to ``shape``."""
    out = []
    for c, h, n in zip(center, half, shape):
        lo = min(max(0, int(c) - int(h)), int(n))
        out.append(slice(lo, max(lo, min(int(n), int(c) + int(h) + 1))))  # empty, never negative
    return tuple(out)


def extract_chip(data: np.ndarray, center, half) -> tuple[np.ndarray, bool]:
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

    def __init__(self, data, center, half):
        self.data, self.clipped = extract_chip(data, center, half)
        self.origin = np.array([int(c) - int(h) for c, h in zip(center, half)])
        self.shape = self.data.shape
        spec = scipy.fft.fftn(self.data, workers=-1)
        power = np.abs(spec) ** 2
        self.spec = spec
        self.freqs = []       # unwrapped frequency of each bin, cycles per sample
        self.centers = []     # band centre, cycles per sample
        for a, n in enumerate(self.shape):
            marginal = power.sum(axis=tuple(b for b in range(power.ndim) if b != a))
            m = np.arange(n)
            # Circular centroid of the marginal power: robust to a band wrapped across Nyquist.
            c = int(round(np.angle(np.sum(marginal * np.exp(2j * np.pi * m / n))) * n / (2 * np.pi)))
            # Relabel bin m to the frequency congruent to it within c +- n/2 (band-centred).
            k = (m - c + n // 2) % n - n // 2 + c
            self.freqs.append(k / n)
            self.centers.append(c / n)

    def values(self, positions) -> np.ndarray:
        """Interpolated values on the outer product of per-axis position arrays (image indices)."""
        grids = [np.atleast_1d(np.asarray(p, dtype=float)) - o for p, o in zip(positions, self.origin)]
        out = self.spec
        # Contract the axes with the fewest output points first (cheapest order).
        for a in sorted(range(len(grids)), key=lambda a: grids[a].size):
            kernel = np.exp(2j * np.pi * np.outer(grids[a], self.freqs[a]))
            out = np.moveaxis(np.tensordot(kernel, out, axes=([1], [a])), 0, a)
        return out / self.data.size

    def refine_peak(self, start, tol=1e-4) -> tuple[np.ndarray, complex]:
        """Local maximum of |f| near ``start`` (image indices) by zooming 9-point grids."""
        pos = np.asarray(start, dtype=float)
        half = 1.0
        best = None
        while True:
            grids = [p + np.linspace(-half, half, 9) for p in pos]
            vals = self.values(grids)
            idx = np.unravel_index(np.argmax(np.abs(vals)), vals.shape)
            pos = np.array([g[i] for g, i in zip(grids, idx)])
            best = vals[idx]
            if half / 4 < tol:
                return pos, complex(best)
            half /= 4.0


def _cut_metrics(p: np.ndarray, step: float, center: int, window: float) -> tuple[float, float, float, float]:
    """IRW, PSLR, ISLR and null-to-null width from a normalised power cut.

    ``p`` is |f|^2 / peak^2 sampled every ``step`` samples with the peak at index ``center``;
    ``window`` is the ISLR half-window in samples. Returns (irw, pslr_db, islr_db, mainlobe) with
    widths in samples.
    """
    n = p.size
    right = p[center:]
    left = p[center::-1]

    def half_power(side):
        below = np.flatnonzero(side < 0.5)
        if below.size == 0:
            return np.nan, side.size - 1
        i = below[0]
        # Linear interpolation of the crossing between samples i-1 (>= 0.5) and i (< 0.5).
        frac = (side[i - 1] - 0.5) / (side[i - 1] - side[i])
        return (i - 1 + frac), i

    def first_null(side, start):
        # First local minimum beyond the -3 dB point: the end of the main lobe.
        d = np.diff(side[start:])
        rising = np.flatnonzero(d > 0)
        return start + rising[0] if rising.size else side.size - 1

    hr, ir = half_power(right)
    hl, il = half_power(left)
    irw = (hr + hl) * step
    nr, nl = first_null(right, ir), first_null(left, il)
    mainlobe = (nr + nl) * step
    lo, hi = center - nl, center + nr
    w = int(math.floor(window / step))
    a, b = max(0, center - w), min(n - 1, center + w)
    main = p[lo:hi + 1].sum()
    side = np.concatenate([p[a:lo], p[hi + 1:b + 1]])
    pslr = 10 * np.log10(side.max()) if side.size and side.max() > 0 else -np.inf
    islr = 10 * np.log10(side.sum() / main) if side.size and side.sum() > 0 else -np.inf
    return float(irw), float(pslr), float(islr), float(mainlobe)


# ----------------------------------------------------------------------------------------------
# Public entry points


def evaluate_image(data, dims, coords, theoretical_irw, truth, names=None,
                   params: EvaluateParams | None = None) -> QualityReport:
    """Measure every target of a 2D (azimuth, range) or 3D (elevation, azimuth, range) image.

    data: complex image, shape ``tuple(len(coords[d]) for d in dims)``; dims: axis names;
    coords: {dim: 1-D uniformly spaced coordinates} (or a sequence in dims order), axis units;
    theoretical_irw: expected IRW per axis (dims order, axis units); truth: (n_targets, ndim)
    true positions (axis units, dims order); names: n_targets labels. Raises InputError.
    """
    params = params or EvaluateParams()
    data = np.asarray(data)
    if data.ndim not in (1, 2, 3):
        raise InputError(f"image must have 1 to 3 axes, got shape {data.shape}")
    if not np.all(np.isfinite(data)):
        raise InputError(f"image contains {int(np.count_nonzero(~np.isfinite(data)))} NaN or Inf value(s)")
    dims = tuple(dims)
    axes = _make_axes(data.shape, dims, coords, theoretical_irw, params.irw_factor)
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

    mag = np.abs(data)
    half = [ax.nulls_to_samples(params.islr_nulls + params.margin_nulls) for ax in axes]
    reports, peaks = [], []
    for name, t in zip(names, truth):
        idx = np.array([ax.to_index(x) for ax, x in zip(axes, t)])
        for ax, i, x in zip(axes, idx, t):
            if not (-0.5 <= i <= ax.size - 0.5):
                lo, hi = sorted((ax.start, float(ax.to_coord(ax.size - 1))))
                raise InputError(f"target {name!r}: {ax.name} = {x:.6g} lies outside the image extent [{lo:.6g}, {hi:.6g}]")
        center = np.rint(idx).astype(int)
        win = window_slices(center, [ax.cells_to_samples(params.search_cells) for ax in axes], data.shape)
        local = mag[win]
        k = np.unravel_index(np.argmax(local), local.shape)
        peak_index = tuple(int(s.start + i) for s, i in zip(win, k))
        reports.append(_measure(data, axes, peak_index, half, t, name, params))
        peaks.append(peak_index)
    false = _false_target(data, mag, axes, truth, peaks, reports, half, params)
    return QualityReport(dims=dims, targets=tuple(reports), false_target=false, params=params)


def _measure(data, axes, peak_index, half, truth, name, params) -> TargetReport:
    chip = _Chip(data, peak_index, half)
    pos, value = chip.refine_peak(peak_index)
    peak2 = abs(value) ** 2
    if peak2 == 0:
        pos = np.full(len(axes), np.nan)
    metrics = []
    for a, ax in enumerate(axes):
        window = params.islr_nulls * ax.null  # samples
        m = int(math.ceil((window + 2 * ax.null) * params.upsample))
        offsets = np.arange(-m, m + 1) / params.upsample
        grids = [np.array([p]) for p in pos]
        grids[a] = pos[a] + offsets
        if peak2 > 0:
            p = np.abs(chip.values(grids).reshape(-1)) ** 2 / peak2
            irw, pslr, islr, main = _cut_metrics(p, 1.0 / params.upsample, m, window)
        else:  # no response at all around the truth: every metric is undefined (fails any --expect check)
            irw = pslr = islr = main = np.nan
        x = float(ax.to_coord(pos[a]))
        err = x - float(truth[a])
        metrics.append(AxisMetrics(
            axis=ax.name, irw=irw * abs(ax.step), irw_theory=ax.irw, irw_ratio=irw * abs(ax.step) / ax.irw,
            pslr_db=pslr, islr_db=islr, mainlobe_width=main * abs(ax.step), position=x, truth=float(truth[a]),
            position_error=err, position_error_cells=err / ax.irw, band_center=chip.centers[a] / ax.step))
    return TargetReport(name=name, peak_amplitude=abs(value), peak_phase=float(np.angle(value)),
                        peak_index=tuple(peak_index), chip_clipped=chip.clipped, axes=tuple(metrics))


def _false_target(data, mag, axes, truth, peaks, reports, half, params) -> Optional[FalseTarget]:
    outside = np.ones(data.shape, dtype=bool)
    guard = [ax.cells_to_samples(params.guard_cells) for ax in axes]
    for t, pk in zip(truth, peaks):
        for c in (np.rint([ax.to_index(x) for ax, x in zip(axes, t)]).astype(int), pk):
            outside[window_slices(c, guard, data.shape)] = False
    if not outside.any():
        return None
    ref = max(reports, key=lambda r: r.peak_amplitude)
    masked = np.where(outside, mag, -1.0)
    k = np.unravel_index(np.argmax(masked), masked.shape)
    pixel = float(mag[k])
    if pixel == 0.0 or ref.peak_amplitude == 0.0:
        return FalseTarget(level_db=-np.inf, position={ax.name: float(ax.to_coord(i)) for ax, i in zip(axes, k)},
                           pixel_level_db=-np.inf, reference_target=ref.name)
    # Refine like a target so the level is free of the pixel-grid scalloping loss.
    chip = _Chip(data, k, half)
    pos, value = chip.refine_peak(k)
    return FalseTarget(
        level_db=float(20 * np.log10(max(abs(value), pixel) / ref.peak_amplitude)),
        position={ax.name: float(ax.to_coord(p)) for ax, p in zip(axes, pos)},
        pixel_level_db=float(20 * np.log10(pixel / ref.peak_amplitude)), reference_target=ref.name)


def target_patch(data, dims, coords, theoretical_irw, target: TargetReport, pair=(0, 1),
                 half_width_nulls: float = 4.0, upsample: int = 8,
                 params: EvaluateParams | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
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
    offsets = []
    for a in pair:
        m = int(math.ceil(half_width_nulls * axes[a].null * upsample))
        off = np.arange(-m, m + 1) / upsample
        grids[a] = pos[a] + off
        offsets.append(off * axes[a].step)
    vals = chip.values(grids)
    vals = vals.reshape(len(offsets[0]), len(offsets[1])) if pair[0] < pair[1] else \
        vals.reshape(len(offsets[1]), len(offsets[0])).T
    peak = chip.values([np.array([p]) for p in pos]).reshape(())
    return offsets[0], offsets[1], vals / peak


def evaluate_product(product, params: EvaluateParams | None = None, source: str = "") -> QualityReport:
    """Evaluate an ``image``/``image3d`` :class:`sarproc.product.model.Product` against its targets table.

    Truth per target is the targets field named like each dim; theory is
    ``product.attrs['theoretical_irw']``. ``source`` (the file name) prefixes error messages.
    """
    where = f"{source}: " if source else ""
    irw = product.attrs.get("theoretical_irw")
    if irw is None:
        raise InputError(f"{where}image attribute 'theoretical_irw' is missing (expected one IRW per axis {product.dims})")
    fields = product.targets.dtype.names or ()
    missing = [d for d in product.dims if d not in fields]
    if missing:
        raise InputError(f"{where}targets table has no field(s) {missing} for the image axes {product.dims}")
    if len(product.targets) == 0:
        raise InputError(f"{where}targets table is empty; nothing to evaluate")
    names = [n.decode() if isinstance(n, bytes) else str(n) for n in product.targets["name"]]
    truth = np.stack([product.targets[d].astype(float) for d in product.dims], axis=1)
    try:
        return evaluate_image(product.data, product.dims, product.coords, irw, truth, names, params)
    except InputError as exc:
        raise InputError(f"{where}{exc}") from None


# ----------------------------------------------------------------------------------------------
# Tolerances (--expect): typed model, every key optional, and the checks


@dataclasses.dataclass(frozen=True)
class AxisBounds:
    """Tolerances on one axis' metrics; None (the default) skips that check."""

    irw_ratio_max: Optional[float] = param(default=None, gt=0, doc="largest allowed IRW / theory")
    irw_ratio_min: Optional[float] = param(default=None, gt=0, doc="smallest allowed IRW / theory")
    pslr_db: Optional[tuple[float, ...]] = param("decibel", default=None, doc="allowed PSLR interval [lo, hi], dB")
    islr_db: Optional[tuple[float, ...]] = param("decibel", default=None, doc="allowed ISLR interval [lo, hi], dB")
    position_cells_max: Optional[float] = param(default=None, ge=0, doc="largest |position error|, resolution cells")

    def validate(self):
        for key in ("pslr_db", "islr_db"):
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

    false_target_db_max: Optional[float] = param("decibel", default=None, doc="largest false-target level, dB")
    axes: dict = param(default={}, doc="per-axis overrides: {axis: AxisBounds}")
    targets: dict = param(default={}, doc="per-target overrides: {name: TargetBounds}")


METRIC_KEYS = tuple(f.name for f in dataclasses.fields(AxisBounds))


def expectations_from_mapping(mapping: dict | None, source: str = "") -> Expectations:
    """Build :class:`Expectations` from a YAML mapping; errors name ``source`` and the key."""
    from sarproc.product.config import build

    allowed = [f.name for f in dataclasses.fields(Expectations)]
    unknown = sorted(set(mapping or {}) - set(allowed))
    if unknown:  # checked here too so the message needs no section prefix
        raise InputError(f"{source}: unknown key(s) {', '.join(map(repr, unknown))}; allowed: {', '.join(sorted(allowed))}")
    top = build(Expectations, mapping, source=source)

    def sub(cls, value, key):
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
    target: Optional[str]   # None for the image-wide false-target check
    axis: Optional[str]
    metric: str
    value: float
    bound: str              # e.g. "<= 1.05" or "in [-13.76, -12.76]"

    def __str__(self):
        where = "false target" if self.target is None else f"target {self.target} axis {self.axis}"
        return f"FAIL {where}: {self.metric} = {self.value:.4g}, expected {self.bound}"


def check_report(report: QualityReport, expect: Expectations, source: str = "") -> list[CheckFailure]:
    """Every failed tolerance of ``report``; names in ``expect`` that match nothing raise InputError."""
    where = f"{source}: " if source else ""
    names = [t.name for t in report.targets]
    for a in expect.axes:
        if a not in report.dims:
            raise InputError(f"{where}axes.{a}: the image has no axis {a!r} (axes: {', '.join(report.dims)})")
    for n, tb in expect.targets.items():
        if n not in names:
            raise InputError(f"{where}targets.{n}: the image has no target {n!r} (targets: {', '.join(names)})")
        for a in tb.axes:
            if a not in report.dims:
                raise InputError(f"{where}targets.{n}.axes.{a}: the image has no axis {a!r}")

    failures = []
    for t in report.targets:
        tb = expect.targets.get(t.name)
        for m in t.axes:
            layers = [expect, expect.axes.get(m.axis), tb, tb.axes.get(m.axis) if tb else None]
            bound = {k: next((getattr(b, k) for b in reversed(layers) if b is not None and getattr(b, k) is not None),
                             None) for k in METRIC_KEYS}
            fail = lambda metric, value, text: failures.append(CheckFailure(t.name, m.axis, metric, value, text))
            # NaN compares False everywhere, so each test is written to fail on NaN.
            if bound["irw_ratio_max"] is not None and not m.irw_ratio <= bound["irw_ratio_max"]:
                fail("irw_ratio", m.irw_ratio, f"<= {bound['irw_ratio_max']:g}")
            if bound["irw_ratio_min"] is not None and not m.irw_ratio >= bound["irw_ratio_min"]:
                fail("irw_ratio", m.irw_ratio, f">= {bound['irw_ratio_min']:g}")
            for key in ("pslr_db", "islr_db"):
                lo_hi = bound[key]
                value = getattr(m, key)
                if lo_hi is not None and not lo_hi[0] <= value <= lo_hi[1]:
                    fail(key, value, f"in [{lo_hi[0]:g}, {lo_hi[1]:g}]")
            if bound["position_cells_max"] is not None and not abs(m.position_error_cells) <= bound["position_cells_max"]:
                fail("position_error_cells", m.position_error_cells, f"|.| <= {bound['position_cells_max']:g}")
    if expect.false_target_db_max is not None and report.false_target is not None:
        if not report.false_target.level_db <= expect.false_target_db_max:
            failures.append(CheckFailure(None, None, "false_target_db", report.false_target.level_db,
                                         f"<= {expect.false_target_db_max:g}"))
    return failures
