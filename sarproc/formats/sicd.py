"""Focused 2D images to SICD (NGA.STND.0024, version 1.4.0 or 1.3.0) through NGA's sarkit, and back.

A sarproc image lies on a plane grid of the scene frame (frames.py); SICD describes such a grid as
Grid/Type PLANE with the row and column unit vectors in ECF (ImageFormAlgo OTHER); a pfa2 image that
keeps polar format's geometry (method plain, uncorrected) is written as ImageFormAlgo PFA instead:
Grid/Type RGAZIM and a PFA block (:func:`pfa_geometry`; :func:`image_formation_algo` says why by
geometry). SICD rows run along range (away from the radar) and columns along azimuth, with the grid
normal (row x col) pointing away from the Earth; for a scene left of the track that means the azimuth
axis is reversed. So the SICD pixel array is
``image.T`` with its columns flipped when needed and the SCP's carrier removed (below):
:func:`sicd_pixels` and :func:`image_from_sicd` do and undo exactly this (complex64 -> RE32F_IM32F; the
carrier phasor costs complex64 rounding, about -140 dB).

"""

from __future__ import annotations

import dataclasses
import logging
import os
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from sarproc import __version__
from sarproc.formats.geolocation import Placement, ecf_to_geodetic, utc_datetime
from sarproc.product.errors import InputError
from sarproc.product.frames import Frame, GroundLosFrame, frame_from_spec
from sarproc.product.metadata import C
from sarproc.product.model import Product

log = logging.getLogger(__name__)

SICD_VERSIONS = ("1.4.0", "1.3.0")  # 1.3.0 for readers that predate 1.4.0 (sarpy <= 2.1.1 knows up to 1.3.0)
KAPFAC = 0.88589  # -3 dB width x bandwidth of a uniformly weighted response (SICD's 0.886, sarkit's 0.8859)
MODE_TYPE = {"spotlight": "SPOTLIGHT", "stripmap": "STRIPMAP", "sliding_spotlight": "DYNAMIC STRIPMAP"}


def deferred_module(name: str) -> Any:
    """Module ``name`` put in ``sys.modules`` without running its code, which runs on the first attribute the
    module lacks (PEP 562 ``__getattr__``): importing it costs nothing until something uses it, and then it is
    the whole module, the same object. For what sarkit imports but an export or import rarely uses
    (docs/performance.md, eighth round). The module as it is where already imported, or where it cannot be
    found or is no plain source module or package (then it is imported)."""
    import importlib
    import importlib.machinery
    import importlib.util
    import sys

    if name in sys.modules:
        return sys.modules[name]
    spec = importlib.util.find_spec(name)
    if spec is None or not isinstance(spec.loader, importlib.machinery.SourceFileLoader):
        return importlib.import_module(name)
    module = importlib.util.module_from_spec(spec)

    def complete(attr: str, module: Any = module, loader: Any = spec.loader) -> Any:
        del module.__dict__["__getattr__"]  # once: the module's code then defines what it has
        try:
            loader.exec_module(module)
        except BaseException:
            sys.modules.pop(name, None)  # as a failed import leaves it: the next import tries again
            raise
        return getattr(module, attr)

    module.__dict__["__getattr__"] = complete
    sys.modules[name] = module
    parent, _, child = name.rpartition(".")
    if parent:
        setattr(sys.modules[parent], child, module)
    return module


def require_sarkit() -> None:
    """Raise InputError saying how to install sarkit when it cannot be imported.

    numpy.testing (~50-70 ms: unittest, importlib.metadata, email), which sarkit's XML helpers import for one
    rarely used search (``ElementWrapper.findall`` with keywords), is deferred to its first use."""
    try:
        deferred_module("numpy.testing")
        import sarkit  # noqa: F401
    except ImportError:
        raise InputError("SICD/CPHD need NGA's sarkit (Python >= 3.11): pip install 'sarproc[formats]'") from None


_CHECKERS = {"SICD": ("_sicd_consistency", "SicdConsistency"), "CPHD": ("_cphd_consistency", "CphdConsistency")}


def consistency_checker(kind: str) -> Any:
    """sarkit's consistency checker class for ``kind`` ('SICD' or 'CPHD'), with its module alone imported.

    ``import sarkit.verification`` imports all four checkers (CPHD, CRSD, SICD, SIDD and their readers,
    shapely; ~50 ms more than the one an export runs: docs/performance.md, eighth round). Where that package
    is not imported yet, it is deferred (:func:`deferred_module`): only the one checker's module is loaded, and
    the package's ``__init__`` runs on the first attribute it lacks, so a later ``import sarkit.verification``
    still gets every checker, the same classes. Raises InputError saying how to install sarkit (and shapely,
    which the checkers need) where it is missing."""
    import importlib
    import sys

    module, name = _CHECKERS[kind]
    package = "sarkit.verification"
    before = sys.modules.get(package)
    try:
        require_sarkit()
        deferred_module(package)
        return getattr(importlib.import_module(f"{package}.{module}"), name)
    except ImportError:
        if before is None and package in sys.modules and "__getattr__" in vars(sys.modules[package]):
            del sys.modules[package]  # as if never tried
        raise InputError(
            f"the {kind} consistency check needs NGA's sarkit with shapely (Python >= 3.11): "
            "pip install 'sarproc[formats]'"
        ) from None


def pulse_times(product: Product) -> np.ndarray:
    """Azimuth times of the pulses, s: the raw axis, or (for images) the simulator's centred PRF grid."""
    if "azimuth_time" in product.coords:
        return np.asarray(product.coords["azimuth_time"], float)
    n = len(product.aux["platform_position"])
    return (np.arange(n) - (n - 1) / 2.0) / product.radar.prf


def fit_position_poly(t: np.ndarray, ecf: np.ndarray, max_order: int = 5) -> tuple[np.ndarray, float]:
    """Least-squares polynomial (order+1, 3) of ECF positions over time; also the worst residual, m."""
    order = int(min(max_order, len(t) - 1))
    scale = max(float(np.abs(t).max()), 1e-9)
    coefs = np.polynomial.polynomial.polyfit(t / scale, ecf, order)
    coefs = coefs / scale ** np.arange(order + 1)[:, None]  # back to powers of seconds
    resid = float(np.abs(np.polynomial.polynomial.polyval(t, coefs).T - ecf).max())
    return coefs, resid


@dataclasses.dataclass(frozen=True)
class SicdGrid:
    """The image grid as SICD sees it: unit vectors (ECF), spacings, reference pixel, column flip."""

    u_row: np.ndarray
    u_col: np.ndarray
    ss_row: float
    ss_col: float
    scp_pixel: tuple[int, int]
    scp_scene: np.ndarray
    flip_cols: bool
    shape: tuple[int, int]
    carrier: tuple[float, float] = (0.0, 0.0)  # (row, col) cycles/m the product's pixels carry at the SCP

    def offsets(self) -> tuple[np.ndarray, np.ndarray]:
        """SICD image coordinates (x of each row, y of each column), m from the SCP."""
        return (
            (np.arange(self.shape[0]) - self.scp_pixel[0]) * self.ss_row,
            (np.arange(self.shape[1]) - self.scp_pixel[1]) * self.ss_col,
        )


def image_grid(product: Product, place: Placement, tol: float = 1e-3, scp_at: np.ndarray | None = None) -> SicdGrid:
    """Check the image is a plane, orthogonal, uniformly sampled grid and describe it in ECF.

    The SCP is the centre pixel, or with ``scp_at`` (a scene point) the pixel on that point (refused
    when the point is not on a pixel of the image).
    """
    if product.kind != "image" or product.dims != ("azimuth", "range"):
        raise InputError(
            f"SICD export needs a 2D image product with dims (azimuth, range), got {product.kind} {product.dims}"
        )
    frame = frame_from_spec(product.attrs["frame"])
    az, rg = (np.asarray(product.coords[d], float) for d in ("azimuth", "range"))
    for name, ax in (("azimuth", az), ("range", rg)):
        step = np.diff(ax)
        if len(ax) < 2 or not np.allclose(step, step[0], rtol=1e-9, atol=0):
            raise InputError(f"SICD export: the image's {name} axis is not uniformly sampled")
    i0, j0 = len(az) // 2, len(rg) // 2
    if scp_at is not None:
        fa, fr = (float(np.asarray(c).reshape(-1)[0]) for c in frame.from_xyz(np.asarray(scp_at, float).reshape(1, 3)))
        fi, fj = (fa - az[0]) / (az[1] - az[0]), (fr - rg[0]) / (rg[1] - rg[0])
        i0, j0 = int(round(fi)), int(round(fj))
        if abs(fi - i0) > 1e-6 or abs(fj - j0) > 1e-6 or not 0 <= i0 < len(az) or not 0 <= j0 < len(rg):
            raise InputError(
                f"SICD export: the reference point {np.round(np.asarray(scp_at, float), 3).tolist()} m "
                f"is not on a pixel of the image (pixel {fi:.3f}, {fj:.3f})"
            )
    p0 = frame.to_xyz(az[i0], rg[j0])
    d_col = frame.to_xyz(az[i0 + 1 if i0 + 1 < len(az) else i0 - 1], rg[j0]) - p0
    d_row = frame.to_xyz(az[i0], rg[j0 + 1 if j0 + 1 < len(rg) else j0 - 1]) - p0
    d_col *= 1 if i0 + 1 < len(az) else -1
    d_row *= 1 if j0 + 1 < len(rg) else -1
    # a plane grid: every corner where the two spacing vectors put it
    for i, j in ((0, 0), (0, len(rg) - 1), (len(az) - 1, 0), (len(az) - 1, len(rg) - 1)):
        err = np.linalg.norm(frame.to_xyz(az[i], rg[j]) - (p0 + (i - i0) * d_col + (j - j0) * d_row))
        if err > tol:
            raise InputError(
                f"SICD export: frame {frame.name!r} is not a plane grid ({err:.3g} m off at a corner); "
                "focus onto a planar frame (los, ground, ground_los)"
            )
    u_row, u_col = (
        place.vector_to_ecf(d_row / np.linalg.norm(d_row)),
        place.vector_to_ecf(d_col / np.linalg.norm(d_col)),
    )
    if abs(float(u_row @ u_col)) > 1e-6:
        raise InputError(
            f"SICD export: frame {frame.name!r} has skewed axes (cos = {float(u_row @ u_col):.3g}); "
            "SICD PLANE grids need orthogonal rows and columns: focus onto los, ground or ground_los"
        )
    up = place.rotation[:, 2]
    flip = float(np.cross(u_row, u_col) @ up) < 0  # SICD: row x col points away from the Earth
    col = len(az) - 1 - i0 if flip else i0
    return SicdGrid(
        u_row=u_row,
        u_col=-u_col if flip else u_col,
        ss_row=float(np.linalg.norm(d_row)),
        ss_col=float(np.linalg.norm(d_col)),
        scp_pixel=(j0, col),
        scp_scene=p0,
        flip_cols=flip,
        shape=(len(rg), len(az)),
    )


def _carrier_phasors(grid: SicdGrid) -> tuple[np.ndarray, np.ndarray]:
    """exp(-j 2 pi c x) along the rows and exp(-j 2 pi c y) along the columns (the carrier folded by the
    pixel spacing first: at pixel positions it is the same phasor, with float64 phases of at most n/2 cycles)."""
    out = []
    for c, ss, x in zip(grid.carrier, (grid.ss_row, grid.ss_col), grid.offsets()):
        cycles_per_pixel = c * ss - np.round(c * ss)
        out.append(np.exp(-2j * np.pi * cycles_per_pixel * (x / ss)).astype(np.complex64))
    return out[0], out[1]


def sicd_pixels(image: np.ndarray, grid: SicdGrid) -> np.ndarray:
    """(n_azimuth, n_range) image -> (NumRows = n_range, NumCols = n_azimuth) SICD array, complex64, with
    the carrier at the SCP (``grid.carrier``) removed."""
    out = np.asarray(image, np.complex64).T
    out = np.array(out[:, ::-1] if grid.flip_cols else out, order="C")
    if any(grid.carrier):
        ph_row, ph_col = _carrier_phasors(grid)
        out *= ph_row[:, None]
        out *= ph_col[None, :]
    return out


def image_from_sicd(pixels: np.ndarray, grid: SicdGrid) -> np.ndarray:
    """Inverse of :func:`sicd_pixels` (to complex64 rounding when a carrier was removed)."""
    pixels = np.array(pixels, np.complex64)
    if any(grid.carrier):
        ph_row, ph_col = _carrier_phasors(grid)
        pixels *= ph_row.conj()[:, None]
        pixels *= ph_col.conj()[None, :]
    return np.ascontiguousarray((pixels[:, ::-1] if grid.flip_cols else pixels).T)


def spectral_centre(pixels: np.ndarray, axis: int, ss: float) -> float:
    """Centre of the data's spectrum along ``axis``, cycles/m in [-1/(2 SS), 1/(2 SS)) (circular mean of power)."""
    power = (np.abs(np.fft.fft(pixels, axis=axis)) ** 2).sum(axis=1 - axis)
    n = len(power)
    return float(np.angle(np.sum(power * np.exp(2j * np.pi * np.arange(n) / n))) / (2 * np.pi * ss))


def local_support_offsets(tree: Any, pixels: np.ndarray, points: ArrayLike, half: int = 16) -> np.ndarray:
    """(measured - DeltaKCOAPoly) / ImpRespBW along (row, col) at SICD pixels ``points`` ((row, col) each): the
    spectral centre of the (2 half)^2 pixels about each point against the file's DeltaKCOAPoly there."""
    import sarkit.sicd as sksicd

    xml = sksicd.XmlHelper(tree)
    grid = {
        a: {k: xml.load(f"./{{*}}Grid/{{*}}{a}/{{*}}{k}") for k in ("SS", "DeltaKCOAPoly", "ImpRespBW")}
        for a in ("Row", "Col")
    }
    xy = sksicd.rowcol_to_xrowycol(tree, np.asarray(points, float))
    out = []
    for (r, c), (x, y) in zip(np.asarray(points, int), xy):
        if not (half <= r <= pixels.shape[0] - half and half <= c <= pixels.shape[1] - half):
            raise ValueError(f"pixel ({r}, {c}) is closer than {half} pixels to the edge of the image")
        win = pixels[r - half : r + half, c - half : c + half]
        row = []
        for axis, g in enumerate(grid.values()):
            d = spectral_centre(win, axis, g["SS"]) - np.polynomial.polynomial.polyval2d(x, y, g["DeltaKCOAPoly"])
            row.append(float(fold(d, g["SS"])) / g["ImpRespBW"])
        out.append(row)
    return np.array(out)


def fold(k: np.ndarray | float, ss: float) -> np.ndarray:
    """Spatial frequency k (cycles/m) folded by the sample spacing into [-1/(2 SS), 1/(2 SS))."""
    return k - np.round(np.asarray(k) * ss) / ss


@dataclasses.dataclass(frozen=True)
class SupportModel:
    """Where the spectral support is centred, in ECF: for a true grid the line of sight at the centre of
    aperture (``arp_poly``, ``time_coa``, ``f_c``), for polar format one constant ``pfa_centre`` (row, col)."""

    scp_ecf: np.ndarray
    u_row: np.ndarray
    u_col: np.ndarray
    arp_poly: np.ndarray
    time_coa: np.ndarray
    f_c: float
    pfa_centre: tuple[float, float] | None = None

    def _points(self, x: ArrayLike, y: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        x, y = np.broadcast_arrays(np.asarray(x, float), np.asarray(y, float))
        p = self.scp_ecf + x[..., None] * self.u_row + y[..., None] * self.u_col
        t = np.polynomial.polynomial.polyval2d(x, y, self.time_coa)
        arp = np.moveaxis(np.polynomial.polynomial.polyval(t, self.arp_poly), 0, -1)
        return p, arp

    def centre(self, x: np.ndarray | float, y: np.ndarray | float) -> tuple[np.ndarray, np.ndarray]:
        """Centre of support (row, col), cycles/m, at image coordinates (x, y) m from the SCP."""
        if self.pfa_centre is not None:
            shape = np.broadcast(np.asarray(x), np.asarray(y)).shape
            return np.full(shape, self.pfa_centre[0]), np.full(shape, self.pfa_centre[1])
        p, arp = self._points(x, y)
        los = p - arp
        los /= np.linalg.norm(los, axis=-1, keepdims=True)
        k = 2.0 * self.f_c / C
        return k * (los @ self.u_row), k * (los @ self.u_col)

    def phase(self, x: np.ndarray | float, y: np.ndarray | float) -> np.ndarray:
        """Phase (cycles) whose gradient along (x, y) is :meth:`centre`, 0 at the SCP: (2 f_c / c) times the
        range from the antenna at the centre of aperture (exact for a fixed centre of aperture, spotlight)."""
        if self.pfa_centre is not None:
            return self.pfa_centre[0] * np.asarray(x) + self.pfa_centre[1] * np.asarray(y)
        p, arp = self._points(x, y)
        r0 = np.linalg.norm(self.scp_ecf - np.polynomial.polynomial.polyval(self.time_coa[0, 0], self.arp_poly))
        return 2.0 * self.f_c / C * (np.linalg.norm(p - arp, axis=-1) - r0)


def carrier_at_scp(
    pixels: np.ndarray,
    grid: SicdGrid,
    model: SupportModel,
    tol: float = 0.1,
    bandwidth: tuple[float, float] = (np.inf, np.inf),
    block: int = 256,
) -> tuple[float, float]:
    """DFT frequency (row, col), cycles/m, at which the pixels (the SICD array, no carrier removed) carry the
    SCP's support.

    The geometry's phase (:meth:`SupportModel.phase`) is taken out of every pixel, so that the whole
    image's spectrum sits at one offset d from the geometry (0 for an image that keeps the carrier, as
    backprojection and pfa2 do); d is measured as the circular mean of the power spectrum and taken as 0
    within ``tol`` of the bandwidth: the centre of support is geometric, and a power-weighted mean
    strays from it by a few percent on a real scene (Gotcha: 3.5 %), so only a larger offset (an image
    formed about another carrier) is taken from the data. The carrier at the SCP is fold(centre(SCP) + d).
    Blocks of ``block`` lines keep the working memory at a few lines' worth.
    """
    from sarproc.product import fft as sfft

    x, y = grid.offsets()
    n_rows, n_cols = pixels.shape
    power_row, power_col = np.zeros(n_rows), np.zeros(n_cols)
    for j0 in range(0, n_cols, block):  # spectrum along the rows (axis 0), column blocks
        sl = slice(j0, min(j0 + block, n_cols))
        ph = model.phase(x[:, None], y[None, sl])
        ph -= np.round(ph)
        deskewed = pixels[:, sl] * np.exp(-2j * np.pi * ph).astype(np.complex64)
        power_row += (np.abs(sfft.fft(deskewed, axis=0, workers=-1)) ** 2).sum(axis=1)
    for i0 in range(0, n_rows, block):  # spectrum along the columns (axis 1), row blocks
        sl = slice(i0, min(i0 + block, n_rows))
        ph = model.phase(x[sl, None], y[None, :])
        ph -= np.round(ph)
        deskewed = pixels[sl, :] * np.exp(-2j * np.pi * ph).astype(np.complex64)
        power_col += (np.abs(sfft.fft(deskewed, axis=1, workers=-1)) ** 2).sum(axis=0)
    k_scp = model.centre(0.0, 0.0)
    out = []
    for power, ss, bw, k in zip((power_row, power_col), (grid.ss_row, grid.ss_col), bandwidth, k_scp):
        n = len(power)
        d = float(np.angle(np.sum(power * np.exp(2j * np.pi * np.arange(n) / n))) / (2 * np.pi * ss))
        if abs(d) <= tol * bw:
            d = 0.0
        else:
            log.info(
                "SICD export: the image's spectrum sits %.4g cycles/m (%.0f %% of the bandwidth) off the "
                "geometry's carrier: taken as the carrier it was formed about",
                d,
                100 * d / bw,
            )
        out.append(float(fold(float(k) + d, ss)))
    return out[0], out[1]


def delta_kcoa_poly(
    model: SupportModel, grid: SicdGrid, kctr: tuple[float, float], order: int = 3, n: int = 12
) -> tuple[np.ndarray, np.ndarray, float]:
    """DeltaKCOAPoly (row, col) of SICD, 2D polynomials in (x, y) m: the centre of support minus KCtr, fitted
    on n x n points over the image; also the worst misfit, cycles/m."""
    if model.pfa_centre is not None:
        return (np.array([[model.pfa_centre[0] - kctr[0]]]), np.array([[model.pfa_centre[1] - kctr[1]]]), 0.0)
    x, y = grid.offsets()
    xs, ys = np.meshgrid(np.linspace(x[0], x[-1], n), np.linspace(y[0], y[-1], n), indexing="ij")
    k_row, k_col = model.centre(xs, ys)
    sx, sy = max(abs(x[0]), abs(x[-1]), 1e-9), max(abs(y[0]), abs(y[-1]), 1e-9)
    vander = np.polynomial.polynomial.polyvander2d(xs.ravel() / sx, ys.ravel() / sy, [order, order])
    scale = (sx ** -np.arange(order + 1))[:, None] * (sy ** -np.arange(order + 1))[None, :]
    polys, worst = [], 0.0
    for k, kc in ((k_row, kctr[0]), (k_col, kctr[1])):
        coef, *_ = np.linalg.lstsq(vander, (k - kc).ravel(), rcond=None)
        poly = coef.reshape(order + 1, order + 1) * scale
        worst = max(worst, float(np.abs(np.polynomial.polynomial.polyval2d(xs, ys, poly) - (k - kc)).max()))
        polys.append(poly)
    return polys[0], polys[1], worst


def delta_k_bounds(poly: np.ndarray, grid: SicdGrid, bw: float, ss: float) -> tuple[float, float]:
    """DeltaK1, DeltaK2: DeltaKCOAPoly at the image's corners -+ half the bandwidth (as SICD's checkers
    compute them), or -+ 1/(2 SS) when the support wraps around the folding frequency."""
    x, y = grid.offsets()
    xs, ys = np.array([x[0], x[0], x[-1], x[-1]]), np.array([y[0], y[-1], y[0], y[-1]])
    dk = np.polynomial.polynomial.polyval2d(xs, ys, poly)
    lo, hi = float(dk.min() - bw / 2), float(dk.max() + bw / 2)
    if lo < -0.5 / ss or hi > 0.5 / ss:
        lo, hi = -0.5 / ss, 0.5 / ss
    return lo, hi


def formed_by_pfa(product: Product) -> bool:
    """True for images of ``pfa2`` (its last history step, with the k-space rectangle it recorded)."""
    words = str(product.history[-1].get("command", "")).split() if product.history else []
    if words[:1] == ["sarproc"]:  # the CLI records its command line: "sarproc pfa2 raw.h5 ..."
        words = words[1:]
    return words[:1] == ["pfa2"] and "support_rectangle" in product.attrs


def polar_format_geometry(product: Product) -> bool:
    """True for a pfa2 image whose pixels keep polar format's geometry (``method: plain`` without
    ``correct_distortion``): a point appears where the planar-wavefront model about the scene centre puts
    it, which is what SICD's PFA projection inverts. The two-step mosaic and the corrected plain image
    lie on the true ground grid instead."""
    if not formed_by_pfa(product):
        return False
    params = product.history[-1].get("parameters") or {}
    return product.attrs.get("method") == "plain" and not params.get("correct_distortion", False)


def image_formation_algo(product: Product) -> str:
    """SICD ImageFormAlgo written by default: PFA for pfa2 images in polar-format geometry, else OTHER.

    ImageFormAlgo PFA means Grid/Type RGAZIM and SICD's PFA projection (R/Rdot from PolarAngPoly and
    SpatialFreqSFPoly: the planar-wavefront model about the SCP). Measured on configs/nie2016_small.yaml
    (1.5 km range, docs/formats.md): in pfa2's ``plain`` image the targets' peaks lie up to 15 m from
    their truth (wavefront curvature) and the PFA projection of the peaks lands within 4 cm of it; pfa2's
    two-step mosaic is on the true ground grid, where the PLANE grid (OTHER) puts every target within
    1 cm and the PFA projection would miss by up to 24 m. Backprojected (and every other) image is on a
    true plane grid: OTHER. RGAZCOMP names another algorithm (range/azimuth compression with a linear
    azimuth spatial frequency in slow time, RgAzComp/KazPoly) that no sarproc chain implements.
    """
    return "PFA" if polar_format_geometry(product) else "OTHER"


def polarization(product: Product) -> tuple[str, str]:
    """(TxPolarization, TxRcvPolarization) of SICD: the product's radar.polarization, else UNKNOWN."""
    pol = getattr(product.radar, "polarization", None)
    if not pol:
        return "UNKNOWN", "UNKNOWN"
    return pol.split(":")[0], pol


@dataclasses.dataclass(frozen=True)
class PfaGeometry:
    """The PFA block of SICD (its sign conventions), derived from the track and pfa2's k-space rectangle.

    Spatial frequency of a pulse at RF frequency f: k = (2 f / c) P(u_los), u_los the unit vector from the
    ARP to the SCP and P the projection onto the focus plane (here the image plane: pfa2 formats its data
    in the ground plane of the image). Krg = k . u_row, Kaz = k . u_col (cycles/m); polar angle
    theta = atan2(Kaz, Krg) and KSF(theta) = |P(u_los)|, so |k| = (2 f / c) KSF(theta) (sarkit's
    r_rdot_from_rgazim_pfa and _compute_pfa_min_max_fx use exactly these).
    """

    fpn: np.ndarray
    ipn: np.ndarray
    polar_ang_ref_time: float
    polar_ang_poly: np.ndarray
    spatial_freq_sf_poly: np.ndarray
    krg: tuple[float, float]
    kaz: tuple[float, float]
    fit_residual: tuple[float, float]  # worst misfit of PolarAngPoly (rad) and SpatialFreqSFPoly


def _polyfit_scaled(x: np.ndarray, y: np.ndarray, order: int) -> np.ndarray:
    scale = max(float(np.abs(x).max()), 1e-12)
    coefs = np.polynomial.polynomial.polyfit(x / scale, y, order)
    return coefs / scale ** np.arange(order + 1)


def pfa_geometry(product: Product, grid: SicdGrid, frame: Frame, t_rel: np.ndarray, t_coa: float) -> PfaGeometry:
    """PFA parameters of a pfa2 image (scene-frame vectors; the caller maps them to ECF)."""
    pos = np.asarray(product.aux["platform_position"], float)
    e_row = frame.to_xyz(0.0, 1.0) - frame.to_xyz(0.0, 0.0)  # along range (rows)
    e_az = frame.to_xyz(1.0, 0.0) - frame.to_xyz(0.0, 0.0)  # along azimuth
    e_row, e_az = e_row / np.linalg.norm(e_row), e_az / np.linalg.norm(e_az)
    e_col = -e_az if grid.flip_cols else e_az
    normal = np.cross(e_row, e_col)  # away from the Earth (image_grid)
    los = grid.scp_scene[None, :] - pos
    los /= np.linalg.norm(los, axis=1, keepdims=True)
    c_rg, c_az = los @ e_row, los @ e_col
    theta = np.arctan2(c_az, c_rg)
    ksf = np.hypot(c_rg, c_az)
    order_t = int(min(5, len(t_rel) - 1))
    ang_poly = _polyfit_scaled(t_rel - t_coa, theta, order_t)  # about t_coa, shifted below
    # reference time: where the projected line of sight lies along the rows (theta = 0), nearest the COA
    t_ref = 0.0
    for _ in range(50):
        val = np.polynomial.polynomial.polyval(t_ref, ang_poly)
        der = np.polynomial.polynomial.polyval(t_ref, np.polynomial.polynomial.polyder(ang_poly))
        step = val / der if der != 0 else 0.0
        t_ref -= step
        if abs(step) < 1e-12:
            break
    # the same polynomial in powers of (time from collect start)
    shifted = np.polynomial.polynomial.Polynomial(ang_poly)(np.polynomial.polynomial.Polynomial([-t_coa, 1.0]))
    ang_poly_abs = np.asarray(shifted.coef, float)
    ang_poly_abs[0] -= float(np.polynomial.polynomial.polyval(t_ref + t_coa, ang_poly_abs))  # exactly 0 at t_ref
    order_k = int(min(4, len(theta) - 1))
    ksf_poly = _polyfit_scaled(theta, ksf, order_k) if np.ptp(theta) > 0 else np.array([float(ksf.mean())])
    resid_t = float(np.abs(np.polynomial.polynomial.polyval(t_rel, ang_poly_abs) - theta).max())
    resid_k = float(np.abs(np.polynomial.polynomial.polyval(theta, ksf_poly) - ksf).max())
    # k-space rectangle of pfa2 (rad/m along e_a, e_r, line of sight towards the antenna): sample range
    # widened by half a step each side (span n dk, the width the theoretical IRW stands for)
    ka0, dka, n_ka, kr0, dkr, n_kr = (float(v) for v in product.attrs["support_rectangle"])
    ka = np.array([ka0 - dka / 2, ka0 + (n_ka - 0.5) * dka])
    kr = np.array([kr0 - dkr / 2, kr0 + (n_kr - 0.5) * dkr])
    two_pi = 2 * np.pi
    krg = np.sort(-kr / two_pi)  # e_row is pfa2's e_r
    kaz = np.sort(-ka * float(e_col @ e_az) / two_pi)
    return PfaGeometry(
        fpn=normal,
        ipn=normal,
        polar_ang_ref_time=float(t_ref + t_coa),
        polar_ang_poly=ang_poly_abs,
        spatial_freq_sf_poly=ksf_poly,
        krg=(float(krg[0]), float(krg[1])),
        kaz=(float(kaz[0]), float(kaz[1])),
        fit_residual=(resid_t, resid_k),
    )


def _formation_and_grid(product: Product, place: Placement, image_formation: str | None) -> tuple[str, SicdGrid, bool]:
    """The ImageFormAlgo to write (OTHER or PFA; None: chosen from the product) and the image's SICD grid.

    Returns (algorithm, grid, auto); an automatic PFA falls back to OTHER, with a warning, where PFA's SCP
    (the point pfa2 formatted the phase history about) cannot be placed on the grid."""
    auto = image_formation is None
    algo = image_formation_algo(product) if image_formation is None else image_formation
    if algo not in ("OTHER", "PFA"):
        raise InputError(f"SICD export: ImageFormAlgo {algo!r} is not one of OTHER, PFA")
    if algo == "PFA" and not formed_by_pfa(product):
        raise InputError("SICD export: ImageFormAlgo PFA needs an image of pfa2 (its recorded k-space rectangle)")
    grid = image_grid(product, place)
    if algo == "PFA":
        frame = frame_from_spec(product.attrs["frame"])
        assert isinstance(frame, GroundLosFrame)  # formed_by_pfa: pfa2 images are in its ground_los frame
        try:
            grid = image_grid(product, place, scp_at=frame.origin)
        except InputError as exc:
            if not auto:
                raise
            log.warning("%s: written as ImageFormAlgo OTHER (PFA needs the SCP there)", exc)
            algo = "OTHER"
    if algo == "PFA" and not polar_format_geometry(product):
        log.warning(
            "SICD export: ImageFormAlgo PFA for a pfa2 image on the true ground grid (two-step or "
            "distortion-corrected): SICD's PFA projection then misplaces pixels by the wavefront curvature"
        )
    return algo, grid, auto


def _time_coa_poly(product: Product, place: Placement, grid: SicdGrid, t_coa: float) -> np.ndarray:
    """SICD's TimeCOAPoly: one centre of aperture for a spotlight image; beam-limited, it moves with the
    along-track position (speed v along +x) from the aperture centre at the scene origin (the SCP is the
    image's centre pixel, scp_scene[0] along track)."""
    r = product.radar
    if r.mode == "spotlight":
        return np.array([[t_coa]])
    vx = place.rotation[:, 0] * r.velocity
    return np.array(
        [
            [t_coa + float(grid.scp_scene[0]) / r.velocity, float(grid.u_col @ vx) / r.velocity**2],
            [float(grid.u_row @ vx) / r.velocity**2, 0.0],
        ]
    )


def _pfa_or_other(
    product: Product, grid: SicdGrid, algo: str, auto: bool, t_rel: np.ndarray, t_coa: float
) -> tuple[str, PfaGeometry | None]:
    """The PFA block's geometry for a PFA export (None for OTHER); an automatic PFA whose polar angle or scale
    factor is not a smooth polynomial of the track is written as OTHER (the SCP on the formatting point is as
    good for PLANE)."""
    if algo != "PFA":
        return algo, None
    pfa = pfa_geometry(product, grid, frame_from_spec(product.attrs["frame"]), t_rel, t_coa)
    if pfa.fit_residual[0] > 1e-6 or pfa.fit_residual[1] > 1e-6:
        msg = (
            f"SICD export: the polar angle / scale factor are not smooth polynomials of the track (residuals "
            f"{pfa.fit_residual[0]:.3g} rad, {pfa.fit_residual[1]:.3g})"
        )
        if not auto:
            raise InputError(msg)
        log.warning("%s: written as ImageFormAlgo OTHER", msg)
        return "OTHER", None
    return algo, pfa


def _grid_dims(
    product: Product,
    grid: SicdGrid,
    scp_ecf: np.ndarray,
    arp_poly: np.ndarray,
    time_coa: np.ndarray,
    pfa: PfaGeometry | None,
) -> tuple[SicdGrid, dict[str, dict[str, Any]]]:
    """SICD's Grid/Row and Grid/Col blocks and the grid with the carrier its pixels lose on export.

    The centre of support (KCtr + DeltaKCOAPoly) comes from the geometry: polar format's processed rectangle
    (one support for every pixel), else the line of sight at each pixel's centre of aperture."""
    irw_az, irw_rg = (float(w) for w in product.attrs["theoretical_irw"])
    irw = {"Row": irw_rg, "Col": irw_az}
    bw = {name: KAPFAC / irw[name] for name in irw}
    model = SupportModel(
        scp_ecf=scp_ecf,
        u_row=grid.u_row,
        u_col=grid.u_col,
        arp_poly=arp_poly,
        time_coa=time_coa,
        f_c=product.radar.carrier_frequency,
        pfa_centre=None if pfa is None else (float(np.mean(pfa.krg)), float(np.mean(pfa.kaz))),
    )
    k_row, k_col = model.centre(0.0, 0.0)
    kctr = (float(k_row), float(k_col))
    poly_row, poly_col, misfit = delta_kcoa_poly(model, grid, kctr)
    if misfit > 1e-3 * min(bw.values()):
        raise InputError(
            f"SICD export: the centre of support is not a smooth polynomial over the image "
            f"(misfit {misfit:.3g} cycles/m)"
        )
    carrier = carrier_at_scp(sicd_pixels(product.data, grid), grid, model, bandwidth=(bw["Row"], bw["Col"]))
    grid = dataclasses.replace(grid, carrier=carrier)
    dims = {}
    for name, u, ss, k, poly in (
        ("Row", grid.u_row, grid.ss_row, kctr[0], poly_row),
        ("Col", grid.u_col, grid.ss_col, kctr[1], poly_col),
    ):
        lo, hi = delta_k_bounds(poly, grid, bw[name], ss)
        dims[name] = {
            "UVectECF": u,
            "SS": ss,
            "ImpRespWid": irw[name],
            "Sgn": -1,
            "ImpRespBW": bw[name],
            "KCtr": k,
            "DeltaK1": lo,
            "DeltaK2": hi,
            "DeltaKCOAPoly": poly,
            "WgtType": {"WindowName": "UNIFORM"},
        }
    return grid, dims


def _collection_blocks(product: Product, place: Placement, t: np.ndarray, algo: str) -> dict[str, Any]:
    """SICD's CollectionInfo, ImageCreation, Timeline, RadarCollection and ImageFormation blocks: who made the
    image, when the pulses were sent, the waveform and what was processed."""
    r = product.radar
    duration = len(t) / r.prf  # the last pulse's interval included (IPPEnd = n - 1)
    f_lo, f_hi = r.carrier_frequency - r.bandwidth / 2, r.carrier_frequency + r.bandwidth / 2
    tx_pol, txrcv_pol = polarization(product)
    waveform = {
        "TxPulseLength": r.pulse_duration,
        "TxRFBandwidth": r.bandwidth,
        "TxFreqStart": f_lo,
        "TxFMRate": r.chirp_rate,
        "RcvDemodType": "CHIRP",
        "ADCSampleRate": r.range_sampling_rate,
        "RcvFMRate": 0.0,
        "@index": 1,
    }
    ipp = {"TStart": 0.0, "TEnd": duration, "IPPStart": 0, "IPPEnd": len(t) - 1, "IPPPoly": np.array([0.0, r.prf])}
    return {
        "CollectionInfo": {
            "CollectorName": "sarproc simulator",
            "CoreName": f"sarproc_{product.kind}",
            "CollectType": "MONOSTATIC",
            "RadarMode": {"ModeType": MODE_TYPE.get(r.mode, "SPOTLIGHT")},
            "Classification": "UNCLASSIFIED",
        },
        "ImageCreation": {
            "Application": f"sarproc {__version__}",
            "DateTime": utc_datetime(np.datetime64("now", "us")),
            "Profile": "sarproc export-sicd",
        },
        "Timeline": {
            "CollectStart": utc_datetime(place.datetime64(float(t[0]))),
            "CollectDuration": duration,
            "IPP": {"@size": 1, "Set": [{**ipp, "@index": 1}]},
        },
        "RadarCollection": {
            "TxFrequency": {"Min": f_lo, "Max": f_hi},
            "Waveform": {"@size": 1, "WFParameters": [waveform]},
            "TxPolarization": tx_pol,
            "RcvChannels": {"@size": 1, "ChanParameters": [{"TxRcvPolarization": txrcv_pol, "@index": 1}]},
        },
        "ImageFormation": {
            "RcvChanProc": {"NumChanProc": 1, "ChanIndex": [1]},
            "TxRcvPolarizationProc": txrcv_pol,
            "TStartProc": 0.0,
            "TEndProc": duration,
            "TxFrequencyProc": {"MinProc": f_lo, "MaxProc": f_hi},
            "ImageFormAlgo": algo,
            "STBeamComp": "NO",
            "ImageBeamComp": "NO",
            "AzAutofocus": "NO",
            "RgAutofocus": "NO",
        },
    }


def _project_corners(root: Any, tree: Any, n_rows: int, n_cols: int, height: float) -> None:
    """GeoData/ImageCorners and RadarCollection/Area: the corner pixels projected (R/Rdot, SICD vol. 3) onto
    the SCP's height above the ellipsoid (the area is optional in SICD; sarpy's validity check counts a
    missing one as invalid)."""
    import sarkit.sicd as sksicd

    corners_rc = np.array([(0, 0), (0, n_cols - 1), (n_rows - 1, n_cols - 1), (n_rows - 1, 0)])
    ground, _, ok = sksicd.image_to_constant_hae_surface(tree, sksicd.rowcol_to_xrowycol(tree, corners_rc), height)
    if not ok:
        raise InputError("SICD export: the image corners do not project onto the ground")
    corners_llh = ecf_to_geodetic(ground)
    root["GeoData"]["ImageCorners"] = np.degrees(corners_llh[:, :2])
    root["RadarCollection"]["Area"] = {"Corner": np.column_stack([np.degrees(corners_llh[:, :2]), corners_llh[:, 2]])}


def sicd_xml(
    product: Product, place: Placement, *, image_formation: str | None = None, version: str = "1.4.0"
) -> tuple[object, SicdGrid]:
    """The SICD XML tree of an image product (lxml ElementTree) and its grid (with the carrier the pixels
    lose on export: :func:`sicd_pixels`)."""
    import lxml.etree
    import sarkit.sicd as sksicd

    if version not in SICD_VERSIONS:
        raise InputError(f"SICD export: version {version!r} is not one of {', '.join(SICD_VERSIONS)}")
    algo, grid, auto = _formation_and_grid(product, place, image_formation)
    t = pulse_times(product)
    t_rel = t - t[0]  # SICD times run from CollectStart
    arp_poly, resid = fit_position_poly(t_rel, place.to_ecf(product.aux["platform_position"]))
    if resid > 0.01:
        raise InputError(f"SICD export: the platform track is not a smooth polynomial (residual {resid:.3g} m)")
    scp_ecf = place.to_ecf(grid.scp_scene)
    scp_llh = ecf_to_geodetic(scp_ecf)
    t_coa = float(-t[0])  # aperture centre, where the spotlight COA is
    time_coa = _time_coa_poly(product, place, grid, t_coa)
    algo, pfa = _pfa_or_other(product, grid, algo, auto, t_rel, t_coa)
    grid, dims = _grid_dims(product, grid, scp_ecf, arp_poly, time_coa, pfa)
    n_rows, n_cols = grid.shape
    blocks = _collection_blocks(product, place, t, algo)

    ns = f"urn:SICD:{version}"
    root = sksicd.ElementWrapper(lxml.etree.Element(f"{{{ns}}}SICD"))
    root["CollectionInfo"] = blocks["CollectionInfo"]
    root["ImageCreation"] = blocks["ImageCreation"]
    root["ImageData"] = {
        "PixelType": "RE32F_IM32F",
        "NumRows": n_rows,
        "NumCols": n_cols,
        "FirstRow": 0,
        "FirstCol": 0,
        "FullImage": {"NumRows": n_rows, "NumCols": n_cols},
        "SCPPixel": np.array(grid.scp_pixel),
    }
    root["GeoData"] = {
        "EarthModel": "WGS_84",
        "SCP": {"ECF": scp_ecf, "LLH": np.array([*np.degrees(scp_llh[:2]), scp_llh[2]])},
        "ImageCorners": np.zeros((4, 2)),
    }  # projected below, once the geometry is complete
    slant = abs(float(np.cross(grid.u_row, grid.u_col) @ place.rotation[:, 2])) < 0.999
    root["Grid"] = {
        "ImagePlane": "SLANT" if slant else "GROUND",
        "Type": "RGAZIM" if pfa is not None else "PLANE",
        "TimeCOAPoly": time_coa,
        "Row": dims["Row"],
        "Col": dims["Col"],
    }
    root["Timeline"] = blocks["Timeline"]
    root["Position"] = {"ARPPoly": arp_poly}
    root["RadarCollection"] = blocks["RadarCollection"]
    root["ImageFormation"] = blocks["ImageFormation"]
    if pfa is not None:  # schema order: the PFA block comes last (SCPCOA is put before it below)
        root["PFA"] = {
            "FPN": place.vector_to_ecf(pfa.fpn),
            "IPN": place.vector_to_ecf(pfa.ipn),
            "PolarAngRefTime": pfa.polar_ang_ref_time,
            "PolarAngPoly": pfa.polar_ang_poly,
            "SpatialFreqSFPoly": pfa.spatial_freq_sf_poly,
            "Krg1": pfa.krg[0],
            "Krg2": pfa.krg[1],
            "Kaz1": pfa.kaz[0],
            "Kaz2": pfa.kaz[1],
        }
    assert root.elem is not None
    tree = root.elem.getroottree()
    # SCPCOA belongs after ImageFormation (schema order)
    tree.getroot().find(f"{{{ns}}}ImageFormation").addnext(sksicd.compute_scp_coa(tree))
    _project_corners(root, tree, n_rows, n_cols, float(scp_llh[2]))
    return tree, grid


def write_sicd(
    path: str | os.PathLike,
    product: Product,
    place: Placement,
    *,
    image_formation: str | None = None,
    version: str = "1.4.0",
) -> SicdGrid:
    """Write ``product`` (a 2D image) as a SICD NITF file (SICD ``version``) at ``path`` (atomically)."""
    require_sarkit()
    import sarkit.sicd as sksicd

    from sarproc.product.io import atomic_path

    tree, grid = sicd_xml(product, place, image_formation=image_formation, version=version)
    meta = sksicd.NitfMetadata(
        xmltree=tree,
        file_header_part=sksicd.NitfFileHeaderPart(
            ostaid="sarproc", ftitle="sarproc SICD", security=sksicd.NitfSecurityFields(clas="U")
        ),
        im_subheader_part=sksicd.NitfImSubheaderPart(
            isorce="sarproc simulation", security=sksicd.NitfSecurityFields(clas="U")
        ),
        de_subheader_part=sksicd.NitfDeSubheaderPart(security=sksicd.NitfSecurityFields(clas="U")),
    )
    with atomic_path(path) as tmp, open(tmp, "wb") as fh, sksicd.NitfWriter(fh, meta) as writer:
        writer.write_image(sicd_pixels(product.data, grid))
    return grid


def read_sicd(path: str | os.PathLike) -> tuple[Any, np.ndarray]:
    """(xml tree, pixels (NumRows, NumCols) complex64) of a SICD NITF file."""
    require_sarkit()
    import sarkit.sicd as sksicd

    with open(path, "rb") as fh, sksicd.NitfReader(fh) as reader:
        return reader.metadata.xmltree, reader.read_image()


def consistency_summary(con: Any) -> dict:
    """What a sarkit ConsistencyChecker found: failed checks split into errors ('Need') and warnings ('Want')."""
    import contextlib
    import io

    text = io.StringIO()
    with contextlib.redirect_stdout(text):
        con.print_result(fail_detail=True, color=False, include_passed_asserts=False)
    errors: list[str] = []
    warnings: list[str] = []
    for name, result in con.failures().items():
        severities = {d["severity"] for d in result["details"] if not d["passed"]}
        (errors if "Error" in severities else warnings).append(name)
    return {
        "passed": not errors,
        "checks": len(con.all()),
        "n_passed": len(con.passes()),
        "n_skipped": len(con.skips()),
        "errors": sorted(errors),
        "warnings": sorted(warnings),
        "report": text.getvalue(),
    }


# numpy's print threshold while sarkit's checks run: more elements print as the first and last 3
CHECK_PRINT_THRESHOLD = 64


def run_checks(con: Any) -> None:
    """``con.check()``: every check of a sarkit ConsistencyChecker, with arrays summarised in its messages.

    A precondition that does not apply (a "Skip") records the values of every name on its line, ``repr``
    included, even though only failures are reported: on the demo CPHD this formatted 12 PVP arrays of 600
    records in full, 1.4 of the check's 1.55 s (docs/performance.md, twelfth round). Under numpy's print
    threshold (:data:`CHECK_PRINT_THRESHOLD`) an array of more elements prints as its first and last 3, as
    numpy prints any array of more than 1000. The checks, and what passes, fails and is skipped, are the same.
    """
    with np.printoptions(threshold=CHECK_PRINT_THRESHOLD):
        con.check()


def check_sicd(path: str | os.PathLike) -> dict:
    """Run sarkit's SicdConsistency (schema, NITF headers, every metadata relation) on a SICD file."""
    with open(path, "rb") as fh:
        con = consistency_checker("SICD").from_file(fh)
        run_checks(con)
    return consistency_summary(con)


def sarpy_check(path: str | os.PathLike) -> dict:
    """Run NGA's older reader's validity check (``sarpy.consistency.sicd_consistency``: schema, NITF headers,
    SICDType.is_valid) on a SICD file: its verdict and the messages it logged, split by level.

    sarpy (``pip install sarpy``, a test dependency) knows SICD up to 1.3.0: a 1.4.0 file gets two errors
    for its unknown namespace (write ``--sicd-version 1.3.0`` for it)."""
    try:
        import sarpy
        from sarpy.consistency import sicd_consistency
    except ImportError:
        raise InputError("the sarpy check needs NGA's sarpy: pip install sarpy") from None
    import warnings

    class Collect(logging.Handler):
        def __init__(self) -> None:
            super().__init__(logging.INFO)
            self.records: list[logging.LogRecord] = []

        def emit(self, record: logging.LogRecord) -> None:
            self.records.append(record)

    handler = Collect()
    logger = logging.getLogger("validation")
    old_level, old_propagate = logger.level, logger.propagate
    logger.addHandler(handler)
    logger.setLevel(logging.INFO)
    logger.propagate = False
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", DeprecationWarning)  # sarpy 2.x deprecates itself for sarkit
            valid = bool(sicd_consistency.check_file(str(path)))
    finally:
        logger.removeHandler(handler)
        logger.setLevel(old_level)
        logger.propagate = old_propagate

    def messages(level: int) -> list[str]:
        return [r.getMessage().strip() for r in handler.records if r.levelno == level and r.getMessage().strip()]

    return {
        "sarpy": sarpy.__version__,
        "valid": valid,
        "errors": messages(logging.ERROR),
        "warnings": messages(logging.WARNING),
        "info": messages(logging.INFO),
    }
