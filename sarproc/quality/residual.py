"""False targets under the side-lobe floor: the residual image, every target's fitted response subtracted.

Moved out of :mod:`sarproc.quality.metrics` unchanged (issue 20); metrics imports this module, so the few
names taken from metrics are imported where they are used.
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import itertools
import math
import threading
from collections.abc import Callable, Iterator, Sequence
from typing import TYPE_CHECKING

import numpy as np

from sarproc.quality import residual_aot, threads
from sarproc.quality.blas import single_blas
from sarproc.quality.lstsq import NormalEquations, least_squares
from sarproc.quality.threads import ordered_map

if TYPE_CHECKING:
    from concurrent.futures import Executor

    import numpy.typing as npt

    from sarproc.quality.metrics import EvaluateParams, FalseTarget, TargetReport, _Axis

# Residual image: every target's fitted response subtracted, so false targets are searched under the
# targets' side-lobe floor instead of outside a guard window.
#
# Each target's response is modelled as a band-limited function on its own spectral support (the
# parallelogram / parallelepiped of :func:`principal_directions`, centred on its band centre f_c) whose
# spectrum is a short Fourier series over the support: sum over orders n of C_n exp(j pi n . u), u the
# support's dual coordinates in (-1/2, 1/2) per ridge. The response of order n is then a product of
# half-null-shifted sincs, prod_a sinc(c_a + n_a / 2) (c the ridge coordinates in nulls), so the spectral
# weight and phase (antenna taper, a quadratic phase left by the processor, a Hamming window) are fitted by
# linear complex least squares on the samples around each peak, and the model is exact and cheap to
# evaluate anywhere in the image (its side lobes across the whole image are subtracted with it).


@dataclasses.dataclass(frozen=True)
class ResidualFloor:
    """The residual image's figures: the image minus every target's fitted response."""

    floor_db: float  # strongest residual pixel in the targets' guard windows, main lobes excluded,
    # relative to the strongest target's peak: how deep the subtraction reaches
    rms_db: float  # residual RMS outside the main lobes, same reference
    exclusion_cells: float  # main-lobe half-box left out of both searches, resolution cells
    orders: int  # spectral-weight orders per target model
    # targets whose fitted model leaves over MISFIT_DB of their peak inside its fit box (a defocused
    # response is not the one the model fits), or whose response it is known not to describe (a fan of side
    # lobes): those boxes stay out of the search; named here
    misfit_targets: tuple[str, ...] = ()
    # per misfit target with a measured peak: what its model leaves and where (:class:`Misfit`)
    misfits: tuple[Misfit, ...] = ()


@dataclasses.dataclass(frozen=True)
class Misfit:
    """Where a misfit target's model leaves the most of its peak inside the box it was fitted on: its response
    there is not the ideal one (defocus, or energy the processing put beside it: docs/cli.md, session 43 row 7c)."""

    name: str
    level_db: float  # the strongest residual pixel in its fit box, relative to the target's own peak
    offset: dict  # {dim: that pixel's offset from the target's peak, axis units}
    samples: dict  # {dim: the same offset, image samples}


# A model leaving this much of its target's peak (dB) inside the box it was fitted on does not fit it.
MISFIT_DB = -30.0
# ... unless what it leaves there is a ghost: a point response, the target's own model moved to that residual's
# peak (amplitude fitted), leaves at most GHOST_LEFT_DB of the residual's energy over that peak's main lobe box
# (+-GHOST_NULLS of the model's nulls per axis), and once up to GHOST_TRIES such ghosts are taken out the box is
# under MISFIT_DB. Such a target is no misfit (its box stays in the false-target search: the ghost is found and
# listed there). Measured on the session 42 trial's reconstruct chain (docs/cli.md, session 43 rows 7c and 11):
# a -30 dB ghost 8 samples beside M3 leaves -25.5 dB; what the processing put beside S (a train along its range
# ridge, -27.9 dB of its peak) -7.0 dB, M1's -8.2 dB, M3's own residue -2.4 dB: not point responses.
GHOST_LEFT_DB = -13.0
GHOST_NULLS = 1.0
GHOST_TRIES = 3

# The false-target list (every ghost, not only the strongest): a local maximum of the residual outside the
# main lobes is listed when its pixel stands LIST_MARGIN_DB over the residual floor. The floor is the
# strongest residual pixel in the guard windows, where the subtraction errors are largest, so a clean
# image's residual elsewhere rarely passes it: measured, the strongest clean residual outside the main lobes
# stands 0.1-0.6 dB over the floor (demo, bp_stripmap, paper scenes 000, 002, 003; docs/product.md), and
# 1 dB still lists a ghost 1.5 dB over the floor (the test's -50 dB ghost over a -52.4 dB floor).
LIST_MARGIN_DB = 1.0
# at most this many entries, strongest first; the number beyond is reported
LIST_CAP = 10
# A ghost inside a target's guard window would be that window's strongest residual pixel, i.e. the floor
# itself, and never stand LIST_MARGIN_DB over it. So the floor is taken once every local maximum standing
# PEEL_MARGIN_DB over all the guard pixels outside its own main lobe and side-lobe envelope is set aside
# (:func:`_floor_beside_ghosts`). 3 dB, not LIST_MARGIN_DB: in noise, the strongest of many pixels stands d dB
# over the next with probability exp(-(10^(d/10) - 1) ln N) for N independent pixels (the spacing of the
# two largest exponential powers is exponential, the largest about ln N times the mean): 1 dB over 10^4
# pixels 0.09, 3 dB 1e-4.
PEEL_MARGIN_DB = 3.0
# A ghost is not modelled, so its own side lobes stay in the residual: a maximum under a stronger entry's
# sinc envelope 1/(pi |c|) per ridge (c its ridge coordinates from that entry, in nulls, on the frame of the
# entry's nearest target's model) times this allowance is that entry's side lobe, not listed. 2 (6 dB)
# covers pixel scalloping and a ghost's ridges a little off its neighbour's; a -30 dB ghost's range side lobes
# 3.5 nulls out (-20.8 dB under it, exactly the envelope) were listed as ghosts without it.
SIDE_LOBE_ALLOWANCE = 2.0
# A target's far ridge bends off the straight line through its peak (the wavefront's curvature: campaign scene
# 20's T1 0.56 range nulls at 88 azimuth nulls out; scene 12's T2, 9 % lit, 1.0-1.23 of its own range nulls at
# 20-24 of its azimuth nulls), so the chain of maxima its model leaves there leaves the +-1-null band of
# :meth:`_Residues.on_a_chain`. The chain is followed from that band outwards: a maximum within 1 null across and
# RIDGE_STEP_NULLS along of a link, farther out than it, is a link, out to RIDGE_BEND_NULLS across the straight
# ridge (a ridge's maxima stand 1 null apart along it; 3 nulls: three times the largest bend measured).
RIDGE_STEP_NULLS = 2.0
RIDGE_BEND_NULLS = 3.0
# A model that misses its target's main lobe skirt (a rect beam under Hamming: campaign scene 14's T2 leaves
# -57.1 to -57.6 dB at 4-5 samples about its peak, inside the main lobe box where no ghost is searched) leaves
# the skirt of that misfit just outside the box (T2's (+7, +4) samples, -57.5 dB, its mirror -62.5). A maximum
# inside a target's fit box (+-fit_nulls of its model's nulls on its ridges, widened as its main lobe measured)
# that does not stand PEEL_MARGIN_DB over the strongest residual in that target's main lobe box is the misfit's
# skirt (:meth:`_Residues.in_a_misfit`), not a ghost.


@dataclasses.dataclass(frozen=True)
class ListedFalseTarget:
    """One false target of the list: a local maximum of the residual above its threshold."""

    level_db: float  # refined peak, relative to the strongest target's peak (as FalseTarget's)
    pixel_level_db: float  # its pixel, same reference
    position: dict  # {dim: refined peak, axis units (the frame's coordinates, metres for its axes)}
    index: dict  # {dim: refined peak, image samples}
    nearest_target: str  # the measured target whose peak is nearest, in resolution cells
    nearest_cells: float  # distance to that peak, resolution cells of the image's theory (root sum of squares)


@dataclasses.dataclass(frozen=True)
class FalseTargetList:
    """Every false target the residual shows, not only the strongest: local maxima outside the main lobes
    whose pixel stands ``margin_db`` over the residual floor, strongest pixel first (the order the report's
    ``false_target`` is chosen by, so the first entry is that figure), at most ``cap`` of them; a maximum
    within +-exclusion_cells of a stronger one, or under its side-lobe envelope (:data:`SIDE_LOBE_ALLOWANCE`),
    is that one's response and not listed; nor is a link of a chain of like maxima along a target's ridge, the
    residue of its model (so the single false target, the strongest residual pixel, may be left out)."""

    threshold_db: float  # floor_db + margin_db, relative to the strongest target's peak
    margin_db: float
    cap: int
    entries: tuple[ListedFalseTarget, ...]
    beyond: int  # maxima above the threshold left out by the cap
    # maxima above the threshold left out as links of a chain along a target's ridge (the residue of its
    # model: none stands PEEL_MARGIN_DB over the others there), not ghosts
    on_ridges: int = 0
    # maxima above the threshold left out as the skirt of a target's model misfit: inside the box that model
    # was fitted on, not PEEL_MARGIN_DB over what it leaves on the target's own main lobe box, not ghosts
    in_misfits: int = 0


@dataclasses.dataclass(frozen=True)
class FitStart:
    """A target's response as found in the image, where its model's fit (:func:`fit_response_models`)
    starts."""

    position: np.ndarray  # refined peak, image indices (ndim,)
    ridges: np.ndarray  # side-lobe ridge directions V (rows, :func:`principal_directions`)
    band_centre: np.ndarray  # the band's centre f_c, cycles/sample (ndim,)
    value: complex  # interpolated peak value; 0: no response, no model fitted
    nulls: np.ndarray | None = None  # its own null spacing, samples per axis (its theory's); None: the image's


@dataclasses.dataclass(frozen=True)
class ResponseModel:
    """A target's fitted response model (:func:`fit_response_models`): a band-limited response on its
    spectral support, sum over orders n of coef_n prod_a sinc(c_a + n_a / 2) (c the ridge coordinates in
    nulls, :func:`_ridge_frame`) times a carrier at its band centre and spatial chirp."""

    position: np.ndarray  # peak, image indices (ndim,): the origin of the ridge coordinates and carrier
    ridges: np.ndarray  # side-lobe ridge directions V (rows)
    nulls: np.ndarray  # null spacing along each ridge (the support's widths), samples (ndim,)
    band_centre: np.ndarray  # carrier f_c, cycles/sample (ndim,)
    orders: np.ndarray  # spectral orders n (K, ndim), :func:`spectral_orders`
    coef: np.ndarray  # complex amplitude of each order (K,)
    chirp: np.ndarray  # spatial chirp K, symmetric (ndim, ndim), cycles/sample^2
    kappa: np.ndarray | None = None  # keystone, relative width slopes (ndim - 1,) (:func:`_strip_factors`); None: none
    # the range edges' bow (2D): the support's range band shifted by curvature * (u_az^2 - 1/12) range bands at
    # azimuth band coordinate u_az (:class:`_BowColumns`); 0: straight edges
    curvature: float = 0.0
    # the ridge coordinates' second-order terms (2D), nulls per sample^2: c_a += x^T warp[a] x (x the offset from
    # the peak, samples; :func:`_fit_warp`): each pulse's wavefront is a circle about the platform, so the azimuth
    # ridge bends away in range by |x|^2 / 2R, and the look angles' chirps differ; None: none
    warp: np.ndarray | None = None
    # the carrier's third-order phase (2D), cycles/sample^3: 2 pi (t0 x0^3 + t1 x0^2 x1 + t2 x0 x1^2 + t3 x1^3) (x
    # the offset from the peak; :func:`_fit_cubic`): the wavefront's next term after the chirp, fitted on sheared
    # supports only; None: none
    cubic: np.ndarray | None = None


@functools.cache
def spectral_orders(ndim: int, max_order: int, max_total: int) -> np.ndarray:
    """Orders n (ndim integers in -max_order..max_order, sum |n_a| <= max_total) of the response basis."""
    grid = itertools.product(range(-max_order, max_order + 1), repeat=ndim)
    return np.array([n for n in grid if sum(abs(k) for k in n) <= max_total], dtype=int)


# The orders' cap on sum |n_a| in 2D: max_order + 1 (a taper on one axis times a linear phase on the other), and
# at least 4 from two orders on, so that the product of both axes' Hamming cosines (orders 0, +-2 on each: the
# window's spectrum is their outer product, 0.23^2 = 0.053 at the (+-2, +-2) corners against 0.54^2 = 0.29 at the
# centre) is in the basis. Without the corners the least squares cannot represent a 2D Hamming response: on the
# analytic response (a rectangle's, sampled 0.45 nulls apart on +-6 nulls) 21 orders leave -42.7 dB at (2, 2)
# nulls, 25 none (-296 dB); on configs/bp_hamming.yaml's O alone the residual floor is -49.26 dB with 21 (3 m from
# O, on the diagonal), -68.55 dB with 25 (docs/product.md, "A window on both axes"). Four orders (a Gaussian
# beam under Hamming) already hold (+-2, +-2); their full grid (81 against 57) bought nothing measured
# (tests/quality/test_tapered_ridges.py's pair -51.78 -> -51.66 dB, lone target -52.18 -> -52.28) at 1.4-1.9 x
# the evaluate time, so their cap stays max_order + 1.
HAMMING_CORNER_TOTAL = 4


def residual_model_orders(ndim: int, max_order: int) -> np.ndarray:
    """The residual image's response-model orders (:func:`spectral_orders`) for ``max_order`` per axis: in 2D the
    sum |n_a| capped at max_order + 1, or at :data:`HAMMING_CORNER_TOTAL` from two orders on (the corners of a
    window applied on both axes); in 3D at max_order."""
    if ndim != 2:
        return spectral_orders(ndim, max_order, max_order)
    cap = max_order + 1 if max_order < 2 else max(max_order + 1, HAMMING_CORNER_TOTAL)
    return spectral_orders(ndim, max_order, cap)


def _ridge_frame(position: npt.ArrayLike, V: npt.ArrayLike, nulls: npt.ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """(A, p): ridge coordinates in nulls are A @ (x - p) for image indices x. A is kept per (V, nulls) bytes
    (:data:`_FRAMES`): a model's frame is asked for at every evaluation of it and every bound of its envelope
    (002 small plain: 4935 times, 40 us each for numpy's inverse of a 2 x 2 matrix), and the same inputs give
    the same bits."""
    V, nulls = np.asarray(V, dtype=float), np.asarray(nulls, dtype=float)
    key = (V.shape, V.tobytes(), nulls.tobytes())
    A = _FRAMES.get(key)
    if A is None:
        A = np.linalg.inv(V.T) / nulls[:, None]
        if len(_FRAMES) >= FRAME_CACHE:
            _FRAMES.clear()
        _FRAMES[key] = A
    return A.copy(), np.asarray(position, dtype=float)


FRAME_CACHE = 4096  # ridge frames kept (:func:`_ridge_frame`); then forgotten all at once
_FRAMES: dict[tuple, np.ndarray] = {}


def _shifted_sincs(c: np.ndarray, max_order: int) -> list[np.ndarray]:
    """sinc(c + n/2) for n = -max_order..max_order (list), from one sin/cos pair of pi c."""
    s, co = np.sin(np.pi * c), np.cos(np.pi * c)
    out = []
    for n in range(-max_order, max_order + 1):
        # sin(pi (c + n/2)): n even -> +-sin(pi c), n odd -> +-cos(pi c)
        num = (s if n % 2 == 0 else co) * (1.0 if (n % 4) in (0, 1) else -1.0)
        den = np.pi * (c + n / 2.0)
        small = np.abs(den) < 1e-9
        out.append(np.where(small, 1.0, num / np.where(small, 1.0, den)))
    return out


def _chirp_pairs(ndim: int) -> list[tuple[int, int]]:
    return [(a, b) for a in range(ndim) for b in range(a, ndim)]


def _chirp_phase(x: Sequence[np.ndarray] | np.ndarray, K: np.ndarray) -> np.ndarray:
    """pi x^T K x for offsets x ((ndim, N) or broadcastable per-axis arrays), K symmetric (cycles/sample^2)."""
    ndim = len(x)
    zero = np.zeros(np.broadcast_shapes(*[np.shape(v) for v in x]))
    return np.pi * sum(
        ((1.0 if a == b else 2.0) * K[a, b] * x[a] * x[b] for a, b in _chirp_pairs(ndim) if K[a, b] != 0.0), zero
    )


KEYSTONE_STRIPS = 32  # range strips of a keystoned support (far lobe phase error pi c kappa / strips)
KEYSTONE_REACH = 100.0  # nulls out to which the strips keep that error under 0.15 rad


def _strip_factors(c: Sequence[np.ndarray], m: int, kappa: np.ndarray | None) -> list[list[np.ndarray]]:
    """Per strip, per axis, the 2m+1 order factors (one array (2m+1, *shape of c_a) per axis) of a support
    whose widths along the axes before the last grow linearly with the last axis' band coordinate u (width
    1 + kappa_a u: a keystone, the azimuth band of a wide-band radar scaling with range frequency). The
    support is cut into KEYSTONE_STRIPS strips along u, each a rectangle with its own widths, so each
    strip's response is exact; with kappa None (or 0) this is the single rectangle, prod_a sinc(c_a + n/2).
    The strip count is :data:`KEYSTONE_STRIPS` (:func:`_strip_count`)."""
    if kappa is None or not np.any(kappa):
        return [[np.stack(_shifted_sincs(ca, m)) for ca in c]]
    ndim = len(c)
    n_strips = _strip_count(kappa)
    width = 1.0 / n_strips
    u0 = 0.5 * width - 0.5
    half = (np.arange(-m, m + 1) / 2.0).reshape((-1,) + (1,) * np.ndim(c[0]))
    # Each strip's factors from the previous one's by complex rotations (strips are equally spaced in u),
    # so the trigonometry is done once per axis, not once per strip; orders stacked along a first axis.
    shifted = [np.asarray(ca, dtype=float)[None] + half for ca in c]
    rot, step, denom, centre = [], [], [], []
    for a in range(ndim - 1):
        x = shifted[a]
        rot.append(np.exp(1j * np.pi * (1.0 + kappa[a] * u0) * x))  # exp(j pi w_s x), strip 0
        step.append(np.exp(1j * np.pi * kappa[a] * width * x))
        small = np.abs(x) < 1e-9
        centre.append(small)
        denom.append(np.pi * np.where(small, 1.0, x))
    x = shifted[-1]
    last_sinc = width * np.sinc(width * x)
    last_rot = np.exp(2j * np.pi * u0 * x)
    last_step = np.exp(2j * np.pi * width * x)
    out = []
    for s in range(n_strips):
        u = u0 + s * width
        per_axis = []
        for a in range(ndim - 1):
            w = 1.0 + kappa[a] * u
            # w sinc(w x) = sin(pi w x) / (pi x), and w at x = 0
            per_axis.append(np.where(centre[a], w, rot[a].imag / denom[a]))
            rot[a] *= step[a]
        per_axis.append(last_sinc * last_rot)
        last_rot = last_rot * last_step
        out.append(per_axis)
    return out


def _strip_count(kappa: np.ndarray) -> int:
    """Strips of a keystoned support (:func:`_strip_factors`): :data:`KEYSTONE_STRIPS` whatever kappa, so
    that the model is smooth in kappa (a count growing with |kappa| made it jump, and the fits' derivatives
    and their end with it); every path but the separable one evaluates the strip sum in closed form, at a
    cost that does not depend on the count."""
    return KEYSTONE_STRIPS


def _keystoned(kappa: np.ndarray | None) -> bool:
    """Whether a fitted keystone matters over the image: its far-lobe phase error with the rectangle,
    pi c kappa, reaches 0.15 rad within :data:`KEYSTONE_REACH` nulls (the strips' own tolerance). Below
    that the model is evaluated over the image as the rectangle, on its cheap paths."""
    return kappa is not None and math.pi * KEYSTONE_REACH * float(np.max(np.abs(kappa))) >= 0.15


def _keystone_product(xs: Sequence[np.ndarray], kappa: np.ndarray) -> np.ndarray:
    """The strip sum of :func:`_strip_factors` for one order per axis, in closed form: ``xs`` the shifted
    coordinates c_a + n_a / 2 per axis (broadcastable arrays), returns sum_s prod_a factor_a,s.

    A strip's factor along a keystoned axis is sin(pi w_s x) / (pi x), w_s = w_0 + kappa width s, and along
    the last axis width sinc(width x) exp(j 2 pi u_s x), u_s = u_0 + width s: written as exponentials the
    product is a sum over signs sigma of terms geometric in s, whose sum over the S strips is a Dirichlet
    kernel exp(j (S - 1) theta / 2) sin(S theta / 2) / sin(theta / 2) of theta_sigma = 2 pi width x_last +
    pi width sum_a sigma_a kappa_a x_a. Same values as the strips, 2^(ndim-1) terms instead of S."""
    ndim = len(xs)
    n_strips = _strip_count(kappa)
    width = 1.0 / n_strips
    u0 = 0.5 * width - 0.5
    # sin(pi w x) / (pi x) at |x| = 1e-7 is its limit w to 1e-14 relative: keeps the division finite
    xk = [np.where(np.abs(x) < 1e-7, 1e-7, x) for x in xs[:-1]]
    last = xs[-1]
    total: np.ndarray | int = 0
    for signs in itertools.product((1.0, -1.0), repeat=ndim - 1):
        theta = 2 * np.pi * width * last + sum(np.pi * width * sg * k * x for sg, k, x in zip(signs, kappa, xk))
        phase = 2 * np.pi * u0 * last + sum(np.pi * sg * (1 + k * u0) * x for sg, k, x in zip(signs, kappa, xk))
        half = 0.5 * theta
        sn = np.sin(half)
        small = np.abs(sn) < 1e-9
        dirichlet = np.where(
            small, n_strips * np.cos(n_strips * half) / np.cos(half), np.sin(n_strips * half) / np.where(small, 1, sn)
        )
        total = total + math.prod(signs) * dirichlet * np.exp(1j * (phase + (n_strips - 1) * half))
    return np.asarray(total) * width * np.sinc(width * last) / math.prod(2j * np.pi * x for x in xk)


# The keystoned columns through the compiled kernel (sarproc.quality.residual_kernels); False (and
# EvaluateParams.exact) keeps the numpy reference, :func:`_keystone_columns`.
COMPILED = True
BOX_KERNEL = True


@contextlib.contextmanager
def numerics(exact: bool) -> Iterator[None]:
    """Within: the numpy reference of the keystoned columns where ``exact``, else the compiled kernel."""
    global COMPILED
    before, COMPILED = COMPILED, COMPILED and not exact
    try:
        yield
    finally:
        COMPILED = before


def _columns(c: Sequence[np.ndarray], orders: np.ndarray, kappa: np.ndarray) -> np.ndarray:
    """(K, *shape) stack of :func:`_keystone_columns` (c broadcastable per axis), compiled where allowed."""
    shape = np.broadcast_shapes(*[np.shape(v) for v in c])
    if not COMPILED:
        return np.stack([np.broadcast_to(col, shape) for col in _keystone_columns(c, orders, kappa)])
    pts = np.stack([np.broadcast_to(np.asarray(v, dtype=float), shape).ravel() for v in c])
    cols = residual_aot.keystone_columns(pts, orders, kappa, _strip_count(kappa))
    return cols.reshape((len(orders),) + tuple(shape))


def _keystone_sum(c: Sequence[np.ndarray], orders: np.ndarray, coef: np.ndarray, kappa: np.ndarray) -> np.ndarray:
    """sum_k coef_k _keystone_product(c + orders_k / 2, kappa) on a box (c broadcastable per axis)."""
    return np.tensordot(np.asarray(coef), _columns(c, orders, kappa), axes=1)


def _keystone_columns(c: Sequence[np.ndarray], orders: np.ndarray, kappa: np.ndarray) -> list[np.ndarray]:
    """_keystone_product(c + orders_k / 2, kappa) for every order k (c broadcastable per axis).

    The orders shift every angle of :func:`_keystone_product` by a constant, so the sines and cosines are
    taken once per sign on the box and each order costs multiplications only (angle addition)."""
    ndim = len(c)
    n_strips = _strip_count(kappa)
    width = 1.0 / n_strips
    u0 = 0.5 * width - 0.5
    last = c[-1]
    shape = np.broadcast_shapes(*[np.shape(v) for v in c])
    s_l, c_l = np.sin(np.pi * width * last), np.cos(np.pi * width * last)
    per_order = [np.zeros(shape, dtype=complex) for _ in orders]
    for signs in itertools.product((1.0, -1.0), repeat=ndim - 1):
        half = np.pi * width * last + sum(0.5 * np.pi * width * sg * k * x for sg, k, x in zip(signs, kappa, c[:-1]))
        phase = 2 * np.pi * u0 * last + sum(np.pi * sg * (1 + k * u0) * x for sg, k, x in zip(signs, kappa, c[:-1]))
        phase = phase + (n_strips - 1) * half
        sh, ch = np.sin(half), np.cos(half)
        ssh, csh = np.sin(n_strips * half), np.cos(n_strips * half)
        rot = np.exp(1j * phase)
        for q, order in enumerate(orders):
            n_a, n_l = order[:-1], order[-1]
            d_half = 0.5 * np.pi * width * n_l + sum(
                0.25 * np.pi * width * sg * k * n for sg, k, n in zip(signs, kappa, n_a)
            )
            d_phase = np.pi * u0 * n_l + sum(0.5 * np.pi * sg * (1 + k * u0) * n for sg, k, n in zip(signs, kappa, n_a))
            d_phase += (n_strips - 1) * d_half
            den = sh * math.cos(d_half) + ch * math.sin(d_half)  # sin(half + d_half)
            num = ssh * math.cos(n_strips * d_half) + csh * math.sin(n_strips * d_half)
            small = np.abs(den) < 1e-9
            if small.any():  # sin(S h) / sin(h) -> S cos(S h) / cos(h)
                lim = n_strips * (csh * math.cos(n_strips * d_half) - ssh * math.sin(n_strips * d_half))
                lim = lim / (ch * math.cos(d_half) - sh * math.sin(d_half))
                dirichlet = np.where(small, lim, num / np.where(small, 1.0, den))
            else:
                dirichlet = num / den
            per_order[q] += math.prod(signs) * dirichlet * (rot * complex(math.cos(d_phase), math.sin(d_phase)))
    for q, order in enumerate(orders):
        x_l = last + order[-1] / 2.0
        s_x = s_l * math.cos(0.5 * np.pi * width * order[-1]) + c_l * math.sin(0.5 * np.pi * width * order[-1])
        small = np.abs(x_l) < 1e-12
        sinc = np.where(small, 1.0, s_x / (np.pi * width * np.where(small, 1.0, x_l)))
        den = math.prod(2j * np.pi * (x + n / 2.0) for x, n in zip(c[:-1], order[:-1]))
        per_order[q] *= width * sinc / np.where(den == 0, 1.0, den)
    # within 1e-7 of a factor's removable singularity the angles above cancel to rounding: those few
    # points from :func:`_keystone_product`, which evaluates the limit there
    near = functools.reduce(
        np.logical_or,
        [np.broadcast_to(np.abs(x + n / 2.0) < 1e-7, shape) for a, x in enumerate(c[:-1]) for n in set(orders[:, a])],
        np.zeros(shape, dtype=bool),
    )
    if near.any():
        pts = [np.broadcast_to(x, shape)[near] for x in c]
        for q, order in enumerate(orders):
            per_order[q][near] = _keystone_product([x + n / 2.0 for x, n in zip(pts, order)], kappa)
    return per_order


def response_basis(
    points: npt.ArrayLike,
    position: npt.ArrayLike,
    V: npt.ArrayLike,
    nulls: npt.ArrayLike,
    f_c: npt.ArrayLike,
    orders: np.ndarray,
    K: np.ndarray | None = None,
    kappa: np.ndarray | None = None,
    warp: np.ndarray | None = None,
) -> np.ndarray:
    """Basis of a target's response at ``points`` ((ndim, N) image indices): (N, K) complex, column k
    the response of spectral order ``orders[k]`` (carrier f_c in cycles/sample, spatial chirp K in
    cycles/sample^2, keystone kappa (ndim - 1 relative width slopes, :func:`_strip_factors`), warp
    (:attr:`ResponseModel.warp`), peak 1 for order 0)."""
    A, p = _ridge_frame(position, V, nulls)
    x = np.asarray(points, dtype=float) - p[:, None]
    c = _warped(A @ x, x, warp)
    m = int(np.abs(orders).max()) if orders.size else 0
    n = np.asarray(orders, dtype=int).reshape(-1, len(c))
    cols: np.ndarray | int
    if kappa is not None and np.any(kappa):  # every order's strip sum, (K, N)
        cols = _columns(list(c), n, kappa)
    else:
        per_axis = [np.stack(_shifted_sincs(ca, m)) for ca in c]
        cols = math.prod(per_axis[a][n[:, a] + m] for a in range(len(c)))
    if K is None and orders.size and not np.any(f_c):  # no carrier (a fit's raw basis): times exp(0j) = 1 + 0j,
        return np.asarray(cols, dtype=complex).T  # which leaves every value as it is
    phase = 2 * np.pi * (np.asarray(f_c, dtype=float) @ x)
    if K is not None:
        phase = phase + _chirp_phase(x, K)
    return (np.asarray(cols) * np.exp(1j * phase)).T


def _warped(c: np.ndarray, x: np.ndarray, warp: np.ndarray | None) -> np.ndarray:
    """Ridge coordinates ``c`` ((ndim, N)) with the warp's second-order terms of the offsets ``x`` added."""
    if warp is None:
        return c
    return c + np.einsum("in,aij,jn->an", x, warp, x)


def model_values(points: npt.ArrayLike, model: ResponseModel) -> np.ndarray:
    """A fitted response model at ``points`` ((ndim, N) image indices), (N,) complex."""
    basis = response_basis(
        points,
        model.position,
        model.ridges,
        model.nulls,
        model.band_centre,
        model.orders,
        model.chirp,
        kappa=model.kappa,
        warp=model.warp,
    )
    values = basis @ model.coef
    if model.curvature:
        values = values + _curvature_values(np.asarray(points, dtype=float), model)
    if model.cubic is not None:
        x = np.asarray(points, dtype=float) - np.asarray(model.position, dtype=float)[:, None]
        values = values * _cubic_carrier(x, model.cubic)
    return values


def _cubic_monomials(x: Sequence[np.ndarray] | np.ndarray) -> list[np.ndarray]:
    """x0^3, x0^2 x1, x0 x1^2, x1^3 of 2D offsets ``x`` (per-axis arrays, broadcastable)."""
    return [x[0] ** 3, x[0] ** 2 * x[1], x[0] * x[1] ** 2, x[1] ** 3]


def _cubic_carrier(x: Sequence[np.ndarray] | np.ndarray, cubic: np.ndarray) -> np.ndarray:
    """exp(2 pi j sum_k cubic_k m_k(x)) (:func:`_cubic_monomials`) of 2D offsets ``x`` from the peak."""
    return np.exp(2j * np.pi * sum(float(t) * m for t, m in zip(cubic, _cubic_monomials(x))))


def _fresnel_box(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """F(a, b) = integral over u in (-1/2, 1/2) of exp(2 pi j (a u + b u^2)) (broadcast arrays): the response of
    a unit band whose phase is quadratic across it; sinc(a) at b = 0. Closed form by the Fresnel integrals
    E = C + jS: exp(-j pi a^2 / 2b) (E(t2) - E(t1)) / 2 sqrt(b), t = (a +- b) / sqrt(b), for b > 0; F(a, -b) is
    its conjugate (scipy.special's ufunc, imported only where a model has curved edges)."""
    a, b = np.broadcast_arrays(np.asarray(a, dtype=float), np.asarray(b, dtype=float))
    bent = np.abs(b) >= SERIES_B
    if bent.all():  # every sample's bow past the series' reach: no series, no samples picked
        return _fresnel_bent(a, b)
    if not bent.any():
        return _fresnel_series(a, b)
    out = np.empty(a.shape, dtype=complex)
    out[bent] = _fresnel_bent(a[bent], b[bent])
    out[~bent] = _fresnel_series(a[~bent], b[~bent])
    return out


SERIES_B = 0.17
"""|b| below which :func:`_fresnel_box` sums its series in b (:func:`_fresnel_series`) and not the Fresnel
integrals' closed form, whose rounding grows as |b| shrinks (its phases a^2 / b and its 1 / sqrt(b) cancel):
against a long-double Gauss-Legendre reference over |a| <= 50 the closed form's error is some 4-6 eps (1 + |a|)
at |b| in 0.13-0.2, 60 at 0.01 and 1e14 at 1e-14; the series' (11 terms) 0.5 up to |b| = 0.13, 2.5 at 0.17,
3.5 at 0.175 (where they cross) and 14 at 0.2 (tests/quality/test_fresnel_small_bow.py; docs/cli.md,
session 44)."""

SERIES_TERMS = 10
"""The last power of b in :func:`_fresnel_series`: its first term left out, (pi |b| / 2)^11 / 11! / 23, is
below eps at |b| < SERIES_B."""

_NEAR_W = 4.0  # |2 pi a| below: the moments by their Taylor series (the upward recursion's error grows as n / |w|)
_NEAR_TERMS = 12  # (|w| / 2)^26 / 26! < 1e-18 at |w| < _NEAR_W
_NEAR_COEF = np.array(
    [
        [(-1) ** m / math.factorial(2 * m) / (2 * k + 2 * m + 1) * 0.5 ** (2 * k) for m in range(_NEAR_TERMS + 1)]
        for k in range(SERIES_TERMS + 1)
    ]
)


def _series_terms(z: float) -> int:
    """The last power of b :func:`_fresnel_series` needs where |2 pi b| <= z: the first term left out,
    (z / 4)^(k + 1) / (k + 1)! / (2k + 3) (M_k <= 4^-k / (2k + 1)), below eps / 4; at most SERIES_TERMS."""
    for k in range(SERIES_TERMS):
        if (z / 4.0) ** (k + 1) / math.factorial(k + 1) / (2 * k + 3) < 2.0**-54:
            return k
    return SERIES_TERMS


def _fresnel_series(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """:func:`_fresnel_box` for small |b| (< :data:`SERIES_B`): F(a, b) = sum over k of (2 pi j b)^k / k! M_k(a),
    M_k(a) = integral over u in (-1/2, 1/2) of u^2k cos(2 pi a u) (the sine parts are odd), k up to what the
    largest |b| needs (:func:`_series_terms`: 4 at |b| = 1e-3, SERIES_TERMS near SERIES_B), summed by Horner's
    rule in real arithmetic (2 pi j b is imaginary). The moments: c_n = integral of
    u^n cos(w u), s_n of u^n sin(w u), w = 2 pi a, by parts upward from c_0 = sinc(a),
    s_n = (n c_(n-1) - 2^(1-n) cos(w / 2)) / w and c_n = (2^(1-n) sin(w / 2) - n s_(n-1)) / w (n odd, even),
    where |w| >= 4; where |w| < 4 (the recursion multiplies errors by n / |w|) those past c_0 by their Taylor
    series in w, c_2k = 2^-2k sum over m of (-1)^m (w / 2)^2m / (2m)! / (2k + 2m + 1)."""
    a = np.asarray(a, dtype=float)
    t = 2.0 * np.pi * np.asarray(b, dtype=float)
    terms = _series_terms(float(np.abs(t).max(initial=0.0)))
    half = np.pi * a  # w / 2
    near = np.abs(half) < _NEAR_W / 2
    inv = 1.0 / np.where(near, 1.0, 2.0 * half)
    sin, cos = np.sin(half), np.cos(half)
    c = np.sinc(a)  # F's value at b = 0 bit for bit (a bow of 0 adds nothing: :func:`_curvature_sum`)
    moments = [c]
    for n in range(1, 2 * terms + 1):
        if n % 2:
            c = (n * c - 2.0 ** (1 - n) * cos) * inv
        else:
            c = (2.0 ** (1 - n) * sin - n * c) * inv
            moments.append(c)
    if near.any():
        v = half[near] ** 2
        for k, coef in enumerate(_NEAR_COEF[1 : terms + 1], start=1):
            acc = np.full(v.shape, coef[-1])
            for q in coef[-2::-1]:
                acc = acc * v + q
            moments[k][near] = acc
    re, im = moments[-1], np.zeros(a.shape)
    for k in range(terms - 1, -1, -1):  # (re + j im) <- M_k + j t / (k + 1) (re + j im)
        tk = t / (k + 1)
        re, im = moments[k] - tk * im, tk * re
    return re + 1j * im


def _fresnel_bent(x: np.ndarray, b: np.ndarray) -> np.ndarray:
    """:func:`_fresnel_box` where every |b| > 1e-12: the Fresnel integrals' closed form."""
    from sarproc.product.special import fresnel

    y = np.abs(b)
    root = np.sqrt(y)
    s2, c2 = fresnel((x + y) / root)
    s1, c1 = fresnel((x - y) / root)
    f = np.exp(-0.5j * np.pi * x * x / y) / (2.0 * root) * ((c2 - c1) + 1j * (s2 - s1))
    return np.where(b > 0, f, np.conj(f))


class _BowTerms:
    """What :func:`_curvature_sum` takes from the ridge coordinates and orders whatever the bow: each azimuth
    order's shifted coordinate and its sinc, each range order's sinc (a bow's search evaluates one set of samples
    at some 25 bows: :func:`_fit_curvature`)."""

    def __init__(self, c: Sequence[np.ndarray], orders: np.ndarray) -> None:
        self.n = np.asarray(orders, dtype=int)
        self.c0, self.c1 = np.asarray(c[0], dtype=float), np.asarray(c[1], dtype=float)
        self.shifted = {k: self.c0 + k / 2.0 for k in sorted(set(self.n[:, 0]))}
        self.sincs = {k: np.sinc(x) for k, x in self.shifted.items()}
        self.rg = {k: np.sinc(self.c1 + k / 2.0) for k in sorted(set(self.n[:, 1]))}


def _curvature_sum(
    c: Sequence[np.ndarray], orders: np.ndarray, coef: np.ndarray | None, beta: float, terms: _BowTerms | None = None
) -> np.ndarray:
    """What the range edges' bow adds to a 2D model (without its carrier), at ridge coordinates c (nulls, arrays
    of one shape): the support's range band shifted by beta (u^2 - 1/12) range bands at azimuth band coordinate
    u (an annular sector's arcs against their chords; the mean shift, beta / 12, is the band centre's), so order
    n's azimuth factor sinc(c_0 + n_0 / 2) becomes F(c_0 + n_0 / 2, beta c_1) exp(-j pi beta c_1 / 6)
    (:func:`_fresnel_box`); the keystone is left out of the difference (its cross term is kappa times this
    one). ``coef`` None: per order, (K, *shape); else the sum over the orders weighted by it. ``terms``: c's and
    the orders' :class:`_BowTerms`, taken already (c is then not read)."""
    t = _BowTerms(c, orders) if terms is None else terms
    n, c0, c1 = t.n, t.c0, t.c1
    shift = np.exp(-2j * np.pi * beta * c1 / 12.0)
    az = {k: _fresnel_box(x, beta * c1) * shift - t.sincs[k] for k, x in t.shifted.items()}
    rg = t.rg
    if coef is None:
        return np.stack([az[a] * rg[b] for a, b in n])
    total = np.zeros(c0.shape, dtype=complex)
    for a in az:
        pick = np.flatnonzero(n[:, 0] == a)
        total += az[a] * sum(coef[q] * rg[n[q, 1]] for q in pick)
    return total


def _curvature_values(points: np.ndarray, model: ResponseModel, coef: np.ndarray | None = None) -> np.ndarray:
    """:func:`_curvature_sum` of ``model`` with its carrier at ``points`` ((2, N) image indices): (N,) weighted by
    ``coef`` (None: the model's own)."""
    A, p = _ridge_frame(model.position, model.ridges, model.nulls)
    x = np.asarray(points, dtype=float) - p[:, None]
    c = _warped(A @ x, x, model.warp)
    phase = 2 * np.pi * (np.asarray(model.band_centre, dtype=float) @ x) + _chirp_phase(x, model.chirp)
    weights = model.coef if coef is None else coef
    return _curvature_sum(list(c), model.orders, weights, model.curvature) * np.exp(1j * phase)


class _BowColumns:
    """(N, K) per bow ``beta``: per order, what a range-edge bow adds to ``model``'s basis at ``points`` (carrier
    included); the ridge coordinates, the carrier and the sincs that do not depend on the bow taken once."""

    def __init__(self, points: np.ndarray, model: ResponseModel) -> None:
        A, p = _ridge_frame(model.position, model.ridges, model.nulls)
        x = np.asarray(points, dtype=float) - p[:, None]
        c = _warped(A @ x, x, model.warp)
        phase = 2 * np.pi * (np.asarray(model.band_centre, dtype=float) @ x) + _chirp_phase(x, model.chirp)
        self.orders, self.terms, self.carrier = model.orders, _BowTerms(list(c), model.orders), np.exp(1j * phase)

    def __call__(self, beta: float) -> np.ndarray:
        return (_curvature_sum((), self.orders, None, beta, self.terms) * self.carrier).T


def _model_on_box(slices: Sequence[slice], model: ResponseModel) -> np.ndarray:
    """A fitted response model on the image box ``slices`` (complex128, the box's shape): its straight support
    (:func:`_straight_on_box`) plus what its range edges' bow adds (:func:`_curvature_sum`), times its cubic
    carrier (:func:`_cubic_carrier`) where it has one."""
    if model.cubic is not None:
        box = _model_on_box(slices, dataclasses.replace(model, cubic=None))
        x = [
            np.arange(s.start, s.stop, dtype=float).reshape([-1 if i == b else 1 for i in range(len(slices))]) - p
            for b, (s, p) in enumerate(zip(slices, model.position))
        ]
        return box * _cubic_carrier(x, model.cubic)
    strips = model.kappa is not None and bool(np.any(model.kappa))  # what model_values sums: the strips
    if model.warp is not None and not (BOX_KERNEL and COMPILED and len(slices) == 2 and strips):
        # not separable: every sample's ridge coordinates
        axes = np.meshgrid(*[np.arange(s.start, s.stop) for s in slices], indexing="ij")
        return model_values(np.stack([x.ravel() for x in axes]), model).reshape(axes[0].shape)
    box = _straight_on_box(slices, model) if model.warp is None else _warped_on_box(slices, model)
    if model.curvature:
        axes = np.meshgrid(*[np.arange(s.start, s.stop) for s in slices], indexing="ij")
        grid = np.stack([x.ravel() for x in axes])
        box += _curvature_values(grid, model).reshape(box.shape)
    return box


def _warped_on_box(slices: Sequence[slice], model: ResponseModel) -> np.ndarray:
    """A warped 2D model with a keystone (any nonzero one: :func:`model_values` sums its strips whether or not
    :func:`_keystoned` holds) on the image box ``slices`` (its range edges straight), as :func:`model_values`
    gives it at every sample to rounding: its ridge coordinates are quadratic in the box's
    indices, so the compiled kernel (:func:`sarproc.quality.residual_kernels.keystone_warped_box_sum`) turns
    every angle along a row by rotations, the carrier's included (:func:`_carrier_coefficients`), without the
    sines and cosines and the (samples, orders) basis of each sample."""
    A, p = _ridge_frame(model.position, model.ridges, model.nulls)
    W = np.asarray(model.warp, dtype=float)
    kappa = np.asarray(model.kappa, dtype=float)
    u = np.array([s.start for s in slices], dtype=float) - p  # the box's first sample's offset x
    cross = W[:, 0, 1] + W[:, 1, 0]
    # c = A x + sum_mn W_mn x_m x_n at x = u + (i, j)
    c0 = A @ u + W[:, 0, 0] * u[0] ** 2 + cross * u[0] * u[1] + W[:, 1, 1] * u[1] ** 2
    d_row = A[:, 0] + 2.0 * W[:, 0, 0] * u[0] + cross * u[1]
    d_col = A[:, 1] + cross * u[0] + 2.0 * W[:, 1, 1] * u[1]
    shape = [s.stop - s.start for s in slices]
    box = residual_aot.keystone_warped_box_sum(
        c0,
        d_row,
        d_col,
        W[:, 0, 0],
        cross,
        W[:, 1, 1],
        shape[0],
        shape[1],
        model.orders,
        model.coef,
        kappa,
        _strip_count(kappa),
        _carrier_coefficients(u, model),
    )
    return box


def _carrier_coefficients(u: np.ndarray, model: ResponseModel) -> np.ndarray:
    """The carrier's phase 2 pi f_c . x + pi x^T K x at x = u + (i, j) (a 2D box's indices i, j from its first
    sample, offset ``u`` from the peak) as its coefficients of (1, i, j, i^2, i j, j^2)."""
    f = np.asarray(model.band_centre, dtype=float)
    K = np.asarray(model.chirp, dtype=float)
    k01 = K[0, 1]  # as :func:`_chirp_phase` reads the symmetric K
    return np.array(
        [
            2 * np.pi * (f[0] * u[0] + f[1] * u[1])
            + np.pi * (K[0, 0] * u[0] ** 2 + 2 * k01 * u[0] * u[1] + K[1, 1] * u[1] ** 2),
            2 * np.pi * f[0] + 2 * np.pi * (K[0, 0] * u[0] + k01 * u[1]),
            2 * np.pi * f[1] + 2 * np.pi * (k01 * u[0] + K[1, 1] * u[1]),
            np.pi * K[0, 0],
            2 * np.pi * k01,
            np.pi * K[1, 1],
        ]
    )


def _straight_on_box(slices: Sequence[slice], model: ResponseModel) -> np.ndarray:
    """A fitted response model on the image box ``slices`` (complex128, the box's shape), its range edges
    straight (``curvature`` left out).

    Sin and cos of pi c_a are taken once per axis; the shifted sincs are then divisions. For an unskewed
    support the order sum is a product of per-axis factors: in 2D one matrix product over every strip's
    orders at once."""
    A, p = _ridge_frame(model.position, model.ridges, model.nulls)
    orders, coef, f_c = model.orders, model.coef, np.asarray(model.band_centre, dtype=float)
    ndim = len(p)
    m = int(np.abs(orders).max())
    xs = [np.arange(s.start, s.stop, dtype=float) - pi for s, pi in zip(slices, p)]
    shape = [len(x) for x in xs]

    def along(b: int, v: np.ndarray) -> np.ndarray:  # 1-D array v along image axis b, broadcastable over the box
        return v.reshape([-1 if i == b else 1 for i in range(ndim)])

    grid = [along(b, xs[b]) for b in range(ndim)]
    carrier = np.exp(1j * (2 * np.pi * sum(f_c[b] * grid[b] for b in range(ndim)) + _chirp_phase(grid, model.chirp)))
    tensor = np.zeros((2 * m + 1,) * ndim, dtype=complex)
    for order, k in zip(orders, coef):
        tensor[tuple(order + m)] = k
    if all(np.count_nonzero(A[a]) == 1 and A[a, a] != 0 for a in range(ndim)):  # separable: outer products
        kappa = model.kappa if _keystoned(model.kappa) else None
        strips = _strip_factors([A[a, a] * xs[a] for a in range(ndim)], m, kappa)
        if ndim == 2:  # sum_s f0_s^T T f1_s as one (n0, S(2m+1)) @ (S(2m+1), n1) product
            left = np.concatenate([tensor.T @ f[0] for f in strips], axis=0)
            right = np.concatenate([f[1] for f in strips], axis=0)
            return (left.T @ right) * carrier
        total: np.ndarray | int = 0
        for factors in strips:
            out = tensor
            for a in range(ndim):  # contract each order axis with its axis' shifted sincs
                out = np.tensordot(out, factors[a], axes=([0], [0]))
            total = total + out
        return total * carrier
    c = [functools.reduce(np.add, [A[a, b] * grid[b] for b in range(ndim) if A[a, b] != 0.0]) for a in range(ndim)]
    kappa = model.kappa
    box = np.zeros(shape, dtype=complex)
    if kappa is not None and _keystoned(kappa):  # skewed and keystoned: each order's strip sum in closed form
        if BOX_KERNEL and COMPILED and ndim == 2:  # along the box's rows by rotations, the orders summed in the kernel
            corner = np.array([s.start for s in slices], dtype=float) - p
            box = residual_aot.keystone_box_sum(
                A @ corner, A[:, 0], A[:, 1], shape[0], shape[1], orders, coef, kappa, _strip_count(kappa)
            )
            return box * carrier
        return _keystone_sum(c, orders, coef, kappa) * carrier
    factors = [np.stack(_shifted_sincs(ca, m)) for ca in c]
    for order, k in zip(orders, coef):
        box += k * math.prod(f[n + m] for f, n in zip(factors, order))
    return box * carrier


# The group fit is a Gauss-Newton (variable projection) on the real parameters (band centres, chirps and,
# with the support's shape, its widths and keystone), the complex amplitudes solved by linear least squares
# at every step; it runs to convergence: until the step it predicts would lower the misfit by less than
# FIT_TOLERANCE of it (no step limits what is reported: the figures do not depend on where it stops, nor on
# FD_STEP, tests/quality/test_residual_convergence.py).
FD_STEP = 1e-4  # width and keystone step of the central-difference derivatives (the numpy reference's)
# Fourth-order central differences, (8 (f(h) - f(-h)) - (f(2h) - f(-2h))) / 12 h: error O(h^4), so the reference
# converges where the analytic derivatives do (second order left 1e-9 of the misfit between them)
FD_STENCIL = ((1, 8.0 / 12.0), (2, -1.0 / 12.0))
# The width and keystone derivatives analytic, in one compiled pass with the strip sums (the reference,
# EvaluateParams.exact or False here: fourth-order central differences, four bases per parameter)
ANALYTIC_SHAPE = True
FIT_TOLERANCE = 1e-9  # predicted relative decrease of the misfit below which a group fit has converged
FIT_MAX_STEPS = 60  # Gauss-Newton steps at most (a safeguard: the fits converge in a few)
# A step is halved at most this many times looking for one that lowers the misfit (2^-20: a millionth of the
# Gauss-Newton step); then the fit stops where it is. Beyond that length the decreases found are the least
# squares' rounding, not the model's: on the make targets' small products only bp_stripmap's two bowed refits
# halve further (their Jacobian leaves out the bow's change with the widths), and the steps they took there, 2^-26
# of Gauss-Newton's, lowered the misfit by 5.4e-11 of itself where the step's first-order decrease is 2.3e-13. At
# 30 halvings, as before session 39, they ran 116 trial bases for nothing: bp_stripmap's evaluate 13 % more CPU,
# its figures the same to 5e-11 (docs/performance.md, session 39, ev39a).
HALVINGS = 20
# A fit that crawls (a defocused target's, whose misfit the model cannot remove: 60 steps each lowering it by
# 1.7e-9 of itself while predicting a little more than FIT_TOLERANCE) stops after FIT_CRAWL_STEPS steps in a
# row that lowered the misfit by less than FIT_CRAWL of it. Not sooner: stopping at 1e-6 moved the demo's
# residual floor by 0.056 dB (the figures hold to 0.05 dB, tests/quality/test_evaluate_pinned.py).
FIT_CRAWL = 1e-8
FIT_CRAWL_STEPS = 3
# A fit whose model leaves more than HOPELESS_MISFIT of its samples' energy (a target the band-limited model
# does not describe: make reproduce-002-small's plain PFA image, misfit 0.94-0.999, its fits at FIT_MAX_STEPS in
# each sweep, each step lowering it by 1e-4..1e-7 of itself) stops at the first step that lowers it by less
# than HOPELESS_CRAWL of itself. Where such a fit stops is not converged either way: on a noisy scene the
# figures move 0.05 dB when FIT_MAX_STEPS doubles, and stopping here lands within 0.01 dB of that
# (tests/quality/test_residual_convergence.py); its target is reported misfitted. Fits that describe their
# samples (misfit below it: every pinned scene's, the demo's, 002 two-step's) are untouched, bit for bit.
HOPELESS_MISFIT = 0.9
HOPELESS_CRAWL = 1e-3
# Gauss-Newton converges linearly where the model's second derivatives, weighted by a residual it cannot
# remove, change the misfit's curvature: the demo's fits (continuous chirp's pedestal, misfit 1e-3) fell by
# 1.5 times the predicted decrease at every step, each step going half the way and each decrease a quarter of the
# previous (13-14 steps); 000 small's by 0.46 times (overshooting by half). No step limit or halving was
# involved. Where two successive full steps find the same best length along them (:func:`_stretch`, within
# STEADY), the next step is that many Gauss-Newton steps long. Only steady ones: stretching by every step's
# parabola took a fit on the partly lit target of tests/quality/test_evaluate_pinned.py's own-supports scene, its
# ratio rising step by step, into another basin (misfit 0.3 % lower, floor 0.085 dB off the pinned one); fits
# the model does not describe (above STRETCH_MISFIT: the noisy scene of test_residual_convergence.py, whose
# stretched fits ended 0.23 dB from the unstretched ones) are not stretched either.
STRETCH = True
MAX_STRETCH = 4.0  # best lengths beyond [1 / MAX_STRETCH, MAX_STRETCH] Gauss-Newton steps are not taken
STEADY = 0.1
STRETCH_MISFIT = 0.5  # only fits whose model leaves less than this of their samples' energy are stretched
# A fit whose result counts only where it ends under a misfit ``bar`` (a restart, kept where it halves the first
# fit's misfit and beats the other restarts: :func:`_restart_misfitted_lone`; a warp, kept where it leaves under
# WARP_GAIN of the misfit without: :func:`_fit_warp`) stops once it cannot get there by its own account: when even
# every step it has left, each lowering the misfit by LOSING_MARGIN times what this step predicts, would leave it
# over the bar (:func:`_cannot_win`). Its result is then discarded as it would have been. The steps such fits take
# lower the misfit by 0.5-1.8 times their prediction, and their predictions fall step by step (bp_beam_edge's
# restarts, after a width reaches its bound: by a factor 0.6-0.86 a step; the warps 002 small plain keeps none of:
# first steps predict 7e-5..3e-2, keeping one needs 0.2). Measured on every pinned scene and the make targets' small
# products: no restart or warp kept differs (models equal to the bit), while bp_beam_edge's losing restarts stop
# after 15-36 of their 60 steps and 002 small plain's 25 warps after 46 of their 190 steps in all.
LOSING_MARGIN = 20.0
# A costly group fit (its least squares over COSTLY_FIT rows x columns^2: crowded targets fitted jointly, e.g. nine
# Hamming-weighted targets 12 m apart in an L-band plain PFA image, 9 x 25 columns on 6823-10 131 rows) converges
# by COSTLY_TOLERANCE of its misfit, not FIT_TOLERANCE. Such fits do not converge quadratically: their steps
# alternate between a full one lowering the misfit by 0.3-0.9 times its prediction and a halved one, the predicted
# decreases 1e-4..1e-7 of the misfit for 50 steps, and they ran to FIT_MAX_STEPS (on that scene 60 steps each of
# the crowded cuts' three sweeps at 0.15 s a step, one thread). Run on (fit of the three sweeps' first, 80 steps)
# the misfit falls 0.2 % after the step predicting 1e-4 (0.002108 -> 0.002104 of the samples' energy). Lone
# targets' fits (every make target's small product) and the pinned scenes' crowded group (3 x 21 columns on 3986
# rows: 1.6e7) stay under it, bit for bit (docs/performance.md, session 42).
COSTLY_FIT = 1e8
COSTLY_TOLERANCE = 1e-4
MAX_CARRIER_STEP = 0.02  # cycles/sample: a step's band-centre change at most (scaled down to it)
MAX_SHAPE_STEP = 0.01  # relative width / keystone change of a step at most
KAPPA_LIMIT = 0.2  # |keystone| at most


@dataclasses.dataclass
class _GroupFit:
    """What :func:`_fit_group` solves for: per member a real parameter vector (band centre f_c, the spatial
    chirp's upper triangle, with the support's shape its width scales - 1 and keystone) and the complex
    amplitudes of its orders at those parameters."""

    points: np.ndarray
    y: np.ndarray
    found: list[FitStart]
    nulls: np.ndarray
    orders: np.ndarray
    shaped: bool
    lower: np.ndarray  # (P,) bounds of one member's parameters (widths within 10 % of their centre)
    upper: np.ndarray
    curvature: Sequence[float] = ()  # per member, its range edges' bow (held, not fitted); () none

    @property
    def ndim(self) -> int:
        return self.points.shape[0]

    def split(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray, tuple[np.ndarray, np.ndarray] | None]:
        """(f_c, K, (scale, kappa) or None) of one member's parameter vector."""
        ndim, pairs = self.ndim, _chirp_pairs(self.ndim)
        K = np.zeros((ndim, ndim))
        for (a, b), v in zip(pairs, theta[ndim : ndim + len(pairs)]):
            K[a, b] = K[b, a] = v
        shape = None
        if self.shaped:
            rest = theta[ndim + len(pairs) :]
            shape = (rest[:ndim].copy(), rest[ndim:].copy())
        return theta[:ndim].copy(), K, shape

    def raw(self, q: int, shape: tuple[np.ndarray, np.ndarray] | None) -> np.ndarray:
        """Member q's basis without carrier and chirp (N, orders)."""
        f = self.found[q]
        if shape is None:
            return response_basis(self.points, f.position, f.ridges, self.nulls, np.zeros(self.ndim), self.orders)
        return response_basis(
            self.points,
            f.position,
            f.ridges,
            self.nulls * (1 + shape[0]),
            np.zeros(self.ndim),
            self.orders,
            kappa=shape[1],
        ) + (self._bow(q, shape[0]) if q < len(self.curvature) and self.curvature[q] else 0.0)

    def _bow(self, q: int, scale: np.ndarray) -> np.ndarray:
        """What member q's range-edge bow adds to its basis, without carrier and chirp (N, orders)."""
        A, _ = _ridge_frame(self.found[q].position, self.found[q].ridges, self.nulls * (1 + scale))
        return _curvature_sum(list(A @ self.offsets(q)), self.orders, None, self.curvature[q]).T

    def carrier(self, q: int, theta: np.ndarray) -> np.ndarray:
        """Member q's carrier and chirp at its samples; the last one kept per member (the Jacobian of the
        parameters whose bases were just evaluated needs it again)."""
        key = theta.tobytes()
        kept = self._carriers.get(q)
        if kept is not None and kept[0] == key:
            return kept[1]
        f_c, K, _ = self.split(theta)
        x = self.offsets(q)
        out = np.exp(1j * (2 * np.pi * (f_c @ x) + _chirp_phase(x, K)))
        self._carriers[q] = (key, out)
        return out

    def offsets(self, q: int) -> np.ndarray:
        """Member q's sample offsets from its peak (ndim, N)."""
        return self._offsets[q]

    def __post_init__(self) -> None:
        self._offsets = [self.points - np.asarray(f.position, dtype=float)[:, None] for f in self.found]
        self._carriers: dict[int, tuple[bytes, np.ndarray]] = {}

    def bases(self, thetas: list[np.ndarray], fixed: list[np.ndarray] | None) -> list[np.ndarray]:
        """Every member's basis (N, orders) at its parameters (``fixed``: the raw bases, shape not fitted)."""
        out = []
        for q, theta in enumerate(thetas):
            raw = fixed[q] if fixed is not None else self.raw(q, self.split(theta)[2])
            out.append(raw * self.carrier(q, theta)[:, None])
        return out

    def jacobian(self, q: int, theta: np.ndarray, basis: np.ndarray, coef: np.ndarray) -> np.ndarray:
        """(N, P) derivatives of member q's response (``basis @ coef``) with respect to its parameters:
        analytic for the band centre and chirp and, with the support's shape, for its widths and keystone
        (:meth:`_shape_columns`; the numpy reference: fourth-order central differences, :data:`FD_STENCIL`)."""
        ndim, pairs = self.ndim, _chirp_pairs(self.ndim)
        x = self.offsets(q)
        model = basis @ coef
        cols = [2j * np.pi * x[a] * model for a in range(ndim)]
        cols += [1j * np.pi * (1.0 if a == b else 2.0) * x[a] * x[b] * model for a, b in pairs]
        if self.shaped and COMPILED and ANALYTIC_SHAPE:
            cols += self._shape_columns(q, theta, coef)
        elif self.shaped:
            car = self.carrier(q, theta)
            base = len(cols)
            for i in range(2 * ndim - 1):
                diff = 0.0
                for k, weight in FD_STENCIL:
                    plus, minus = theta.copy(), theta.copy()
                    plus[base + i] += k * FD_STEP
                    minus[base + i] -= k * FD_STEP
                    diff = diff + weight * (self.raw(q, self.split(plus)[2]) - self.raw(q, self.split(minus)[2]))
                cols.append(((diff * car[:, None]) @ coef) / FD_STEP)
        return np.stack(cols, axis=1)

    def _shape_columns(self, q: int, theta: np.ndarray, coef: np.ndarray) -> list[np.ndarray]:
        """Member q's response derivatives with respect to its width scales and keystone, analytic
        (:func:`sarproc.quality.residual_kernels.keystone_derivatives`): the ridge coordinates are c_a =
        (A x)_a / (1 + scale_a), so d / d scale_a is -c_a / (1 + scale_a) d / d c_a."""
        scale, kappa = self.split(theta)[2]  # type: ignore[misc]
        f = self.found[q]
        A, _ = _ridge_frame(f.position, f.ridges, self.nulls * (1 + scale))
        c = A @ self.offsets(q)
        d = residual_aot.keystone_derivatives(c, self.orders, coef, kappa, _strip_count(kappa))
        car = self.carrier(q, theta)
        ndim = self.ndim
        return [d[a] * (-c[a] / (1 + scale[a])) * car for a in range(ndim)] + [
            d[ndim + a] * car for a in range(ndim - 1)
        ]


def _amplitudes(bases: list[np.ndarray], y: np.ndarray) -> tuple[np.ndarray, np.ndarray, float, NormalEquations]:
    """(coef (members, orders), residual, |residual|^2, the bases' least squares): the members' amplitudes by
    linear least squares."""
    normal = NormalEquations(np.concatenate(bases, axis=1))
    coef = normal.solve(y)
    r = y - normal.B @ coef
    return coef.reshape(len(bases), -1), r, float(np.vdot(r, r).real), normal


def _halved_step(
    solve: Callable[[np.ndarray], tuple], x: np.ndarray, step: np.ndarray, cost: float, halvings: int = 10
) -> tuple[float, tuple] | None:
    """(length, solve's result there): the first of the step's lengths 1, 1/2, 1/4, ... (``halvings`` of them)
    whose misfit (the third item ``solve`` returns) is under ``cost``; None where none is (at the minimum to
    rounding). The warp's and the sheared cubic's line search."""
    length = 1.0
    for _halving in range(halvings):
        trial = solve(x + length * step)
        if trial[2] < cost:
            return length, trial
        length /= 2
    return None


def _gauss_newton_step(
    normal: NormalEquations, r: np.ndarray, J: np.ndarray, free: np.ndarray
) -> tuple[np.ndarray, float]:
    """(step, predicted decrease of |r|^2): the real parameters' Gauss-Newton step (the ``free`` ones; the
    others 0), the amplitudes eliminated (variable projection: J projected off the span of the bases
    ``normal.B``)."""
    B = normal.B
    Jf = J[:, free]
    if COMPILED:  # B's least squares for every column of J (normal equations, refined): no full Q of a tall B
        Jp = Jf - B @ normal.solve(Jf)
    else:  # the numpy reference
        Q = np.linalg.qr(B)[0]
        Jp = Jf - Q @ (Q.conj().T @ Jf)
    A = np.concatenate([Jp.real, Jp.imag], axis=0)
    b = np.concatenate([r.real, r.imag])
    scale = np.linalg.norm(A, axis=0)
    scale[scale == 0] = 1.0
    d = np.linalg.lstsq(A / scale, b, rcond=None)[0] / scale
    step = np.zeros(J.shape[1])
    step[free] = d
    fit = A @ d
    return step, float(fit @ fit)


def _fit_group(
    members: list[int],
    points: np.ndarray,
    y: np.ndarray,
    found: list[FitStart],
    nulls: np.ndarray,
    orders: np.ndarray,
    K0: list[np.ndarray],
    shape0: list[tuple[np.ndarray, np.ndarray]] | None = None,
    centre: list[np.ndarray] | None = None,
    curvature: Sequence[float] = (),
    max_steps: int | None = None,
    bar: float | None = None,
) -> tuple[np.ndarray, list[np.ndarray], list[np.ndarray], list]:
    """Complex amplitudes of every member's orders, and real band centres f_c and spatial chirps K by
    Gauss-Newton to convergence (:data:`FIT_TOLERANCE`; the amplitudes by linear least squares at each step,
    a step halved until it lowers the misfit, stretched where the steps fall short or overshoot steadily:
    :data:`STRETCH`).

    With ``shape0`` (per member: (scale, kappa) starting values) the support's shape is fitted too: its
    widths (null spacing ``nulls * (1 + scale)`` per axis) and keystone kappa (:func:`_strip_factors`).
    They matter far out: a support edge 0.5 % off puts the side lobes 40 nulls away a fifth of a null out
    of step. The widths stay within 10 % of ``centre`` (per member, the nulls' scale; default 1).
    With ``bar`` (a misfit, a fraction of |y|^2, that the fit's result counts only under) it stops where it cannot
    get under it (:data:`LOSING_MARGIN`); its result then leaves more than ``bar``.
    Returns (coef, f_c, K, (scale, kappa) or None) per member."""
    ndim = points.shape[0]
    pairs = _chirp_pairs(ndim)
    shaped = shape0 is not None
    n_p = ndim + len(pairs) + (2 * ndim - 1 if shaped else 0)
    thetas = []
    for q, k in enumerate(members):
        parts = [np.asarray(found[k].band_centre, dtype=float), np.array([K0[q][a, b] for a, b in pairs], dtype=float)]
        if shape0 is not None:
            parts += [np.asarray(shape0[q][0], dtype=float), np.asarray(shape0[q][1], dtype=float)]
        thetas.append(np.concatenate(parts))
    lower = np.full((len(members), n_p), -np.inf)
    upper = np.full((len(members), n_p), np.inf)
    if shaped:
        s0 = ndim + len(pairs)
        for q in range(len(members)):
            mid = np.ones(ndim) if centre is None else np.asarray(centre[q], dtype=float)
            lower[q, s0 : s0 + ndim], upper[q, s0 : s0 + ndim] = 0.9 * mid - 1, 1.1 * mid - 1
            lower[q, s0 + ndim :], upper[q, s0 + ndim :] = -KAPPA_LIMIT, KAPPA_LIMIT
    thetas = [np.clip(t, lo, hi) for t, lo, hi in zip(thetas, lower, upper)]
    fit = _GroupFit(points, y, [found[k] for k in members], nulls, orders, shaped, lower[0], upper[0], curvature)
    fixed = None if shaped else [fit.raw(q, None) for q in range(len(members))]
    bases = fit.bases(thetas, fixed)
    coef, r, cost, normal = _amplitudes(bases, y)
    crawled = 0  # consecutive steps that lowered the misfit by less than FIT_CRAWL of it
    stretch, last = 1.0, math.nan  # the next step's length in Gauss-Newton steps (:func:`_stretch`), the last measured
    energy = float(np.vdot(y, y).real)
    n_steps = FIT_MAX_STEPS if max_steps is None else max_steps
    tolerance = (
        COSTLY_TOLERANCE if fit_size(points.shape[1], len(members) * len(orders)) > COSTLY_FIT else FIT_TOLERANCE
    )
    for n in range(n_steps):
        if cost <= 1e-30 * max(energy, 1e-300):
            break
        J = np.concatenate([fit.jacobian(q, t, b, c) for q, (t, b, c) in enumerate(zip(thetas, bases, coef))], axis=1)
        theta = np.concatenate(thetas)
        lo, hi = lower.ravel(), upper.ravel()
        free: np.ndarray = np.ones(theta.size, dtype=bool)
        step, predicted = _gauss_newton_step(normal, r, J, free)
        # parameters at a bound that the step pushes beyond it stay there (the step solved without them)
        held = ((theta <= lo) & (step < 0)) | ((theta >= hi) & (step > 0))
        if held.any():
            free = ~held
            step, predicted = (np.zeros_like(step), 0.0) if not free.any() else _gauss_newton_step(normal, r, J, free)
        if predicted <= tolerance * cost:
            break
        if bar is not None and _cannot_win(cost, predicted, n_steps - n, bar * energy):
            break
        limit = _step_limit(stretch * step, len(members), ndim, len(pairs), shaped)
        length = stretch * limit  # the step taken, in Gauss-Newton steps
        for _halving in range(HALVINGS):
            trial_theta = np.clip(theta + length * step, lo, hi)
            trial = list(trial_theta.reshape(len(members), n_p))
            trial_bases = fit.bases(trial, fixed)
            trial_coef, trial_r, trial_cost, trial_normal = _amplitudes(trial_bases, y)
            if trial_cost < cost:
                break
            length = length / 2
        else:
            break  # no step lowers the misfit: at its minimum to rounding
        # a full step (not limited, not halved) of a fit its model mostly describes measures the misfit's
        # curvature along it; where two such steps in a row find the same best length (a steady linear
        # convergence), the next step is taken that long
        full = STRETCH and length == stretch and trial_cost < STRETCH_MISFIT * energy
        measured = _stretch(cost, trial_cost, predicted, length) if full else math.nan
        stretch = measured if _steady(measured, last) else 1.0
        last = measured
        crawled = crawled + 1 if cost - trial_cost < FIT_CRAWL * trial_cost else 0
        hopeless = trial_cost > HOPELESS_MISFIT * energy and cost - trial_cost < HOPELESS_CRAWL * trial_cost
        thetas, bases, coef, r, cost, normal = trial, trial_bases, trial_coef, trial_r, trial_cost, trial_normal
        if crawled >= FIT_CRAWL_STEPS or hopeless:
            break
    out = [fit.split(t) for t in thetas]
    return coef, [o[0] for o in out], [o[1] for o in out], [o[2] for o in out]


def fit_size(rows: int, columns: int) -> float:
    """Rows x columns^2 of a fit's least squares (its Gram matrix's cost, and a Gauss-Newton step's)."""
    return float(rows) * float(columns) ** 2


def _cannot_win(cost: float, predicted: float, steps_left: int, bar: float) -> bool:
    """Whether a fit at misfit ``cost`` whose next Gauss-Newton step predicts a decrease ``predicted`` stays at or over
    ``bar`` even if each of its ``steps_left`` steps (this one included) lowered it by :data:`LOSING_MARGIN` times
    that (all three in the same units, |residual|^2)."""
    return cost - LOSING_MARGIN * steps_left * predicted >= bar


def _stretch(cost: float, trial_cost: float, predicted: float, length: float) -> float:
    """The step length, in Gauss-Newton steps, at which the misfit is least along this step (``length`` of
    them long): the minimum of the parabola through the misfit before (slope -2 ``predicted`` per Gauss-Newton
    step) and after it; infinite where that parabola has none."""
    curvature = (trial_cost - cost + 2.0 * predicted * length) / (length * length)
    return predicted / curvature if curvature > 0 else math.inf


def _steady(measured: float, last: float) -> bool:
    """Whether two successive best step lengths (:func:`_stretch`) agree within :data:`STEADY`, both within
    [1 / :data:`MAX_STRETCH`, :data:`MAX_STRETCH`] (NaN: not measured)."""
    lowest = 1.0 / MAX_STRETCH
    within = lowest <= measured <= MAX_STRETCH and lowest <= last <= MAX_STRETCH
    return within and abs(measured - last) <= STEADY * last


def _step_limit(step: np.ndarray, members: int, ndim: int, n_pairs: int, shaped: bool) -> float:
    """The factor (<= 1) that keeps a step's band-centre changes within :data:`MAX_CARRIER_STEP` and its
    shape changes within :data:`MAX_SHAPE_STEP` (the whole step scaled, its direction kept)."""
    per = step.reshape(members, -1)
    factor = 1.0
    largest = float(np.abs(per[:, :ndim]).max())
    if largest > MAX_CARRIER_STEP:
        factor = MAX_CARRIER_STEP / largest
    if shaped:
        largest = float(np.abs(per[:, ndim + n_pairs :]).max())
        if largest > MAX_SHAPE_STEP:
            factor = min(factor, MAX_SHAPE_STEP / largest)
    return factor


def _ridge_strips(
    pos: npt.ArrayLike, V: np.ndarray, nulls: np.ndarray, stride: np.ndarray, shape: tuple[int, ...], reach_nulls: float
) -> list:
    """Samples (ndim, M) along each side-lobe ridge out to +-``reach_nulls`` nulls, +-1 null across it:
    the far side lobes pin the spatial chirp and band edges that the box around the peak leaves loose."""
    ndim = len(shape)
    out = []
    for a in range(ndim):
        t = np.arange(-reach_nulls * nulls[a], reach_nulls * nulls[a] + 1, stride[a])
        across = [
            np.arange(-int(math.ceil(nulls[b])), int(math.ceil(nulls[b])) + 1, stride[b]) if b != a else np.zeros(1)
            for b in range(ndim)
        ]
        offs = np.stack([x.ravel() for x in np.meshgrid(*across, indexing="ij")], axis=0)  # (ndim, M0)
        line = np.asarray(pos, dtype=float)[:, None] + np.outer(V[a], t)  # (ndim, T)
        pts = np.rint(line[:, :, None] + offs[:, None, :]).reshape(ndim, -1).astype(int)
        inside = np.all((pts >= 0) & (pts < np.asarray(shape)[:, None]), axis=0)
        out.append(pts[:, inside])
    return out


# A lone target whose first fit (on its box, the image's band widths within 10 %) leaves more than this
# fraction of the box's energy has a support of its own: partly lit (a sliding spotlight's edge targets,
# a stripmap's beam edge) or wider than the nominal band with an antenna taper across it. Its widths are
# then searched (:func:`_search_widths`) before the ridge sweeps.
WIDTH_SEARCH_MISFIT = 1e-3
# Such a target's richer orders (:func:`_widen_misfitted_lone`): this many more than the theory's, at least two
# per axis. A rect beam's edge cuts the Hamming-weighted band (campaign scene 23, 22.8 deg squint): the band is
# a Hamming segment on the lit support, which two orders follow only to -28.5 dB (T3, 94 % lit, alone) and
# three to -68.6 dB (session 34; with two richer orders, as before, the theory's for Hamming, nothing changed).
RICHER_EXTRA_ORDERS = 1
WIDTH_SCALES = 1.25 ** np.arange(-3, 8)  # 0.51 .. 4.8 times the image's null spacing, 25 % apart


def _misfit(model: ResponseModel | None, points: np.ndarray, y: np.ndarray) -> float:
    """|y - model|^2 / |y|^2 on ``points``."""
    if model is None:
        return 0.0
    fit = model_values(points, model)
    energy = float(np.vdot(y, y).real)
    return float(np.vdot(y - fit, y - fit).real) / energy if energy > 0 else 0.0


def unique_columns(points: np.ndarray, shape: tuple[int, ...]) -> tuple[np.ndarray, np.ndarray]:
    """(columns, inverse): ``np.unique(points, axis=1, return_inverse=True)`` of (ndim, N) indices into an array
    of ``shape``, by their flat indices: the same columns in the same (lexicographic) order and the same inverse,
    from a sort of integers instead of numpy's sort of whole columns (6000 2D columns: 12 ms -> 0.5 ms; the
    demo's evaluate spent 0.07-0.10 s in it)."""
    flat, inverse = np.unique(np.ravel_multi_index(tuple(points), shape), return_inverse=True)
    # laid out as numpy's (column-major): the fits' products of these points then round alike
    columns = np.stack(np.unravel_index(flat, shape), axis=1).T
    return columns.astype(points.dtype, copy=False), inverse.ravel()


def _fit_samples(
    found: FitStart, nulls: np.ndarray, shape: tuple[int, ...], params: EvaluateParams
) -> tuple[np.ndarray, np.ndarray]:
    """(box, box and ridge strips): the image indices ((ndim, M)) a target's model is fitted on, about two per
    null: +-``params.fit_nulls`` nulls around its peak, and strips along its ridges (:func:`_ridge_strips`)."""
    r = np.ceil(params.fit_nulls * nulls).astype(int)
    stride = np.maximum(1, np.floor(nulls / 2)).astype(int)
    c = np.rint(found.position).astype(int)
    pts = [np.arange(max(0, ci - ri), min(n, ci + ri + 1), st) for ci, ri, n, st in zip(c, r, shape, stride)]
    g = np.meshgrid(*pts, indexing="ij")
    box = np.stack([x.ravel() for x in g], axis=0)
    ridges = _ridge_strips(found.position, found.ridges, nulls, stride, shape, params.fit_ridge_nulls)
    return box, np.concatenate([box] + ridges, axis=1)


def _refit_lone(
    model: ResponseModel,
    found: FitStart,
    points: np.ndarray,
    y: np.ndarray,
    nulls: np.ndarray,
    orders: np.ndarray,
    scale: np.ndarray,
) -> ResponseModel:
    """A lone target's model fitted again on ``points`` (:func:`_fit_group`, support shape included) with
    ``orders``, its widths started at ``scale`` times the null spacing ``nulls`` (and kept within
    10 % of it)."""
    ndim = len(nulls)
    coef, f_c, K, shape = _fit_group(
        [0],
        points,
        y,
        [dataclasses.replace(found, band_centre=model.band_centre)],
        nulls,
        orders,
        [model.chirp],
        [(scale - 1, np.zeros(ndim - 1))],
        [scale],
    )
    return dataclasses.replace(
        model,
        band_centre=f_c[0],
        chirp=K[0],
        coef=coef[0],
        orders=orders,
        nulls=nulls * (1 + shape[0][0]),
        kappa=shape[0][1],
    )


class _WidthBases:
    """``response_basis(points, model.position, model.ridges, nulls * scale, model.band_centre, model.orders,
    model.chirp)`` (no keystone, no warp: the rectangle's separable basis) for the scales a width search tries,
    the same arrays: the carrier and chirp do not depend on the widths, so they are taken once, and an axis'
    shifted sincs are reused while its ridge coordinates are the same bits (a search along one axis leaves the
    other's row of the ridge frame, and so its coordinates, as they were)."""

    def __init__(self, points: np.ndarray, model: ResponseModel, nulls: np.ndarray) -> None:
        self.model, self.nulls = model, nulls
        self.x = np.asarray(points, dtype=float) - np.asarray(model.position, dtype=float)[:, None]
        orders = model.orders
        self.m = int(np.abs(orders).max()) if orders.size else 0
        self.n = np.asarray(orders, dtype=int).reshape(-1, self.x.shape[0])
        phase = 2 * np.pi * (np.asarray(model.band_centre, dtype=float) @ self.x) + _chirp_phase(self.x, model.chirp)
        self.carrier = np.exp(1j * phase)
        self.sincs: dict[int, tuple[bytes, np.ndarray]] = {}  # per axis: (its coordinates' bytes, their sincs)

    def __call__(self, scale: np.ndarray) -> np.ndarray:
        A, _ = _ridge_frame(self.model.position, self.model.ridges, self.nulls * scale)
        c = A @ self.x
        per_axis = []
        for a, ca in enumerate(c):
            key = ca.tobytes()
            kept = self.sincs.get(a)
            if kept is None or kept[0] != key:
                kept = self.sincs[a] = (key, np.stack(_shifted_sincs(ca, self.m)))
            per_axis.append(kept[1])
        cols = math.prod(per_axis[a][self.n[:, a] + self.m] for a in range(len(c)))
        return (np.asarray(cols) * self.carrier).T


def _search_widths(
    model: ResponseModel, points: np.ndarray, y: np.ndarray, nulls: np.ndarray, below: float | None = None
) -> tuple[np.ndarray, float]:
    """(scale, misfit): the support widths that fit ``y`` best with the rectangle's basis (linear least
    squares at the model's band centre and chirp, the model's orders), one axis at a time, per axis the
    scale of the image's null spacing ``nulls`` (:data:`WIDTH_SCALES`, then a half and a quarter step either
    side of the best), and the misfit (|residual|^2 / |y|^2) there. With ``below`` (a misfit) it returns at
    the first scale whose misfit is under it: where only whether the search gets there is asked, the rest
    of the search cannot change the answer (its misfit only falls)."""

    bases = _WidthBases(points, model, nulls)
    seen: dict[bytes, float] = {}  # the grids meet the current scale again (1.0 on each axis): solved once

    def misfit(scale: np.ndarray) -> float:
        key = scale.tobytes()
        if key not in seen:
            B = bases(scale)
            r = y - B @ least_squares(B, y)
            seen[key] = float(np.vdot(r, r).real)
        return seen[key]

    energy = float(np.vdot(y, y).real)
    if not energy > 0:
        below = None
    scale = np.ones(len(nulls))
    best = misfit(scale)
    step = WIDTH_SCALES[1] / WIDTH_SCALES[0]
    for a in range(len(nulls)):
        for grid in (WIDTH_SCALES, [step**-0.5, step**0.5], [step**-0.25, step**0.25]):
            centre = scale[a] if grid is not WIDTH_SCALES else 1.0
            for s in np.asarray(grid) * centre:
                if below is not None and best / energy < below:
                    return scale, best / energy
                trial = scale.copy()
                trial[a] = s
                value = misfit(trial)
                if value < best:
                    best, scale = value, trial
    return scale, best / energy if energy > 0 else 0.0


def _start_nulls(
    data: np.ndarray, found: FitStart, nulls: np.ndarray, orders: np.ndarray, params: EvaluateParams
) -> np.ndarray:
    """The null spacing a target's fit starts from: its own (``found.nulls``, its theory's) unless the
    image's ``nulls`` fit its box better (linear least squares at its band centre), so that a theory the
    response does not follow (a beam edge's partly lit support with the antenna's taper across it) is not
    where its widths start."""
    own = np.asarray(nulls if found.nulls is None else found.nulls, dtype=float)
    if np.allclose(own, nulls, rtol=1e-3, atol=0) or not abs(found.value) > 0:
        return own
    box = _fit_samples(found, own, data.shape, params)[0]
    y = data[tuple(box)].astype(complex)

    def misfit(x: np.ndarray) -> float:
        B = response_basis(box, found.position, found.ridges, x, found.band_centre, orders)
        r = y - B @ least_squares(B, y)
        return float(np.vdot(r, r).real)

    return own if misfit(own) <= misfit(nulls) else nulls


# Two targets closer than the peak search's window share one peak: each target's peak is the strongest pixel within
# +-search_cells of its truth, so the weaker of a close pair (campaign scene 17's T1, 2.6 m and 3 cells from T2;
# scene 3's T2, 1.5 m from T5) is found on its neighbour's peak, and the group fit then holds two models on one
# position, the weaker one's response left unmodelled (scene 17's floor -29.3 dB, both misfits). A start within
# COINCIDE_NULLS of another's (every axis, the image's nulls) whose truth lies over a null from it is moved to its
# truth's offset from the start whose truth lies nearest that peak (the image's geolocation error shared). Only
# the model's start: the target's figures stay those of the peak it was found on. Scene 17 then floors at -33.2
# dB, not under -50: its Gaussian-beam targets, each alone, are fitted only to -40.9 / -38.7 dB.
COINCIDE_NULLS = 0.5


def separated_starts(
    found: list[FitStart], truth: npt.ArrayLike, nulls: npt.ArrayLike, data: np.ndarray
) -> list[FitStart]:
    """``found`` with each start that coincides with another's (:data:`COINCIDE_NULLS`) while its ``truth``
    (image indices, one row per start) lies over a null from it moved to its truth's offset from the start
    whose truth is nearest the shared peak; its peak value read from ``data`` there."""
    truth = np.asarray(truth, dtype=float)
    nulls = np.asarray(nulls, dtype=float)
    out = list(found)
    for j, f in enumerate(found):
        if not abs(f.value) > 0:
            continue
        sharing = [
            k
            for k, g in enumerate(found)
            if abs(g.value) > 0 and np.all(np.abs(np.asarray(g.position) - f.position) <= COINCIDE_NULLS * nulls)
        ]
        if len(sharing) < 2:
            continue
        miss = [float(np.max(np.abs(truth[k] - found[k].position) / nulls)) for k in sharing]
        keeper = sharing[int(np.argmin(miss))]
        if j == keeper or np.max(np.abs(truth[j] - f.position) / nulls) <= 1.0:
            continue
        position = np.asarray(found[keeper].position, dtype=float) + truth[j] - truth[keeper]
        index = tuple(int(v) for v in np.clip(np.rint(position), 0, np.array(data.shape) - 1))
        position = np.clip(position, 0, np.array(data.shape) - 1.0)
        if not abs(data[index]) > 0:
            continue
        out[j] = dataclasses.replace(f, position=position, value=complex(data[index]))
    return out


FIT_REACH_DB = -100.0  # other groups' side lobes are subtracted from a fit's samples down to this level

# The fits' matrices are small (a few thousand rows, tens of columns): threaded BLAS only adds its
# start-up and, on a loaded machine, threads spinning for each other (measured 7x slower on 2 cores); one
# thread also keeps the figures the same in every run (:mod:`sarproc.quality.blas`).


def fit_response_models(
    data: np.ndarray,
    found: list[FitStart],
    nulls: npt.ArrayLike,
    params: EvaluateParams,
    support_shape: bool = False,
    sheared: Sequence[bool] = (),
    budget: float | None = None,
) -> list[ResponseModel | None]:
    """:func:`_fit_response_models` with the numerics ``params.exact`` asks for; ``sheared``: per target, whether
    its support is sheared (its ridges not perpendicular in space): those lone targets get a cubic carrier
    (:func:`_fit_cubics`); with ``budget`` (rows x columns^2) a group whose joint fit is larger raises
    :class:`CrowdedGroup` before any fit runs."""
    with numerics(params.exact):
        return _fit_response_models(data, found, nulls, params, support_shape, sheared, budget)


# The residual's response models of crowded targets are fitted jointly, one least squares for the group, whose
# cost grows as the cube of its members (rows x columns^2: each member adds its samples and its orders). Over
# RESIDUAL_BUDGET the residual is not taken (the false target is then the guard-window figure, and the report says
# why), as the crowded cuts' refit is not tried over metrics.REFIT_BUDGET. Nine Hamming targets 12 m apart in an
# L-band plain PFA image: 9 x 25 columns on 10 131 rows, 5.1e8, fitted (about 15 s of CPU); 36 of them:
# 36 x 25 on 26 379 rows, 2.1e10, whose fit did not end in 16 CPU-minutes (docs/cli.md, row 9b).
RESIDUAL_BUDGET = 1e9


class CrowdedGroup(Exception):
    """A group of targets whose joint response-model fit is over its budget (:data:`RESIDUAL_BUDGET`)."""

    def __init__(self, members: Sequence[int], rows: int, columns: int) -> None:
        super().__init__(f"{len(members)} targets fitted jointly: {rows} rows x {columns} columns")
        self.members, self.rows, self.columns = list(members), rows, columns


def _overlapping_groups(
    found: list[FitStart], live: list[int], own: list[np.ndarray], half: list[np.ndarray]
) -> list[list[int]]:
    """The live targets grouped (transitively) where their fit boxes (half-widths ``half``) plus a null
    overlap: each group is fitted jointly."""
    group = {j: {j} for j in live}
    for j in live:
        for k in live:
            if (
                k > j
                and np.all(
                    np.abs(found[j].position - found[k].position) <= half[j] + half[k] + np.maximum(own[j], own[k])
                )
                and group[j] is not group[k]
            ):
                merged = group[j] | group[k]
                for q in merged:
                    group[q] = merged
    distinct: list[set[int]] = []
    for j in live:
        if group[j] not in distinct:
            distinct.append(group[j])
    return [sorted(g) for g in distinct]


# A misfitted lone target's box fit is started again from its band centre shifted by this fraction of its
# band along each axis, and the lowest misfit kept. The Gauss-Newton only descends, so it ends in the basin
# its start lies in: a partly lit target's power centroid (where it starts) lies off its cut support's
# centre, and bp_beam_edge's B then ends at a band centre 0.035 cycles/sample short of the best, its chirp's
# sign flipped to make up for it (box misfit 1.8e-2 against 5.0e-4 in the better basin, residual false
# target -29.9 against -40.8 dB).
RESTART_BAND_FRACTION = 0.125
# Not where the fit leaves over this fraction of its box's energy: noise or structure no band-limited model
# follows, not a basin (tests/quality/test_residual_convergence.py's noisy targets: 0.45-0.80; B: 0.018).
RESTART_MISFIT_MAX = 0.1
# A group's restarts (:func:`_restart_misfitted_groups`) are probed this many Gauss-Newton steps each; only the
# lowest probe is carried to convergence
PROBE_STEPS = 8


def _band_shifted_starts(found: list[FitStart], steps: dict[int, np.ndarray], n_axes: int) -> Iterator[list[FitStart]]:
    """The restarts' starts: for each axis and sign, ``found`` with each member ``k`` of ``steps`` started from its
    band centre shifted by that sign of ``steps[k]`` (cycles/sample per axis) along that axis, together."""
    for a in range(n_axes):
        for sign in (-1.0, 1.0):
            starts = list(found)
            for k, step in steps.items():
                shift = np.zeros(n_axes)
                shift[a] = sign * step[a]
                starts[k] = dataclasses.replace(found[k], band_centre=np.asarray(found[k].band_centre) + shift)
            yield starts


def _restart_misfitted_lone(
    fits: list,
    models: list[ResponseModel | None],
    found: list[FitStart],
    nulls: np.ndarray,
    orders: np.ndarray,
    centre: dict[int, np.ndarray],
    support_shape: bool,
) -> None:
    """Each lone target whose box fit leaves misfit (over :data:`WIDTH_SEARCH_MISFIT`, under
    :data:`RESTART_MISFIT_MAX`) fitted again on its box from its band centre shifted
    by +-:data:`RESTART_BAND_FRACTION` of its band along each axis; the model with the lowest box misfit
    kept where it halves the first fit's (as :func:`_widen_misfitted_lone` keeps a model: a basin, not a
    nudge within one). Updates ``models`` in place."""

    def restarted(fit: tuple) -> ResponseModel | None:  # reads and replaces its own target's model only
        members, near, y_near, _, _ = fit
        k, model = members[0], models[members[0]]
        if len(members) > 1 or model is None:
            return None
        first = _misfit(model, near, y_near)
        if not WIDTH_SEARCH_MISFIT < first < RESTART_MISFIT_MAX:
            return None
        best, kept = 0.5 * first, None
        # its band: one cycle per null
        for starts in _band_shifted_starts(found, {k: RESTART_BAND_FRACTION / model.nulls}, near.shape[0]):
            trial: list[ResponseModel | None] = [None] * len(models)
            # a restart that cannot get under the best misfit so far stops there (:data:`LOSING_MARGIN`)
            _fit_one_group(members, near, y_near, trial, starts, nulls, orders, centre, support_shape, bar=best)
            if (misfit := _misfit(trial[k], near, y_near)) < best:
                best, kept = misfit, trial[k]
        return kept

    for fit, kept in zip(fits, list(ordered_map(restarted, fits))):
        if kept is not None:
            models[fit[0][0]] = kept


def _group_misfit(models: Sequence[ResponseModel | None], points: np.ndarray, y: np.ndarray) -> float:
    """|y - sum of ``models``|^2 / |y|^2 on ``points``."""
    fit = sum((model_values(points, m) for m in models if m is not None), np.zeros(y.shape, complex))
    energy = float(np.vdot(y, y).real)
    return float(np.vdot(y - fit, y - fit).real) / energy if energy > 0 else 0.0


def _restart_misfitted_groups(
    fits: list,
    models: list[ResponseModel | None],
    found: list[FitStart],
    nulls: np.ndarray,
    orders: np.ndarray,
    centre: dict[int, np.ndarray],
) -> None:
    """:func:`_restart_misfitted_lone` for a group of several: its box fit started again from every member's
    band centre shifted by the same +-:data:`RESTART_BAND_FRACTION` of its band along each axis (a close pair
    shares its illumination), the models with the lowest box misfit kept where they halve the first fit's;
    then, where they did, each member's fit started again from every other member's band centre, kept where
    it lowers the group's box misfit by a fifth. Updates ``models`` in place.

    Campaign scene 11 (rect beam under Hamming, T1 and T2 7.3 m apart in range, fully lit): each alone is
    fitted to -63.0 / -53.7 dB, but their joint fit from their power centroids (0.030 cycles/sample above
    their band centre in azimuth) ended with both 7 % narrow in azimuth and band centres 0.016 high, box
    misfit 5.0e-3 against 2.0e-5 at the band centres each alone finds (2.9e-5 their lone models as they are):
    both misfits, floor -33.8 dB. The common restart finds T2's basin (misfit 3.7e-4), T1 then starts from
    T2's band centre and finds its own (2.0e-5): floor -54.8 dB."""

    def restarted(fit: tuple) -> dict[int, ResponseModel | None]:  # its members' models, reading no others'
        mine = list(models)
        _restart_misfitted_group(fit, mine, found, nulls, orders, centre)
        return {k: mine[k] for k in fit[0]}

    for replaced in list(ordered_map(restarted, fits)):
        for k, model in replaced.items():
            models[k] = model


def _restart_misfitted_group(
    fit: tuple,
    models: list[ResponseModel | None],
    found: list[FitStart],
    nulls: np.ndarray,
    orders: np.ndarray,
    centre: dict[int, np.ndarray],
) -> None:
    """One group's :func:`_restart_misfitted_groups`: its members' ``models`` replaced in place."""
    members, near, y_near, _, _ = fit
    if len(members) < 2 or any(models[k] is None for k in members):
        return
    first = _group_misfit([models[k] for k in members], near, y_near)
    if not WIDTH_SEARCH_MISFIT < first < RESTART_MISFIT_MAX:
        return
    band = {k: 1.0 / m.nulls for k in members if (m := models[k]) is not None}  # cycles/sample per axis
    best, kept = 0.5 * first, None
    probe, probed = math.inf, None
    steps = {k: RESTART_BAND_FRACTION * band[k] for k in members}
    for starts in _band_shifted_starts(found, steps, near.shape[0]):
        trial: list[ResponseModel | None] = [None] * len(models)
        _fit_one_group(members, near, y_near, trial, starts, nulls, orders, centre, True, PROBE_STEPS)
        if (misfit := _group_misfit([trial[k] for k in members], near, y_near)) < probe:
            probe, probed = misfit, trial
    if probed is not None:  # the most promising basin's fit carried to convergence
        _fit_one_group(members, near, y_near, probed, found, nulls, orders, centre, True)
        if (misfit := _group_misfit([probed[k] for k in members], near, y_near)) < best:
            kept = probed
    if kept is None:  # no other basin for the group as a whole: none sought for each member
        return
    for k in members:
        models[k] = kept[k]
    # then each member started from each other member's band centre (a close pair shares its illumination),
    # the others from their models
    current = _group_misfit([models[k] for k in members], near, y_near)
    for k in members:
        best, kept = 0.8 * current, None
        for other in members:
            m = models[other]
            if other == k or m is None:
                continue
            starts = list(found)
            starts[k] = dataclasses.replace(found[k], band_centre=m.band_centre)
            trial = list(models)
            trial[k] = None
            _fit_one_group(members, near, y_near, trial, starts, nulls, orders, centre, True)
            if (misfit := _group_misfit([trial[j] for j in members], near, y_near)) < best:
                best, kept = misfit, trial
        if kept is not None:
            for j in members:
                models[j] = kept[j]
            current = best


def _widen_misfitted_lone(
    data: np.ndarray,
    fits: list,
    models: list[ResponseModel | None],
    found: list[FitStart],
    own: list[np.ndarray],
    nulls: np.ndarray,
    richer: np.ndarray,
    params: EvaluateParams,
    own_orders: dict[int, np.ndarray],
    centre: dict[int, np.ndarray],
) -> None:
    """For each lone target its first fit leaves misfit (:data:`WIDTH_SEARCH_MISFIT`): richer orders
    (:data:`RICHER_EXTRA_ORDERS`), then (still misfit) the widths searched and the samples taken on them; only
    where the linear fit at the current band centre and chirp says it would halve the misfit, and kept where it
    does (structure no band-limited model follows, e.g. the two-step PFA's, is not chased at every target). Updates
    ``models``, ``own_orders``, ``centre`` and ``fits`` in place."""
    ndim = data.ndim

    def widened(fit: tuple) -> tuple[ResponseModel, np.ndarray, tuple] | None:  # its own target's model only
        members, near, y_near, far, y_far = fit
        k, model = members[0], models[members[0]]
        if model is None or len(members) > 1 or (before := _misfit(model, near, y_near)) <= WIDTH_SEARCH_MISFIT:
            return None
        rich = dataclasses.replace(model, orders=richer, kappa=None)
        linear = _search_widths(rich, near, y_near, own[k], below=0.5 * before)[1]
        if linear >= 0.5 * before:
            return None
        samples = (near, y_near, far, y_far)
        trial = _refit_lone(model, found[k], near, y_near, own[k], richer, np.ones(ndim))
        scale = np.ones(ndim)
        for _ in range(2):  # the box and ridges follow the widths found
            if _misfit(trial, samples[0], samples[1]) <= WIDTH_SEARCH_MISFIT:
                break
            scale = _search_widths(trial, samples[0], samples[1], own[k])[0]
            at, along = _fit_samples(found[k], own[k] * scale, data.shape, params)
            samples = (at, data[tuple(at)].astype(complex), along, data[tuple(along)].astype(complex))
            trial = _refit_lone(trial, found[k], samples[0], samples[1], own[k], richer, scale)
        if _misfit(trial, samples[0], samples[1]) < 0.5 * before:
            return trial, scale, samples
        return None

    for g, done in enumerate(list(ordered_map(widened, fits))):
        if done is not None:
            members, (trial, scale, samples) = fits[g][0], done
            k = members[0]
            models[k], own_orders[k], centre[k] = trial, richer, scale * own[k] / nulls
            fits[g] = (members, *samples)


def _others_subtracted(
    y: np.ndarray,
    points: np.ndarray,
    members: list[int],
    live: list[int],
    models: list[ResponseModel | None],
    reach: float,
) -> np.ndarray:
    """``y`` minus the other groups' current models on ``points`` (their side lobes), each only where its
    envelope reaches ``reach``. Within :func:`_fit_response_models` a model (the same object) on the same
    ``points`` (the same array) is evaluated once (:data:`_OTHERS`): a quarter of these evaluations on 002
    small two-step are of models no fit has replaced since; and where a model's envelope over the box holding all of
    ``points`` decides that it reaches all of them or none, it is not bounded at each (:func:`_reach_by_box`)."""
    rhs = y.copy()
    cache, pending = _OTHERS.cache, _OTHERS.pending
    for j in live:
        m = models[j]
        if j in members or m is None:
            continue
        key = (id(m), id(points), reach)
        hit = None if cache is None else cache.get(key)
        if hit is not None and hit[0] is m and hit[1] is points:
            near, values = hit[2], hit[3]
        else:
            ahead = None if pending is None else pending.pop(key, None)
            if ahead is not None and ahead[0] is m and ahead[1] is points:  # asked for ahead (:func:`_prefetch_others`)
                # not started yet: computed here (the thread would only be waited for)
                near, values = _values_near(m, points, reach, ahead[2]) if ahead[3].cancel() else ahead[3].result()
            else:
                decided = _reach_by_box(m, points, reach) if cache is not None else None
                near, values = (None, None) if decided is False else _values_near(m, points, reach, decided)
            if cache is not None:  # the objects held with their values, so their ids are not reused
                cache[key] = (m, points, near, values)
        if values is not None:
            rhs[near] -= values
    return rhs


def _values_near(
    model: ResponseModel, points: np.ndarray, reach: float, decided: bool | None
) -> tuple[np.ndarray, np.ndarray | None]:
    """Which of ``points`` ``model``'s envelope reaches ``reach`` at (all where ``decided``; else bounded at each)
    and the model's values there (None where at none): what :func:`_others_subtracted` subtracts."""
    near = np.ones(points.shape[1], dtype=bool) if decided else envelope_bound(model, points.T) >= reach
    return near, model_values(points[:, near], model) if near.any() else None


def _prefetch_others(
    fits: list,
    models: list[ResponseModel | None],
    live: list[int],
    reach: float,
    reads: Callable[[list[int]], bool] | None = None,
    refitted: int | None = None,
) -> None:
    """For a serial loop over ``fits`` in which each reading group (``reads(members)``; None: every group) subtracts
    the other groups' models (:func:`_others_subtracted`) and then may replace its own: the values of the models a
    reader will read as they stand now, computed ahead on :data:`_OTHERS`'s pool, the first reader's first. At the
    loop's start (``refitted`` None) those of the groups after each reader (no fit of the loop replaces them before
    it reads them); after group ``refitted``'s fit, its new models for the readers after it. The same function of
    the same model and samples, so the same bits; the loop takes each where it would have computed it, in its own
    order. Nothing where no pool runs (one thread, ``EvaluateParams.exact``)."""
    pool, cache, pending = _OTHERS.pool, _OTHERS.cache, _OTHERS.pending
    if pool is None or cache is None or pending is None:
        return
    group = {k: g for g, fit in enumerate(fits) for k in fit[0]}
    sources = live if refitted is None else [k for k in fits[refitted][0] if k in group]
    for g, (members, _, _, far, _) in enumerate(fits):
        if (refitted is not None and g <= refitted) or (reads is not None and not reads(members)):
            continue
        for j in sources:
            m = models[j]
            if m is None or j in members or (refitted is None and group.get(j, len(fits)) <= g):
                continue
            key = (id(m), id(far), reach)
            hit = cache.get(key) or pending.get(key)
            if hit is not None and hit[0] is m and hit[1] is far:
                continue
            decided = _reach_by_box(m, far, reach)
            if decided is False:
                cache[key] = (m, far, None, None)
            else:
                pending[key] = (m, far, decided, pool.submit(_values_near, m, far, reach, decided))


# A model's envelope over a box bounds its envelope at every sample in the box from above (:func:`envelope_bound`)
# and from below (:func:`envelope_floor`): where the one, this fraction above it for rounding, is under the reach,
# so is every sample's; where the other is this fraction over it, so is every sample's.
BOX_MARGIN = 1e-9


def _reach_by_box(model: ResponseModel, points: np.ndarray, reach: float) -> bool | None:
    """Whether ``model``'s envelope (:func:`envelope_bound`) reaches ``reach`` at every sample of ``points`` ((ndim, N)
    indices), True, or at none, False, as its bounds over the box that holds them all decide (with
    :data:`BOX_MARGIN`); None where they do not (then each sample is bounded). 002 small plain: of the 1500 (model,
    samples) pairs its fits bound, 608 reach none of their samples and 657 all; the box decides 585 and 640. Within
    :func:`_fit_response_models` a model is bounded over the boxes of every sample set the fits know at once
    (:func:`_know_samples`), once. A warped model's bound at a sample is not its bound over a box (the warp's norm
    times the sample's squared distance): not decided."""
    boxes, bounds = _OTHERS.boxes, _OTHERS.bounds
    if boxes is None or bounds is None or model.warp is not None or not points.shape[1]:
        return None
    if id(points) not in boxes:
        _know_samples([points])
    kept = bounds.get(id(model))
    if kept is None or kept[0] is not model or id(points) not in kept[1]:
        keys = list(boxes)
        lo = np.array([boxes[k][1] for k in keys])
        hi = np.array([boxes[k][2] for k in keys])
        most, least = envelope_bound(model, lo, hi).tolist(), envelope_floor(model, lo, hi).tolist()
        kept = (model, dict(zip(keys, zip(most, least))))
        bounds[id(model)] = kept  # the model held, so its id is not reused
    most, least = kept[1][id(points)]
    if most * (1.0 + BOX_MARGIN) < reach:
        return False
    if least >= reach * (1.0 + BOX_MARGIN):
        return True
    return None


def _know_samples(sets: Sequence[np.ndarray]) -> None:
    """Each sample set's box (its least and greatest index per axis) kept for :func:`_reach_by_box` (the array
    held, so its id is not reused) while :func:`_fit_response_models` runs."""
    boxes = _OTHERS.boxes
    if boxes is None:
        return
    for points in sets:
        if id(points) not in boxes and points.shape[1]:
            boxes[id(points)] = (points, points.min(axis=1).astype(float), points.max(axis=1).astype(float))


class _OthersCache(threading.local):
    """Per thread (evaluations may run side by side on a Dask worker's threads), while :func:`_fit_response_models`
    runs (None outside it): ``cache``, (model, points, reach) -> (model, points, mask, values) of
    :func:`_others_subtracted`; ``boxes``, id(points) -> (points, least, greatest index per axis) and ``bounds``,
    id(model) -> (model, {id(points): its envelope's bounds over that box, most and least}) of :func:`_reach_by_box`."""

    cache: dict | None = None
    boxes: dict | None = None
    bounds: dict | None = None
    pool: Executor | None = None
    pending: dict | None = None


_OTHERS = _OthersCache()


def _fit_one_group(
    members: list[int],
    points: np.ndarray,
    rhs: np.ndarray,
    models: list[ResponseModel | None],
    found: list[FitStart],
    nulls: np.ndarray,
    orders: np.ndarray,
    centre: dict[int, np.ndarray],
    support_shape: bool,
    max_steps: int | None = None,
    bar: float | None = None,
) -> None:
    """One group's :func:`_fit_group` on ``points`` / ``rhs``, started from its current models (or its
    peaks), its members' models replaced in ``models``. ``orders``: the group's; ``max_steps``: its
    Gauss-Newton steps at most (None: :data:`FIT_MAX_STEPS`); ``bar``: the misfit (a fraction of |rhs|^2) its
    result counts only under (:data:`LOSING_MARGIN`; None: fitted to convergence)."""
    ndim = points.shape[0]
    current = [models[k] for k in members]
    K0 = [np.zeros((ndim, ndim)) if m is None else m.chirp for m in current]
    start = [
        found[k] if m is None else dataclasses.replace(found[k], band_centre=m.band_centre)
        for k, m in zip(members, current)
    ]
    shape0 = None
    if support_shape:
        shape0 = [
            (centre[k] - 1, np.zeros(ndim - 1))
            if m is None
            else (m.nulls / nulls - 1, np.zeros(ndim - 1) if m.kappa is None else m.kappa)
            for k, m in zip(members, current)
        ]
    bows = [0.0 if m is None else m.curvature for m in current]
    coef, f_c, K, shape = _fit_group(
        list(range(len(members))),
        points,
        rhs,
        start,
        nulls,
        orders,
        K0,
        shape0,
        [centre[k] for k in members],
        bows if shape0 is not None else (),
        max_steps,
        bar,
    )
    for q, k in enumerate(members):
        models[k] = ResponseModel(
            position=np.asarray(found[k].position, dtype=float),
            ridges=np.asarray(found[k].ridges),
            nulls=nulls if shape[q] is None else nulls * (1 + shape[q][0]),
            band_centre=f_c[q],
            orders=orders,
            coef=coef[q],
            chirp=K[q],
            kappa=None if shape[q] is None else shape[q][1],
            curvature=bows[q] if shape[q] is not None else 0.0,
        )


@single_blas
def _fit_response_models(
    data: np.ndarray,
    found: list[FitStart],
    nulls: npt.ArrayLike,
    params: EvaluateParams,
    support_shape: bool = False,
    sheared: Sequence[bool] = (),
    budget: float | None = None,
) -> list[ResponseModel | None]:
    """:func:`_fitted_response_models` with the other groups' models on a fit's samples evaluated once
    (:data:`_OTHERS`)."""
    before = (_OTHERS.cache, _OTHERS.boxes, _OTHERS.bounds, _OTHERS.pool, _OTHERS.pending)
    _OTHERS.cache, _OTHERS.boxes, _OTHERS.bounds, _OTHERS.pending = {}, {}, {}, {}
    with threads.pool(params.exact) as ahead:
        _OTHERS.pool = ahead
        try:
            return _fitted_response_models(data, found, nulls, params, support_shape, sheared, budget)
        finally:
            _OTHERS.cache, _OTHERS.boxes, _OTHERS.bounds, _OTHERS.pool, _OTHERS.pending = before


def _fitted_response_models(
    data: np.ndarray,
    found: list[FitStart],
    nulls: npt.ArrayLike,
    params: EvaluateParams,
    support_shape: bool = False,
    sheared: Sequence[bool] = (),
    budget: float | None = None,
) -> list[ResponseModel | None]:
    """Every target's response model, fitted by complex least squares on the samples within
    +-``params.fit_nulls`` nulls of its peak (about two per null); with ``support_shape`` its support's
    widths and keystone too (:func:`_fit_group`), as the residual image needs far out.

    Targets whose fit boxes (plus a null) overlap are fitted jointly (:func:`_overlapping_groups`); then
    each group is fitted again, twice, on its boxes and ridge strips (``params.fit_ridge_nulls``) minus the
    other groups' models (:func:`_others_subtracted`), misfitted lone targets first given richer orders and
    widths of their own (:func:`_widen_misfitted_lone`).
    ``nulls``: the image's null spacing (samples per axis); with ``support_shape`` a target's optional
    ``found[k].nulls``, its own (its theory's, where the image's resolution varies with position),
    sizes its box and strips and is where its widths start (and stay within 10 % of) where it fits the
    box better than the image's (:func:`_start_nulls`).
    Returns one model per target (None for a target with no response)."""
    nulls = np.asarray(nulls, dtype=float)
    ndim = data.ndim
    orders = (
        residual_model_orders(ndim, params.residual_orders)
        if support_shape  # the residual image's models; the crowded cuts' refits keep their cap (metrics)
        else spectral_orders(ndim, params.residual_orders, params.residual_orders + (1 if ndim == 2 else 0))
    )
    # each target's own null spacing (the image's without support_shape: the basis' widths are then fixed)
    own = [_start_nulls(data, f, nulls, orders, params) if support_shape else nulls for f in found]
    half = [np.ceil(params.fit_nulls * x).astype(int) for x in own]
    live = [j for j, f in enumerate(found) if abs(f.value) > 0]
    boxes, strips = {}, {}
    for j in live:
        boxes[j], strips[j] = _fit_samples(found[j], own[j], data.shape, params)
    models: list[ResponseModel | None] = [None for _ in found]
    fits = []  # per group: (members, box samples, their values, box and ridge samples, their values)
    for members in _overlapping_groups(found, live, own, half):
        near = unique_columns(np.concatenate([boxes[k] for k in members], axis=1), data.shape)[0]
        far = unique_columns(np.concatenate([strips[k] for k in members], axis=1), data.shape)[0]
        if budget is not None and fit_size(far.shape[1], len(members) * len(orders)) > budget:
            raise CrowdedGroup(members, far.shape[1], len(members) * len(orders))
        fits.append((members, near, data[tuple(near)].astype(complex), far, data[tuple(far)].astype(complex)))
    reach = 0.0 if params.exact else float(np.abs(data).max()) * 10 ** (FIT_REACH_DB / 20)
    _know_samples([fit[3] for fit in fits])  # every model bounded over all their boxes at once (:func:`_reach_by_box`)
    # a member's support widths (the image nulls' scale): its own null spacing, or where _search_widths found them
    centre = {j: own[j] / nulls for j in live}
    rich = max(2, params.residual_orders + RICHER_EXTRA_ORDERS)
    richer = spectral_orders(ndim, rich, rich + (ndim == 2))
    own_orders: dict[int, np.ndarray] = {}  # a misfitted lone member's orders (one more than the theory's, >= 2)

    # Sweep 0 on the boxes alone (the chirp converges from zero there); then on boxes and ridge strips, with
    # the other groups' models subtracted.
    # These sweeps descend on no one misfit (each group fits its own samples, the others' models held) and three
    # are not always converged (issue 20 item 1, session 28; more sweeps as 1-2, sweep 0 run fully or stopped at a
    # predicted decrease of 1e-3): the pinned skewed, keystoned, own-supports and defocused scenes and bp_stripmap
    # settle by sweep 3 (floor within 0.004 dB of 10 sweeps', from either start); the pinned simulated,
    # backprojected scene converges slowly from either start (floor -54.91 dB after 3 sweeps, -55.77 after 30, its
    # misfit then still falling 1e-4 of itself a sweep); the demo settles by sweep 8 from sweep 0 run fully
    # (-38.69 dB; -38.86 after 3) and not from sweep 0 stopped (misfit half as large, floor -39.6..-41.8 dB); 000
    # small's never does (total misfit 3.1-3.5e-3 and floor -38.2..-40.7 dB from sweep to sweep through 30), so
    # the 0.3 dB that stopping sweep 0 early moved its floor is one draw of that wander. One joint fit of its nine
    # targets converges from either start (floor -42.18 / -42.16 dB, misfit 2.75e-3) at 30-60 times the CPU; each
    # group fitted on every group's samples (a descent on one misfit) settles from either start too, but at
    # -38.55 dB (0.01 dB apart after 10 sweeps; 10-20 times the CPU): its fits have minima 3.6 dB apart in floor.
    def first_fit(fit: tuple) -> list[ResponseModel | None]:
        members, near, y_near = fit[:3]
        mine = list(models)
        _fit_one_group(
            members, near, y_near, mine, found, nulls, own_orders.get(members[0], orders), centre, support_shape
        )
        return [mine[k] for k in members]

    for sweep in range(3):
        if sweep == 1 and support_shape:
            _restart_misfitted_lone(fits, models, found, nulls, orders, centre, support_shape)
            _restart_misfitted_groups(fits, models, found, nulls, orders, centre)
            _widen_misfitted_lone(data, fits, models, found, own, nulls, richer, params, own_orders, centre)
        if sweep == 0:  # each group on its own box alone: no group reads another's model (then in order)
            for members, fitted in zip([f[0] for f in fits], list(ordered_map(first_fit, fits, params.exact))):
                for k, model in zip(members, fitted):
                    models[k] = model
            continue
        _prefetch_others(fits, models, live, reach)
        for g, (members, _, _, far, y_far) in enumerate(fits):
            rhs = _others_subtracted(y_far, far, members, live, models, reach)
            group_orders = own_orders.get(members[0], orders)
            _fit_one_group(members, far, rhs, models, found, nulls, group_orders, centre, support_shape)
            _prefetch_others(fits, models, live, reach, refitted=g)
    if support_shape and ndim == 2:
        bowed = _fit_curvatures(fits, models, live, reach)
        reads = lambda members: members[0] in bowed  # noqa: E731
        _prefetch_others(fits, models, live, reach, reads)
        for g, (members, _, _, far, y_far) in enumerate(fits):  # their centres, chirps and shapes again, bow held
            if members[0] in bowed:
                rhs = _others_subtracted(y_far, far, members, live, models, reach)
                _fit_one_group(
                    members, far, rhs, models, found, nulls, own_orders.get(members[0], orders), centre, True
                )
                _prefetch_others(fits, models, live, reach, reads, refitted=g)
        _fit_warps(fits, models, live, reach)
        if any(sheared):
            _fit_cubics(fits, models, live, reach, sheared)
            if params.joint_ridge_lines:
                _fit_ridge_lines(fits, models, live, reach, sheared, data.shape)
    return models


# A sheared support (a squinted aperture at a steep depression in a ground plane: its ridges make 37 deg in space,
# docs/cli.md row 7d) comes with a short range and a short wavelength: there the wavefront's third-order term
# over the image, (2 / lambda) |d|^3 / 2R^2 (Ku band, 1.44 km, 18 m out: 0.2 cycles), is left by the chirp and the
# warp; the far ridges carried it as a phase error (a lone 16 GHz target's range ridge 56 samples out left at -40
# dB of its peak, 8 dB under the image there). Each lone sheared target's carrier takes a cubic phase
# (ResponseModel.cubic), fitted by Gauss-Newton with its other parameters held (:func:`_fit_cubic`) and kept where
# it leaves under CUBIC_GAIN of the misfit without. Targets whose ridges are perpendicular (every slant-plane
# frame, pfa2's rectangles) are not searched: their models are as before, to the bit.
# The range edges' bow is refined with the cubic (CUBIC_BOW; session 43): searched before the warp and the cubic,
# it took 4 % off a misfit the cubic phase still dominated and was not kept (its probe gain 0.9), and a uniform
# range band's sharp edges, an annulus' arcs against the model's chords (-0.032 range bands per azimuth band^2 on
# the trial's lone target, fitted -0.032), left the floor at -49.3 dB beside the range ridge; with it -58.9 dB.
# On a larger image the strips reach 40 nulls and more (the trial's 3x4 grid, 340 x 390 samples): there the
# wavefront's phase errors far out are cycles, Gauss-Newton from no warp and no cubic does not converge (a lone
# target at the grid's middle: warp 0.867, cubic 0.995 of the misfit, both rejected; floor -37.95 dB), so both are
# fitted first within CUBIC_NEAR_NULLS of the peak (:func:`_fit_near_first`), then on the whole strips with the
# warp, the chirp, the widths and the keystone refined in the cubic's Gauss-Newton (session 44: -65.76 dB; the 3x4
# -32.78 -> -37.45 dB, its targets' shared ridge lines still fitted one target at a time; docs/cli.md).
CUBIC_GAIN = 0.9
CUBIC_STEPS = 20
CUBIC_DV = 1e-4  # the cross slopes' central difference
CUBIC_MAX_TILT_STEP = 0.01  # a step's cross-slope change at most
CUBIC_CRAWL = 1e-3  # a step lowering the misfit by less than this of itself ends the fit
CUBIC_BOW = True  # the bow refined with the cubic (False: held as _fit_curvatures left it, as before session 43)
CUBIC_DBOW = 1e-3  # the bow's central difference (range bands per azimuth band^2)
CUBIC_MAX_BOW_STEP = 0.01  # a step's bow change at most
CUBIC_DWARP = 1e-7  # the warp's central difference (nulls per sample^2)
CUBIC_NEAR_NULLS = 20.0  # nulls along each ridge the warp and cubic are fitted on first (0: the whole strips at once)


def _fit_cubics(
    fits: list, models: list[ResponseModel | None], live: list[int], reach: float, sheared: Sequence[bool]
) -> None:
    """Each lone sheared 2D target's cubic carrier (:func:`_fit_cubic`) on its box and ridge strips, the other
    groups' models subtracted: first near its peak (:func:`_fit_near_first`), then on the whole strips with its
    warp, chirp, widths and keystone; kept where it leaves under :data:`CUBIC_GAIN` of the misfit without.
    Updates ``models``."""
    for members, _, _, far, y_far in fits:
        k, model = members[0], models[members[0]]
        if len(members) > 1 or model is None or not sheared[k]:
            continue
        rhs = _others_subtracted(y_far, far, members, live, models, reach)
        staged = CUBIC_NEAR_NULLS > 0
        if staged and model.cubic is None:
            model = _fit_near_first(far, rhs, model)
        cubed, before, after = _fit_cubic(far, rhs, model, warped=staged)
        if CUBIC_NEAR_NULLS and model is not models[k]:  # the staged terms judged against the model without them
            before, after = _misfit(models[k], far, rhs), _misfit(cubed, far, rhs)
        if after < CUBIC_GAIN * before:
            models[k] = cubed


# Targets on one ridge line (the trial's 3x4: the three of a range column share their azimuth ridge, T00_03 and
# T01_02 their range ridge) each leave the other's ridge under their own strips there: only their sum is measured,
# and fitted one target at a time, the others subtracted, the alternation converges slowly (session 44: -37.50 dB
# after one round of whole-strip fits, -38.43 after three). A pair of sheared lone targets whose ridge strips
# share over LINE_SHARE of the smaller strip set (their boxes left out) is fitted jointly on the union of their
# strips (:func:`_fit_cubics_jointly`), the other targets' models subtracted, kept where it lowers the pair's misfit
# there (session 45: the 3x4 -37.45 -> -37.90 dB uniform, -38.50 -> -40.07 Hamming; docs/cli.md). On the 3x4
# (340 x 390 samples) collinear ridges share 0.08-0.35 of a target's strip samples, ridges crossing at an angle
# 0.02-0.05. Opt-in (EvaluateParams.joint_ridge_lines): it costs 1.8-2.2x evaluate's CPU on the 3x4.
LINE_SHARE = 0.06


def _ridge_line_pairs(fits: list, models: list[ResponseModel | None], sheared: Sequence[bool], shape: tuple) -> list:
    """(j, k, union of their strips, its values) per pair of sheared lone targets whose ridge strips share over
    :data:`LINE_SHARE` of the smaller one's samples beyond their boxes, most shared first."""
    lone = {}
    for members, near, _, far, y_far in fits:
        k = members[0]
        if len(members) == 1 and models[k] is not None and sheared[k]:
            flat = np.ravel_multi_index(tuple(far), shape)
            lone[k] = (far, y_far, np.setdiff1d(flat, np.ravel_multi_index(tuple(near), shape)))
    pairs = []
    for j, k in itertools.combinations(sorted(lone), 2):
        shared = np.intersect1d(lone[j][2], lone[k][2]).size
        if shared > LINE_SHARE * min(lone[j][2].size, lone[k][2].size):
            points, inverse = unique_columns(np.concatenate([lone[j][0], lone[k][0]], axis=1), shape)
            values = np.empty(points.shape[1], complex)
            values[inverse] = np.concatenate([lone[j][1], lone[k][1]])
            pairs.append((shared, j, k, points, values))
    pairs.sort(key=lambda p: -p[0])
    return [p[1:] for p in pairs]


def _fit_ridge_lines(
    fits: list, models: list[ResponseModel | None], live: list[int], reach: float, sheared: Sequence[bool], shape: tuple
) -> None:
    """Each pair of sheared lone targets on one ridge line (:func:`_ridge_line_pairs`) fitted jointly on the union of
    their strips, the other targets' models subtracted (:func:`_fit_cubics_jointly`, warped), kept where the pair
    leaves less there. Updates ``models``."""
    for j, k, points, values in _ridge_line_pairs(fits, models, sheared, shape):
        pair = [models[j], models[k]]
        if pair[0] is None or pair[1] is None:
            continue
        rhs = _others_subtracted(values, points, [j, k], live, models, reach)
        fitted, before, after = _fit_cubics_jointly(points, rhs, pair, warped=True)
        if after < before:
            models[j], models[k] = fitted


def _fit_near_first(points: np.ndarray, y: np.ndarray, model: ResponseModel) -> ResponseModel:
    """``model`` with the warp (where it has none) and the cubic carrier fitted first on the samples within
    :data:`CUBIC_NEAR_NULLS` nulls of its peak along each ridge (:func:`_fit_warp`, :func:`_fit_cubic`), each kept
    where it leaves under its gain of the misfit there: the start of the whole strips' cubic fit."""
    A, p = _ridge_frame(model.position, model.ridges, model.nulls)
    near = np.max(np.abs(A @ (np.asarray(points, dtype=float) - p[:, None])), axis=0) <= CUBIC_NEAR_NULLS
    if near.all():
        return model
    pts, rhs = points[:, near], y[near]
    straight = dataclasses.replace(model, warp=None)  # a warp fitted on the whole strips from none may be astray
    warped, before, after = _fit_warp(pts, rhs, straight, WARP_GAIN)
    if after < WARP_GAIN * before:
        model = warped
    elif model.warp is not None and _misfit(straight, pts, rhs) <= _misfit(model, pts, rhs):
        model = straight
    cubed, before, after = _fit_cubic(pts, rhs, model)
    return cubed if after < CUBIC_GAIN * before else model


def _fit_cubic(
    points: np.ndarray, y: np.ndarray, model: ResponseModel, warped: bool = False
) -> tuple[ResponseModel, float, float]:
    """(model, misfit before, after): ``model`` with the cubic carrier (:attr:`ResponseModel.cubic`) that fits
    ``y`` on ``points`` best, by Gauss-Newton from none (or from ``model.cubic``), its band centre, its ridges'
    cross slopes (V[0, 1], V[1, 0]: the range edges' tilt against the ridges measured, 0.0058 range bands per
    azimuth band on the trial's scene) and its range edges' bow (:attr:`ResponseModel.curvature`,
    :data:`CUBIC_BOW`) refined with it; with ``warped`` its warp, chirp, widths and keystone too (the whole
    strips' fit of :func:`_fit_cubics`); its other parameters held, amplitudes by linear least squares,
    eliminated from the steps. :func:`_fit_cubics_jointly` of the one model."""
    fitted, before, after = _fit_cubics_jointly(points, y, [model], warped)
    return fitted[0], before, after


class _CubicTerms:
    """One model's parameters in :func:`_fit_cubics_jointly` (band centre's shift, the cubic's four terms, with
    ``warped`` the chirp's three; the two cross slopes; with ``warped`` the warp's six terms, the widths' relative
    changes and the keystone's; the bow, :data:`CUBIC_BOW`): its basis at them, its Jacobian's columns (the basis'
    derivatives in the cross slopes, warp, shape and bow are central differences taken once, at the start: a
    chord), its step's limits and the model they give."""

    def __init__(self, points: np.ndarray, model: ResponseModel, warped: bool) -> None:
        self.points, self.model, self.warped = points, model, warped
        x = np.asarray(points, dtype=float) - np.asarray(model.position, dtype=float)[:, None]
        # band centre's shift, the cubic's terms, then (``warped``) the chirp's
        rows = [x[0], x[1], *_cubic_monomials(x)] + ([x[0] ** 2 / 2, x[0] * x[1], x[1] ** 2 / 2] if warped else [])
        self.phases = np.stack(rows)
        n_ph = len(rows)
        self.n_ph = n_ph
        self.cross = [(0, 1), (1, 0)]
        self.tilt = slice(n_ph, n_ph + len(self.cross))
        self.bowed = CUBIC_BOW  # the bow, the last parameter
        self.pairs = _chirp_pairs(2)
        self.n_warp = 2 * len(self.pairs) if warped else 0  # the warp's terms (:func:`_fit_warp`), after the slopes
        self.bend = slice(self.tilt.stop, self.tilt.stop + self.n_warp)
        self.keyed = model.kappa is not None
        self.n_shape = (2 + int(self.keyed)) if warped else 0  # the widths' relative changes and keystone's, then
        self.form = slice(self.bend.stop, self.bend.stop + self.n_shape)
        self.warp0 = np.zeros((2, 2, 2)) if model.warp is None else np.asarray(model.warp, dtype=float)
        self.size = n_ph + len(self.cross) + self.n_warp + self.n_shape + int(self.bowed)

    def warp_of(self, w: np.ndarray) -> np.ndarray | None:
        if not self.n_warp:
            return self.model.warp
        W = self.warp0.copy()
        for a in range(2):
            for q, (i, j) in enumerate(self.pairs):
                W[a, i, j] += w[a * len(self.pairs) + q]
                if i != j:
                    W[a, j, i] += w[a * len(self.pairs) + q]
        return W

    def shaped(self, sh: np.ndarray | None) -> tuple[np.ndarray, np.ndarray | None]:
        model = self.model
        if sh is None or not self.n_shape:
            return model.nulls, model.kappa
        kappa = model.kappa + sh[2:3] if self.keyed else model.kappa
        return model.nulls * (1 + sh[:2]), kappa

    def base(self, V: np.ndarray, beta: float, w: np.ndarray | None = None, sh: np.ndarray | None = None) -> np.ndarray:
        model = self.model
        W = self.warp_of(np.zeros(self.n_warp) if w is None else w)
        nulls, kappa = self.shaped(sh)
        b = response_basis(
            self.points, model.position, V, nulls, model.band_centre, model.orders, model.chirp, kappa=kappa, warp=W
        )
        if beta:
            b = b + _BowColumns(self.points, dataclasses.replace(model, ridges=V, warp=W, nulls=nulls, kappa=kappa))(
                beta
            )
        return b

    def ridges(self, theta: np.ndarray) -> np.ndarray:
        V = np.array(self.model.ridges, dtype=float)
        for (i, j), d in zip(self.cross, theta[self.tilt]):
            V[i, j] += d
        return V

    def bow(self, theta: np.ndarray) -> float:  # within the bow search's +-CURVATURE_LIMIT
        beta = self.model.curvature + (float(theta[-1]) if self.bowed else 0.0)
        return min(max(beta, -CURVATURE_LIMIT), CURVATURE_LIMIT)

    def start(self) -> np.ndarray:
        theta = np.zeros(self.size)
        if self.model.cubic is not None:  # from the cubic fitted already (:func:`_fit_near_first`)
            theta[2:6] = self.model.cubic
        return theta

    def basis(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(basis with its carrier's refinement, that factor) at ``theta``."""
        factor = np.exp(2j * np.pi * (theta[: self.n_ph] @ self.phases))[:, None]
        return self.base(self.ridges(theta), self.bow(theta), theta[self.bend], theta[self.form]) * factor, factor

    def chords(self, theta: np.ndarray) -> list[np.ndarray]:
        """The basis' central differences in the cross slopes, warp, shape and bow at ``theta``."""
        V, beta = self.model.ridges, self.bow(theta)
        slopes = []
        for i, j in self.cross:
            dV = np.zeros((2, 2))
            dV[i, j] = CUBIC_DV
            slopes.append((self.base(V + dV, beta) - self.base(V - dV, beta)) / (2 * CUBIC_DV))
        for q in range(self.n_warp):
            dw = np.zeros(self.n_warp)
            dw[q] = CUBIC_DWARP
            slopes.append((self.base(V, beta, dw) - self.base(V, beta, -dw)) / (2 * CUBIC_DWARP))
        for q in range(self.n_shape):
            ds = np.zeros(self.n_shape)
            ds[q] = FD_STEP
            slopes.append((self.base(V, beta, None, ds) - self.base(V, beta, None, -ds)) / (2 * FD_STEP))
        if self.bowed:
            up, down = self.base(V, beta + CUBIC_DBOW), self.base(V, beta - CUBIC_DBOW)
            slopes.append((up - down) / (2 * CUBIC_DBOW))
        return slopes

    def clip(self, step: np.ndarray) -> None:
        step[self.tilt] = np.clip(step[self.tilt], -CUBIC_MAX_TILT_STEP, CUBIC_MAX_TILT_STEP)
        if self.bowed:
            step[-1] = np.clip(step[-1], -CUBIC_MAX_BOW_STEP, CUBIC_MAX_BOW_STEP)
        step[self.form] = np.clip(step[self.form], -MAX_SHAPE_STEP, MAX_SHAPE_STEP)

    def fitted(self, theta: np.ndarray, coef: np.ndarray) -> ResponseModel:
        model = self.model
        centre = np.asarray(model.band_centre, dtype=float) + theta[:2]
        chirp = model.chirp + np.array([[theta[6], theta[7]], [theta[7], theta[8]]]) if self.warped else model.chirp
        return dataclasses.replace(
            model,
            coef=coef,
            cubic=theta[2:6],
            band_centre=centre,
            ridges=self.ridges(theta),
            curvature=self.bow(theta),
            warp=self.warp_of(theta[self.bend]),
            nulls=self.shaped(theta[self.form])[0],
            kappa=self.shaped(theta[self.form])[1],
            chirp=chirp,
        )


def _fit_cubics_jointly(
    points: np.ndarray, y: np.ndarray, models: Sequence[ResponseModel], warped: bool = False
) -> tuple[list[ResponseModel], float, float]:
    """(models, misfit before, after): :func:`_fit_cubic`'s parameters of every model (:class:`_CubicTerms`) solved
    together on ``points`` / ``y``, their amplitudes by one linear least squares: targets on one ridge line, whose
    sum alone is measured there (:func:`_fit_ridge_lines`). The models as given where no step lowers the misfit."""
    terms = [_CubicTerms(points, m, warped) for m in models]
    cuts = np.cumsum([0] + [t.size for t in terms])
    spans = [slice(int(a), int(b)) for a, b in zip(cuts[:-1], cuts[1:])]

    def solve(theta: np.ndarray) -> tuple[list, np.ndarray, float, NormalEquations, list, list]:
        parts = [t.basis(theta[s]) for t, s in zip(terms, spans)]
        bases = [b for b, _ in parts]
        normal = NormalEquations(np.concatenate(bases, axis=1))
        solved = normal.solve(y)
        r = y - normal.B @ solved
        coef = np.split(solved, np.cumsum([b.shape[1] for b in bases])[:-1])  # the members' orders may differ
        return coef, r, float(np.vdot(r, r).real), normal, [f for _, f in parts], bases

    theta = np.concatenate([t.start() for t in terms])
    coef, r, cost, normal, factors, bases = solve(theta)
    before = cost
    slopes = [t.chords(theta[s]) for t, s in zip(terms, spans)]  # once, at the start (a chord)
    for _ in range(CUBIC_STEPS):
        cols = []
        for q, t in enumerate(terms):
            fit = y - r if len(terms) == 1 else bases[q] @ coef[q]
            cols += list(2j * np.pi * t.phases * fit)  # d model / d theta_k, the amplitudes held
            cols += [(slope * factors[q]) @ coef[q] for slope in slopes[q]]
        step, predicted = _gauss_newton_step(normal, r, np.stack(cols, axis=1), np.ones(len(theta), dtype=bool))
        if predicted <= 1e-6 * cost:
            break
        for t, s in zip(terms, spans):
            part = step[s]
            t.clip(part)
            step[s] = part
        halved = _halved_step(solve, theta, step, cost)
        if halved is None:
            break
        length, trial = halved
        theta = theta + length * step
        crawled = cost - trial[2] < CUBIC_CRAWL * cost
        coef, r, cost, normal, factors, bases = trial
        if crawled:
            break
    if cost >= before:
        return list(models), before, before
    return [t.fitted(theta[s], coef[q]) for q, (t, s) in enumerate(zip(terms, spans))], before, cost


# Each pulse's wavefront is a circle about the platform, not the plane wave of the band-limited model: a response's
# azimuth ridge bends away in range by |x|^2 / 2R (0.56 range nulls 45 m out at 1.9 km), and each look angle
# carries its own spatial chirp. The ridge coordinates then take second-order terms (ResponseModel.warp), fitted
# for each lone target by Gauss-Newton (:func:`_fit_warp`, amplitudes by linear least squares) and kept where they
# lower its samples' misfit under WARP_GAIN of the model's without. Campaign scene 20's T1 (partly lit, 17.6 deg
# squint): its azimuth ridge 88 nulls out was left at -48.8 dB, 2 dB over the image there.
WARP_GAIN = 0.8
WARP_STEPS = 10
WARP_DC = 1e-3  # nulls: the central difference of the basis along each ridge coordinate


def _fit_warps(fits: list, models: list[ResponseModel | None], live: list[int], reach: float) -> None:
    """Each lone 2D target's warp (:func:`_fit_warp`) on its box and ridge strips, the other groups' models
    subtracted; kept where it leaves under :data:`WARP_GAIN` of the misfit without. Updates ``models``."""
    reads = lambda members: len(members) == 1 and models[members[0]] is not None  # noqa: E731
    _prefetch_others(fits, models, live, reach, reads)
    for g, (members, _, _, far, y_far) in enumerate(fits):
        k, model = members[0], models[members[0]]
        if len(members) > 1 or model is None:
            continue
        rhs = _others_subtracted(y_far, far, members, live, models, reach)
        warped, before, after = _fit_warp(far, rhs, model, WARP_GAIN)
        if after < WARP_GAIN * before:
            models[k] = warped
            _prefetch_others(fits, models, live, reach, reads, refitted=g)


def _fit_warp(
    points: np.ndarray, y: np.ndarray, model: ResponseModel, gain: float | None = None
) -> tuple[ResponseModel, float, float]:
    """(model, misfit before, after): ``model`` with the warp (:attr:`ResponseModel.warp`, every second-order term
    of each ridge coordinate) that fits ``y`` on ``points`` best, by Gauss-Newton from none (its other parameters
    held; amplitudes by linear least squares, eliminated from the steps). With ``gain``, the search stops where it
    cannot leave under ``gain`` times the misfit before (:data:`LOSING_MARGIN`: it is kept only there)."""
    ndim = points.shape[0]
    A, p = _ridge_frame(model.position, model.ridges, model.nulls)
    x = np.asarray(points, dtype=float) - p[:, None]
    pairs = _chirp_pairs(ndim)
    phase = 2 * np.pi * (np.asarray(model.band_centre, dtype=float) @ x) + _chirp_phase(x, model.chirp)
    carrier = np.exp(1j * phase)
    quad = np.stack([(1.0 if i == j else 2.0) * x[i] * x[j] for i, j in pairs])  # (pairs, N)
    m = int(np.abs(model.orders).max())

    def tensor(w: np.ndarray) -> np.ndarray:
        W = np.zeros((ndim, ndim, ndim))
        for a in range(ndim):
            for q, (i, j) in enumerate(pairs):
                W[a, i, j] = W[a, j, i] = w[a * len(pairs) + q]
        return W

    def basis_at(c: np.ndarray) -> np.ndarray:
        if model.kappa is not None and np.any(model.kappa):
            cols = _columns(list(c), model.orders, model.kappa)
        else:
            per_axis = [np.stack(_shifted_sincs(ca, m)) for ca in c]
            cols = math.prod(per_axis[a][model.orders[:, a] + m] for a in range(ndim))
        if model.curvature:
            cols = cols + _curvature_sum(list(c), model.orders, None, model.curvature)
        return (np.asarray(cols) * carrier).T

    def solve(w: np.ndarray) -> tuple[np.ndarray, np.ndarray, float, NormalEquations, np.ndarray]:
        c = _warped(A @ x, x, tensor(w))
        coef, r, cost, normal = _amplitudes([basis_at(c)], y)
        return c, coef[0], cost, normal, r

    w = np.zeros(ndim * len(pairs))
    c, coef, cost, normal, r = solve(w)
    before = cost
    for n in range(WARP_STEPS):
        cols = []
        for a in range(ndim):
            dc = np.zeros_like(c)
            dc[a] = WARP_DC
            slope = (basis_at(c + dc) - basis_at(c - dc)) @ coef / (2 * WARP_DC)
            cols += [slope * q for q in quad]
        step, predicted = _gauss_newton_step(normal, r, np.stack(cols, axis=1), np.ones(len(cols), dtype=bool))
        if predicted <= 1e-6 * cost:
            break
        if gain is not None and _cannot_win(cost, predicted, WARP_STEPS - n, gain * before):
            break
        halved = _halved_step(solve, w, step, cost)
        if halved is None:
            break
        length, trial = halved
        w = w + length * step
        c, coef, cost, normal, r = trial
    return dataclasses.replace(model, coef=coef, warp=tensor(w)), before, cost


# The range edges of a SAR image's support are arcs about zero frequency (each pulse's band lies along its line of
# sight), not the chords the straight model draws: across the look angles dtheta they bow by dtheta^2 / 8 of the
# carrier, i.e. curvature beta = -dtheta^2 / (2 kappa) range bands per azimuth band squared (kappa = B / f_0, the
# keystone). A 2 deg rect beam at 150 MHz / 10 GHz: beta = -0.040 (1 % of the band at the azimuth edges); its range
# side lobes fan out over the look angles, and the straight model left -47 dB beside its range ridge, constant far
# along it (issue 20: the evaluate campaign's scenes 20, 21). Each lone target's bow is searched
# (:func:`_fit_curvatures`) within +-CURVATURE_LIMIT and kept where it lowers its samples' misfit under
# CURVATURE_GAIN of the straight one's.
CURVATURE_LIMIT = 0.2
CURVATURE_STEP = 0.025  # the search's coarse grid, then a bounded scalar search within a step of its best
CURVATURE_GAIN = 0.8
# Probed first (a 2 deg beam at 1.5 % bandwidth: -0.040; a 4 deg one: -0.16): the search runs only where one of
# them lowers the misfit under CURVATURE_PROBE_GAIN of the straight model's (Hamming and Gaussian tapers, whose
# edges are soft, and narrow look angles are left at once)
CURVATURE_PROBES = (0.04, 0.12)
CURVATURE_PROBE_GAIN = 0.9
CURVATURE_SIGN_KAPPA = 1e-3  # a fitted keystone beyond this sets the bow's sign


def _fit_curvatures(fits: list, models: list[ResponseModel | None], live: list[int], reach: float) -> set[int]:
    """Each lone target's range-edge bow (:func:`_curvature_sum`, :func:`_fit_curvature`) on its box and ridge
    strips (the other groups' models subtracted), kept where it leaves under :data:`CURVATURE_GAIN` of the
    straight model's misfit. Updates ``models`` in place; returns the targets given a bow."""
    bowed = set()
    reads = lambda members: len(members) == 1 and models[members[0]] is not None  # noqa: E731
    _prefetch_others(fits, models, live, reach, reads)
    for g, (members, _, _, far, y_far) in enumerate(fits):
        k, model = members[0], models[members[0]]
        if len(members) > 1 or model is None:
            continue
        rhs = _others_subtracted(y_far, far, members, live, models, reach)
        beta, coef, before, after = _fit_curvature(far, rhs, model)
        if after < CURVATURE_GAIN * before and beta:
            models[k] = dataclasses.replace(model, coef=coef, curvature=beta)
            bowed.add(k)
            _prefetch_others(fits, models, live, reach, reads, refitted=g)
    return bowed


def _fit_curvature(points: np.ndarray, y: np.ndarray, model: ResponseModel) -> tuple[float, np.ndarray, float, float]:
    """(curvature, amplitudes, misfit straight, misfit bowed): the bow within +-:data:`CURVATURE_LIMIT` whose
    model, amplitudes solved by linear least squares (band centre, chirp, widths and keystone as fitted
    straight), leaves the least |y - model|^2 on ``points``: a grid of :data:`CURVATURE_STEP`, then a bounded
    scalar search within a step of its best."""
    straight = response_basis(
        points, model.position, model.ridges, model.nulls, model.band_centre, model.orders, model.chirp, model.kappa
    )

    bow = _BowColumns(points, model)
    solved: dict[float, tuple[float, np.ndarray]] = {}  # per bow: (misfit, amplitudes)

    def misfit(beta: float) -> float:
        if beta not in solved:
            B = straight + bow(beta) if beta else straight
            coef = least_squares(B, y)
            r = y - B @ coef
            solved[beta] = (float(np.vdot(r, r).real), coef)
        return solved[beta][0]

    before = misfit(0.0)
    # the arcs bow toward zero frequency, the keystone's narrow end: beta has the sign of -kappa where it is fitted
    kappa = 0.0 if model.kappa is None else float(model.kappa[0])
    signs = (-1.0,) if kappa > CURVATURE_SIGN_KAPPA else (1.0,) if kappa < -CURVATURE_SIGN_KAPPA else (-1.0, 1.0)
    probes = [sg * b for sg in signs for b in CURVATURE_PROBES]
    if min(misfit(b) for b in probes) >= CURVATURE_PROBE_GAIN * before:  # no bow there: nothing to search
        return 0.0, solved[0.0][1], before, before
    grid = np.arange(-CURVATURE_LIMIT, CURVATURE_LIMIT + 0.5 * CURVATURE_STEP, CURVATURE_STEP)
    grid = grid[np.isin(np.sign(grid), (0.0, *signs))]
    best = float(grid[int(np.argmin([misfit(float(b)) if b else before for b in grid]))])
    lo, hi = max(-CURVATURE_LIMIT, best - CURVATURE_STEP), min(CURVATURE_LIMIT, best + CURVATURE_STEP)
    beta, least = _bounded_minimum(misfit, lo, hi, 2e-4)
    misfit(beta)  # the bounded search's best: solved already
    return beta, solved[beta][1], before, least


def _bounded_minimum(func: Callable[[float], float], lo: float, hi: float, xatol: float) -> tuple[float, float]:
    """(x, func(x)): the minimum of ``func`` on [lo, hi] by Brent's bounded search, step for step
    ``scipy.optimize.minimize_scalar(func, bounds=(lo, hi), method="bounded", options={"xatol": xatol})``
    (scipy 1.17's ``_minimize_scalar_bounded``, BSD licence: the same trial points, rounded alike, so the
    same answer), without importing scipy.optimize (0.2 s of CPU beside scipy.special, which the bow needs)."""
    sqrt_eps = math.sqrt(2.2e-16)
    golden_mean = 0.5 * (3.0 - math.sqrt(5.0))
    a, b = lo, hi
    fulc = a + golden_mean * (b - a)
    nfc, xf = fulc, fulc
    rat = e = 0.0
    x = xf
    fx = func(x)
    num = 1
    ffulc = fnfc = fx
    xm = 0.5 * (a + b)
    tol1 = sqrt_eps * abs(xf) + xatol / 3.0
    tol2 = 2.0 * tol1
    while abs(xf - xm) > (tol2 - 0.5 * (b - a)):
        golden = True
        if abs(e) > tol1:  # a parabola through the three best points
            golden = False
            r = (xf - nfc) * (fx - ffulc)
            q = (xf - fulc) * (fx - fnfc)
            p = (xf - fulc) * q - (xf - nfc) * r
            q = 2.0 * (q - r)
            if q > 0.0:
                p = -p
            q = abs(q)
            r = e
            e = rat
            if abs(p) < abs(0.5 * q * r) and p > q * (a - xf) and p < q * (b - xf):
                rat = (p + 0.0) / q
                x = xf + rat
                if (x - a) < tol2 or (b - x) < tol2:
                    rat = tol1 * (_sign(xm - xf) + float(xm - xf == 0))
            else:
                golden = True
        if golden:  # a golden-section step
            e = a - xf if xf >= xm else b - xf
            rat = golden_mean * e
        x = xf + (_sign(rat) + float(rat == 0)) * max(abs(rat), tol1)
        fu = func(x)
        num += 1
        if fu <= fx:
            if x >= xf:
                a = xf
            else:
                b = xf
            fulc, ffulc = nfc, fnfc
            nfc, fnfc = xf, fx
            xf, fx = x, fu
        else:
            if x < xf:
                a = x
            else:
                b = x
            if fu <= fnfc or nfc == xf:
                fulc, ffulc = nfc, fnfc
                nfc, fnfc = x, fu
            elif fu <= ffulc or fulc == xf or fulc == nfc:  # noqa: SIM109 (scipy's ==: NaN never equal)
                fulc, ffulc = x, fu
        xm = 0.5 * (a + b)
        tol1 = sqrt_eps * abs(xf) + xatol / 3.0
        tol2 = 2.0 * tol1
        if num >= 500:  # scipy's maxiter
            break
    return xf, fx


def _sign(v: float) -> float:
    """numpy's sign of a float: -1, 0 or 1 (NaN: NaN)."""
    return float(np.sign(v))


@single_blas
def residual_image(
    data: np.ndarray, models: Sequence[ResponseModel | None], block_samples: int = 1 << 18
) -> np.ndarray:
    """``data`` minus every fitted model over the whole image (complex128), in slabs along axis 0 (the
    reference: :func:`subtract_models` evaluates each model only where it can matter)."""
    out = np.array(data, dtype=np.complex128)
    rows = max(1, block_samples // max(1, math.prod(data.shape[1:])))
    for start in range(0, data.shape[0], rows):
        slab = (slice(start, min(data.shape[0], start + rows)),) + tuple(slice(0, n) for n in data.shape[1:])
        for model in models:
            if model is not None:
                out[slab] -= _model_on_box(slab, model)
    return out


# Each model is evaluated only on the image blocks where its envelope (an upper bound of |model|) reaches a
# level: first REACH_FIRST_DB below the strongest target's peak, then, once the residual's floor in the guard
# windows is known, REACH_BELOW_FLOOR_DB below that floor. A sample left out then changes the residual by
# less than the level (per model), so the floor, the false target and the RMS move by a few thousandths of a
# dB at most, and a model costs its ridges and the box around its peak instead of the whole image.
# Warped models go WARPED_REACH_DB deeper: their bound over a box is their exact coordinate range there
# (:func:`_warped_box_range`; before session 37, |W| times the box's farthest |x|^2 from the peak took in most of
# the image, and so subtracted them far below the level), and at the same level the truncation's largest error
# against the whole-image residual on 002 small two-step grew from 1.3e-4 to 2.4e-4 of the peak; 10 dB deeper,
# 8.1e-5, on 7.7 M samples instead of 17.0 M (docs/performance.md, session 37). Straight models keep the level
# (their bound was tight already: 000 small's and 002 plain's residuals the same bits).
REACH_FIRST_DB = -40.0
REACH_BELOW_FLOOR_DB = -40.0
WARPED_REACH_DB = -10.0
REACH_BLOCK = 32  # samples per block edge (2D); 3D cubes use REACH_BLOCK // 2


def _warped_box_range(A: np.ndarray, W: np.ndarray, mid: np.ndarray, half: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(centre, radius) (B, ndim): the range of the warped ridge coordinates c_a(x) = A_a x + x^T W_a x over each
    box of centre ``mid`` and half-widths ``half`` ((B, ndim) offsets from the peak, samples). c is quadratic,
    so at x = mid + d exactly c(mid) + g d + d^T W_a d, g = A_a + (W_a + W_a^T) mid: over |d| <= half it lies
    within sum |g| half + sum |W_a| half half of c(mid). The box's own warp term, not |W| times the box's
    farthest |x|^2 from the peak: far from the peak the model's ridges are where the warp puts them, and the
    boxes they do not reach are left out (002 small two-step at the same levels: 17.0 M -> 4.5 M samples; 7.7 M
    with :data:`WARPED_REACH_DB`)."""
    centre = mid @ A.T + np.einsum("bi,aij,bj->ba", mid, W, mid)
    grad = A[None] + np.einsum("aij,bj->bai", W + W.transpose(0, 2, 1), mid)
    radius = np.einsum("bai,bi->ba", np.abs(grad), half) + np.einsum("bi,aij,bj->ba", half, np.abs(W), half)
    return centre, radius


def envelope_bound(model: ResponseModel, lo: np.ndarray, hi: np.ndarray | None = None) -> np.ndarray:
    """Upper bound of |model| over each image box [lo, hi] ((B, ndim) inclusive index corners; ``hi`` None:
    at the points ``lo``): (B,).

    The model is a sum over orders n of coef_n prod_a sinc(c_a + n_a / 2) times a carrier of modulus 1, c =
    A (x - p) affine in the image index x, so over a box each c_a spans an interval (centre and radius) and
    |sinc| <= min(1, 1 / (pi d)), d the interval's distance from zero less the largest order shift. A
    keystoned support (the widths 1 + kappa u along the other axes growing with the last axis' band
    coordinate u) is a trapezoid: its response is, per sign, a sinc of c_last +- kappa c_a / 2 over pi c_a, so
    the last axis' distance shrinks by sum_a |kappa_a| |c_a| / 2 (that ridge fans out) and the widths reach 1
    + sum |kappa| / 2; the strips that approximate the trapezoid (:func:`_strip_factors`) get a factor of 2
    of margin, and their staircase's own ridges a term of their own."""
    A, p = _ridge_frame(model.position, model.ridges, model.nulls)
    radius: np.ndarray | None
    if hi is not None and model.warp is not None:
        centre, radius = _warped_box_range(A, np.asarray(model.warp, dtype=float), (lo + hi) / 2.0 - p, (hi - lo) / 2.0)
    else:
        centre = (lo - p if hi is None else (lo + hi) / 2.0 - p) @ A.T  # (B, ndim)
        # at points no radius (a zero one's sums and differences change no bit; 002 small plain bounds its other
        # groups' models at their fits' samples 1500 times)
        radius = None if hi is None else ((hi - lo) / 2.0) @ np.abs(A).T
        if model.warp is not None:  # at points (a fit's samples): the warp's norm times |x|^2
            radius = ((lo - p) ** 2).sum(axis=1)[:, None] * np.abs(model.warp).sum(axis=(1, 2))[None, :]
    magnitude = np.abs(centre)
    inner = magnitude if radius is None else magnitude - radius  # |c| at its least and most over each box
    outer = magnitude if radius is None else magnitude + radius
    return _envelope(model, inner, outer)


def envelope_floor(model: ResponseModel, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """A lower bound, per image box [lo, hi] ((B, ndim) inclusive index corners), of :func:`envelope_bound` at each
    of its points (an unwarped model): the bound with each term taken where the box makes it least, at the ridge
    coordinates' largest |c| where it falls with |c| (the sincs) and their least where it grows (a keystone's fan,
    a bow), (B,)."""
    if model.warp is not None:
        raise ValueError("envelope_floor: a warped model's bound at points is not bounded over boxes here")
    A, p = _ridge_frame(model.position, model.ridges, model.nulls)
    magnitude = np.abs(((lo + hi) / 2.0 - p) @ A.T)
    radius = ((hi - lo) / 2.0) @ np.abs(A).T
    return _envelope(model, magnitude + radius, np.maximum(0.0, magnitude - radius))


def _envelope(model: ResponseModel, inner: np.ndarray, outer: np.ndarray) -> np.ndarray:
    """:func:`envelope_bound` from the ridge coordinates' |c| (B, ndim) where the bound is taken: ``inner`` for the
    sincs' distances from their ridges (the bound falls as they grow), ``outer`` for the keystone's fan and the
    bow (it grows with them); the same |c| for both at a point."""
    shift = float(np.abs(model.orders).max()) / 2.0
    dist = np.maximum(0.0, inner - shift)
    kappa = model.kappa
    width, margin = 1.0, 1.0
    steps: float | np.ndarray = 0.0
    if kappa is not None and _keystoned(kappa):
        k = np.abs(np.asarray(kappa, dtype=float))
        # the strips' staircase: its steps' edges add ridges across the last axis every S nulls along it,
        # of about sum |kappa| / (4 pi |c_last|) whatever the other coordinates (bounded 4x over here)
        steps = float(k.sum()) / (np.pi * np.maximum(dist[:, -1], _strip_count(k) / 2.0))
        far = (outer[:, :-1] + shift) @ k
        dist[:, -1] = np.maximum(0.0, dist[:, -1] - far / 2.0)
        width, margin = 1.0 + float(k.sum()) / 2.0, 2.0
    env = np.minimum(width, 1.0 / (np.pi * np.maximum(dist, 1e-300)))
    bound = margin * env.prod(axis=-1) + steps
    if model.curvature:
        # the bow's term: |F(a, b)| <= 1, and for |a| > |b| (integrating by parts) 1 / (pi (|a| - |b|)) +
        # |b| / (pi (|a| - |b|)^2), b = curvature c_1 at most over the box; the straight sinc's bound besides
        b = abs(model.curvature) * outer[:, 1]
        d = np.maximum(dist[:, 0] - b, 1e-3)  # within 1e-3 of |b| the bound is 1 anyway
        fresnel = np.minimum(1.0, (1.0 + b / d) / (np.pi * d))
        bound = bound + env[:, 1] * (fresnel + env[:, 0])
    return float(np.abs(model.coef).sum()) * bound


def _block_grid(shape: tuple[int, ...]) -> tuple[list[np.ndarray], np.ndarray, np.ndarray]:
    """(edges per axis, lo, hi): the image cut into blocks, their inclusive corners (B, ndim) in C order."""
    size = REACH_BLOCK if len(shape) <= 2 else max(4, REACH_BLOCK // 2)
    edges = [np.append(np.arange(0, n, size), n) for n in shape]
    starts = np.meshgrid(*[e[:-1] for e in edges], indexing="ij")
    stops = np.meshgrid(*[e[1:] - 1 for e in edges], indexing="ij")
    return edges, np.stack([s.ravel() for s in starts], axis=1), np.stack([s.ravel() for s in stops], axis=1)


def _boxes(needed: np.ndarray, edges: list[np.ndarray]) -> list[tuple[slice, ...]]:
    """Boxes (slices) covering the True blocks of ``needed`` (the block grid's shape): runs along the last
    axis, merged over consecutive blocks of the axis before it where their runs are the same."""

    def runs(row: np.ndarray) -> list[tuple[int, int]]:
        d = np.diff(np.concatenate([[0], row.astype(np.int8), [0]]))
        return list(zip(np.flatnonzero(d == 1).tolist(), np.flatnonzero(d == -1).tolist()))

    last = edges[-1]
    if needed.ndim == 1:
        return [(slice(int(last[a]), int(last[b])),) for a, b in runs(needed)]
    done: list = []
    open_: dict[tuple, list[int]] = {}  # (outer blocks, run) -> [first, last] block along the axis before the last
    for lead in np.ndindex(*needed.shape[:-1]):
        outer, i = lead[:-1], lead[-1]
        for run in runs(needed[lead]):
            key = (outer, run)
            if key in open_ and open_[key][1] == i - 1:
                open_[key][1] = i
                continue
            if key in open_:
                done.append((key, open_[key]))
            open_[key] = [i, i]
    done += list(open_.items())
    inner = edges[-2]
    return [
        tuple(slice(int(edges[a][k]), int(edges[a][k + 1])) for a, k in enumerate(outer))
        + (slice(int(inner[first]), int(inner[stop + 1])), slice(int(last[run[0]]), int(last[run[1]])))
        for (outer, run), (first, stop) in done
    ]


@single_blas
def subtract_models(
    out: np.ndarray,
    models: Sequence[ResponseModel | None],
    level: float,
    above: float = np.inf,
    block_samples: int = 1 << 18,
) -> None:
    """Subtract from ``out`` (in place) every model on the blocks where its :func:`envelope_bound` lies in
    [level, above): elsewhere it is below ``level`` (or was subtracted by an earlier call with that level). A
    warped model's levels are :data:`WARPED_REACH_DB` lower."""
    edges, lo, hi = _block_grid(out.shape)
    grid = tuple(len(e) - 1 for e in edges)
    parts: list[tuple[tuple[slice, ...], ResponseModel]] = []  # in the order they are subtracted
    for model in models:
        if model is None:
            continue
        bound = envelope_bound(model, lo, hi)
        deeper = 1.0 if model.warp is None else 10 ** (WARPED_REACH_DB / 20)
        needed = ((bound >= level * deeper) & (bound < above * deeper)).reshape(grid)
        if not needed.any():
            continue
        for box in _boxes(needed, edges):
            rows = max(1, block_samples // max(1, math.prod(s.stop - s.start for s in box[1:])))
            for start in range(box[0].start, box[0].stop, rows):
                parts.append(((slice(start, min(box[0].stop, start + rows)),) + box[1:], model))
    # each part's values on threads (they read only their model), subtracted in this order
    for (part, _), values in zip(parts, ordered_map(lambda p: _model_on_box(*p), parts)):
        out[part] -= values


def _exclusion_mask(
    shape: tuple[int, ...],
    axes: Sequence[_Axis],
    truth: np.ndarray,
    peaks: Sequence[np.ndarray],
    cells: float,
    broadening: Sequence[float] = (),
) -> np.ndarray:
    """True outside the +-``cells`` boxes around every truth and found peak; the boxes of the first
    len(broadening) truth rows and peaks are widened by those factors (a target's measured main lobe over
    its theory's)."""
    from sarproc.quality.metrics import window_slices  # metrics imports this module

    outside = np.ones(shape, dtype=bool)
    # every truth row (unmeasured targets of a --targets subset included) and every found peak
    centres = [np.rint([ax.to_index(x) for ax, x in zip(axes, t)]).astype(int) for t in truth]

    def factor(i: int) -> float:
        return broadening[i] if i < len(broadening) else 1.0

    factors = [factor(i) for i in range(len(centres))] + [factor(i) for i in range(len(peaks))]
    for c, f in zip(centres + list(peaks), factors):
        outside[window_slices(c, [ax.cells_to_samples(cells * f) for ax in axes], shape)] = False
    return outside


def _misfit_targets(
    mag: np.ndarray,
    axes: Sequence[_Axis],
    peaks: Sequence[np.ndarray],
    reports: Sequence[TargetReport],
    params: EvaluateParams,
    own_nulls: Sequence[np.ndarray | None] = (),
) -> list[int]:
    """Indices of the targets whose residual (``mag``) inside the box their model was fitted on (+-fit_nulls of
    their own null spacing ``own_nulls``, widened as their main lobe measured) is over :data:`MISFIT_DB` of
    their peak: the model does not fit them. Good fits leave -35 dB or less there (the two-step PFA's seams,
    the worst of the test scenes)."""
    from sarproc.quality.metrics import window_slices  # metrics imports this module

    out = []
    for i, (peak, report) in enumerate(zip(peaks, reports)):
        box = window_slices(peak, _fit_box(axes, report, params, _own(own_nulls, i)), mag.shape)
        if report.peak_amplitude > 0 and mag[box].max() > report.peak_amplitude * 10 ** (MISFIT_DB / 20):
            out.append(i)
    return out


def _ghosts_fill_box(
    residual: np.ndarray,
    axes: Sequence[_Axis],
    peak: np.ndarray,
    report: TargetReport,
    model: ResponseModel | None,
    params: EvaluateParams,
    own_null: np.ndarray | None,
    half: Sequence[int],
) -> bool:
    """True where what a target's ``model`` leaves over :data:`MISFIT_DB` in its fit box is ghosts, not its
    own misfit (:data:`GHOST_LEFT_DB`): each strongest residual peak there, outside the target's main lobe box,
    a point response of the model's shape, up to :data:`GHOST_TRIES` of them."""
    from sarproc.quality.metrics import refine_false_target, window_slices  # metrics imports this module

    if model is None or not report.peak_amplitude > 0:
        return False
    fit = np.array(_fit_box(axes, report, params, own_null))
    reach = np.ceil(GHOST_NULLS * np.asarray(model.nulls, dtype=float)).astype(int)
    # the ghosts are taken out of a copy of the box and the margin the fits and the peak refinement reach into
    region = window_slices(peak, fit + np.maximum(reach, np.asarray(half)) + 1, residual.shape)
    origin = np.array([r.start for r in region])
    local = np.array(residual[region], dtype=np.complex128)
    box = window_slices(peak - origin, fit, local.shape)
    level = report.peak_amplitude * 10 ** (MISFIT_DB / 20)
    lobe = np.array(
        [ax.cells_to_samples(params.exclusion_cells * main_lobe_broadening(report)) for ax in axes], dtype=float
    )
    for _ in range(GHOST_TRIES + 1):
        mag = np.abs(local[box])
        j = np.unravel_index(int(np.argmax(mag)), mag.shape)
        if mag[j] <= level:
            return True
        k = np.array([s.start + i for s, i in zip(box, j)])
        if np.all(np.abs(k + origin - peak) <= lobe):  # on its own main lobe: a misfit, whatever lies beside it
            return False
        pos, _ = refine_false_target(local, k, half)
        win = window_slices(k, reach, local.shape)
        grid = np.meshgrid(*[np.arange(w.start, w.stop, dtype=float) + o for w, o in zip(win, origin)], indexing="ij")
        moved = dataclasses.replace(model, position=np.asarray(pos, dtype=float) + origin)
        g = model_values(np.array([x.ravel() for x in grid]), moved)
        y = local[win].ravel()
        gg = float(np.vdot(g, g).real)
        if gg == 0.0:
            return False
        left = y - (np.vdot(g, y) / gg) * g
        if float(np.vdot(left, left).real) > 10 ** (GHOST_LEFT_DB / 10) * float(np.vdot(y, y).real):
            return False
        local[win] = left.reshape(local[win].shape)
    return False


def _misfit_details(
    mag: np.ndarray,
    axes: Sequence[_Axis],
    peaks: Sequence[np.ndarray],
    reports: Sequence[TargetReport],
    params: EvaluateParams,
    misfit: Sequence[int],
    own_nulls: Sequence[np.ndarray | None] = (),
) -> tuple[Misfit, ...]:
    """Per ``misfit`` target (indices) with a positive peak: the strongest residual (``mag``) in its fit box
    (:func:`_fit_box`), relative to its own peak, and that pixel's offset from its peak."""
    from sarproc.quality.metrics import window_slices  # metrics imports this module

    out = []
    for i in misfit:
        peak, report = np.rint(peaks[i]).astype(int), reports[i]
        if not report.peak_amplitude > 0:
            continue
        box = window_slices(peak, _fit_box(axes, report, params, _own(own_nulls, i)), mag.shape)
        chip = mag[box]
        k = np.unravel_index(int(np.argmax(chip)), chip.shape)
        samples = [int(s.start + j - p) for s, j, p in zip(box, k, peak)]
        out.append(
            Misfit(
                name=report.name,
                level_db=float(20 * np.log10(max(float(chip[k]), 1e-300) / report.peak_amplitude)),
                offset={ax.name: float(n * ax.step) for ax, n in zip(axes, samples)},
                samples={ax.name: n for ax, n in zip(axes, samples)},
            )
        )
    return tuple(out)


def _fit_box(
    axes: Sequence[_Axis], report: TargetReport, params: EvaluateParams, own_null: np.ndarray | None = None
) -> list[int]:
    """Half-sizes in samples of the box a target's model is fitted on (+-fit_nulls of ``own_null``, its own null
    spacing in samples per axis, as :func:`_fit_samples` takes it; the image's where None), widened as its main
    lobe measured. A partly lit target's own null is many of the image's (campaign scene 12's T2, 9 % lit: 7.2
    in azimuth), and its model is fitted, and can fail, that far out."""
    nulls = params.fit_nulls * main_lobe_broadening(report)
    if own_null is None:
        return [ax.nulls_to_samples(nulls) for ax in axes]
    return [max(ax.nulls_to_samples(nulls), int(math.ceil(nulls * n))) for ax, n in zip(axes, own_null)]


def _own(own_nulls: Sequence[np.ndarray | None], i: int) -> np.ndarray | None:
    """Target ``i``'s own null spacing (samples per axis), None where not given."""
    return own_nulls[i] if i < len(own_nulls) else None


def main_lobe_broadening(report: TargetReport) -> float:
    """How much wider a target's measured main lobe is than its theory's (at least 1): a defocused target's
    own main lobe is not a false target, however badly its ideal response model fits it."""
    ratios = [m.irw_ratio for m in report.axes if np.isfinite(m.irw_ratio)]
    return max([1.0, *ratios])


def own_cell_broadening(report: TargetReport, axes: Sequence[_Axis]) -> float:
    """How much wider a target's own theoretical IRW is than the image's resolution cell (the largest over the
    axes, at least 1): a weighted target's main lobe (Hamming: 1.30 / B against the image's 0.886 / B, its first
    nulls at 2 / B) spans more of the image's cells than the exclusion's +-2 cover."""
    cell = {ax.name: ax.irw for ax in axes}
    ratios = [
        m.irw_theory / cell[m.axis]
        for m in report.axes
        if m.axis in cell and cell[m.axis] > 0 and m.irw_theory is not None and np.isfinite(m.irw_theory)
    ]
    return max([1.0, *ratios])


def _main_lobe_residue(
    mag: np.ndarray,
    axes: Sequence[_Axis],
    peaks: Sequence[np.ndarray],
    reports: Sequence[TargetReport],
    params: EvaluateParams,
) -> list[float]:
    """Per target, the strongest residual (``mag``) in its main lobe box (+-exclusion_cells, widened as the
    search's exclusion: :func:`_search_masks`): what its model leaves on its own response, where no ghost is
    searched."""
    from sarproc.quality.metrics import window_slices  # metrics imports this module

    out = []
    for peak, r in zip(peaks, reports):
        cells = params.exclusion_cells * main_lobe_broadening(r) * own_cell_broadening(r, axes)
        box = window_slices(np.rint(peak).astype(int), [ax.cells_to_samples(cells) for ax in axes], mag.shape)
        out.append(float(mag[box].max()))
    return out


def _search_masks(
    shape: tuple[int, ...],
    axes: Sequence[_Axis],
    truth: np.ndarray,
    peaks: Sequence[np.ndarray],
    reports: Sequence[TargetReport],
    params: EvaluateParams,
    misfit: Sequence[int] = (),
    own_nulls: Sequence[np.ndarray | None] = (),
) -> tuple[np.ndarray, np.ndarray]:
    """(search, guard): where false targets are searched on the residual (outside every main lobe, each as
    wide as measured: :func:`main_lobe_broadening`) and where its floor is taken (the targets' guard windows,
    main lobes excluded). Truth rows and peaks are in the reports' order; truth rows beyond them (targets
    left out of a --targets subset) have no fitted model, so their whole guard windows stay out of both
    (their side lobes are still in the residual); the ``misfit`` targets' (indices) fit boxes, where their
    models do not fit them, stay out of the search."""
    from sarproc.quality.metrics import window_slices  # metrics imports this module

    measured = len(reports)
    broadening = [main_lobe_broadening(r) * own_cell_broadening(r, axes) for r in reports]
    search = _exclusion_mask(shape, axes, truth, peaks, params.exclusion_cells, broadening)
    if len(truth) > measured:
        search &= _exclusion_mask(shape, axes, truth[measured:], [], params.guard_cells)
    for i in misfit:
        box = window_slices(peaks[i], _fit_box(axes, reports[i], params, _own(own_nulls, i)), shape)
        search[box] = False
    guard = ~_exclusion_mask(shape, axes, truth, peaks, params.guard_cells) & search
    return search, guard


def residual_false_target(
    data: np.ndarray,
    models: Sequence[ResponseModel | None],
    axes: Sequence[_Axis],
    truth: np.ndarray,
    peaks: Sequence[np.ndarray],
    reports: Sequence[TargetReport],
    half: Sequence[int],
    params: EvaluateParams,
    unmodelled: Sequence[int] = (),
    own_nulls: Sequence[np.ndarray | None] = (),
) -> tuple[FalseTarget | None, ResidualFloor, FalseTargetList | None]:
    """:func:`_residual_false_target` of ``data`` minus every model, each evaluated only where it reaches
    :data:`REACH_FIRST_DB` below the strongest peak, then :data:`REACH_BELOW_FLOOR_DB` below the floor so
    found (:func:`subtract_models`; ``params.exact``: over the whole image, :func:`residual_image`).
    ``unmodelled``: the targets whose response the model is known not to describe (a fan of side lobes),
    treated as misfits whatever their residual. ``own_nulls``: each target's own null spacing (samples per axis,
    the one its model's fit box was taken in; None: the image's)."""
    frames = [None if m is None else _ridge_frame(m.position, m.ridges, m.nulls)[0] for m in models]
    if params.exact:
        with numerics(exact=True):
            residual = residual_image(data, models)
            return _residual_false_target(
                residual, axes, truth, peaks, reports, half, params, unmodelled, frames, own_nulls, models
            )
    ref = max(r.peak_amplitude for r in reports)
    out = np.array(data, dtype=np.complex128)
    level = ref * 10 ** (REACH_FIRST_DB / 20)
    subtract_models(out, models, level)
    search, guard = _search_masks(out.shape, axes, truth, peaks, reports, params)
    while guard.any():  # down to REACH_BELOW_FLOOR_DB under the floor, which falls as more is subtracted
        want = max(float(np.abs(out[guard]).max()) * 10 ** (REACH_BELOW_FLOOR_DB / 20), ref * 1e-12)
        if want >= 0.999 * level:
            break
        subtract_models(out, models, want, above=level)
        level = want
    return _residual_false_target(out, axes, truth, peaks, reports, half, params, unmodelled, frames, own_nulls, models)


def _residual_false_target(
    residual: np.ndarray,
    axes: Sequence[_Axis],
    truth: np.ndarray,
    peaks: Sequence[np.ndarray],
    reports: Sequence[TargetReport],
    half: Sequence[int],
    params: EvaluateParams,
    unmodelled: Sequence[int] = (),
    frames: Sequence[np.ndarray | None] = (),
    own_nulls: Sequence[np.ndarray | None] = (),
    models: Sequence[ResponseModel | None] = (),
) -> tuple[FalseTarget | None, ResidualFloor, FalseTargetList | None]:
    """(FalseTarget or None, ResidualFloor, FalseTargetList or None): strongest residual response outside the
    main lobes, the residual's floor inside the targets' guard windows (``unmodelled`` counted as misfits) and
    every false target over that floor (:func:`_listed_false_targets`; None without a finite floor).
    ``frames``: each target's model's ridge frame A (:func:`_ridge_frame`; None: no model). ``models``: each
    target's model; with them a target whose fit box holds only ghosts over :data:`MISFIT_DB`
    (:func:`_ghosts_fill_box`) is no misfit, so its box is searched and the ghosts found."""
    from sarproc.quality.metrics import FalseTarget, refine_false_target  # metrics imports this module

    ref = max(reports, key=lambda r: r.peak_amplitude)
    mag = np.abs(residual)
    misfit = [
        i
        for i in _misfit_targets(mag, axes, peaks, reports, params, own_nulls)
        if not models
        or not _ghosts_fill_box(
            residual, axes, np.rint(peaks[i]).astype(int), reports[i], models[i], params, _own(own_nulls, i), half
        )
    ]
    misfit = sorted(set(misfit) | set(unmodelled))
    search, guard = _search_masks(residual.shape, axes, truth, peaks, reports, params, misfit, own_nulls)

    def db(v: float) -> float:
        return float(20 * np.log10(v / ref.peak_amplitude)) if v > 0 and ref.peak_amplitude > 0 else -np.inf

    maxima = _local_maxima(np.where(search, mag, 0.0))  # of the search region, for the floor and the list
    # each target's fit box in nulls of its model's ridges and what its model leaves on its main lobe box
    # (the misfit skirt's test; none without the models' frames)
    boxes = [params.fit_nulls * main_lobe_broadening(r) for r in reports] if frames else []
    levels = _main_lobe_residue(mag, axes, peaks, reports, params) if frames else []
    floor = ResidualFloor(
        floor_db=db(_floor_beside_ghosts(mag, guard, maxima, axes, peaks, params, frames, misfit, boxes, levels))
        if guard.any()
        else -np.inf,
        rms_db=db(float(np.sqrt(np.mean(mag[search] ** 2)))) if search.any() else -np.inf,
        exclusion_cells=params.exclusion_cells,
        misfit_targets=tuple(reports[i].name for i in misfit),
        orders=len(residual_model_orders(residual.ndim, params.residual_orders)),
        misfits=_misfit_details(mag, axes, peaks, reports, params, misfit, own_nulls),
    )
    listed = (
        _listed_false_targets(
            residual, mag, search, maxima, axes, peaks, reports, half, params, floor.floor_db, frames, boxes, levels
        )
        if math.isfinite(floor.floor_db) and ref.peak_amplitude > 0
        else None
    )
    if not search.any():
        return None, floor, listed
    k = np.unravel_index(np.argmax(np.where(search, mag, -1.0)), mag.shape)
    pixel = float(mag[k])
    position = {ax.name: float(ax.to_coord(i)) for ax, i in zip(axes, k)}
    if pixel == 0.0 or ref.peak_amplitude == 0.0:
        return (
            FalseTarget(level_db=-np.inf, position=position, pixel_level_db=-np.inf, reference_target=ref.name),
            floor,
            listed,
        )
    pos, value = refine_false_target(residual, k, half)
    near, dist = _nearest_target(np.asarray(pos, dtype=float), axes, peaks)
    # a ghost is on the list (its strongest entry: the list is ordered by pixel, as k is chosen); else this
    # pixel is the floor or a target's residue, and the list says why it left it out
    ghost = (
        None
        if listed is None
        else any(np.allclose([e.index[ax.name] for ax in axes], pos, atol=0.5) for e in listed.entries)
    )
    return (
        FalseTarget(
            level_db=db(max(abs(value), pixel)),
            position={ax.name: float(ax.to_coord(p)) for ax, p in zip(axes, pos)},
            pixel_level_db=db(pixel),
            reference_target=ref.name,
            nearest_target=reports[near].name,
            nearest_cells=float(dist[near]),
            ghost=ghost,
        ),
        floor,
        listed,
    )


def _local_maxima(x: np.ndarray) -> np.ndarray:
    """True where ``x`` is the largest of its 3 samples per axis (the edge sample repeated beyond the edge):
    scipy.ndimage.maximum_filter(x, 3, mode="nearest") == x without importing scipy.ndimage (45 ms of
    evaluate's start; focus.multichannel.detection has one, but quality does not import focus)."""
    padded = np.pad(x, 1, mode="edge")
    out = np.ones(x.shape, dtype=bool)
    for shift in itertools.product(range(3), repeat=x.ndim):
        out &= x >= padded[tuple(slice(o, o + n) for o, n in zip(shift, x.shape))]
    return out


def _ridge_envelope(offset: np.ndarray, frame: np.ndarray) -> np.ndarray:
    """Sinc side-lobe envelope, per row of ``offset`` (samples from a peak), of a response whose ridge frame
    is ``frame`` (rows: the ridge coordinates in nulls per sample): prod over its axes of min(1, 1 / (pi c))."""
    c = np.abs(offset @ frame.T)
    return np.prod(np.minimum(1.0, 1.0 / (np.pi * np.maximum(c, 1e-12))), axis=1)


def _nearest_target(x: np.ndarray, axes: Sequence[_Axis], peaks: Sequence[np.ndarray]) -> tuple[int, np.ndarray]:
    """(index of the target whose peak is nearest ``x``, every target's distance), in resolution cells of the
    image's theory (root sum of squares over the axes)."""
    cells = np.array([abs(ax.step) / ax.irw for ax in axes])
    centres = np.array([np.asarray(p, dtype=float) for p in peaks])
    dist = np.sqrt((((centres - x) * cells) ** 2).sum(axis=1))
    return int(np.argmin(dist)), dist


def _ridge_frames(
    axes: Sequence[_Axis], peaks: Sequence[np.ndarray], frames: Sequence[np.ndarray | None]
) -> np.ndarray:
    """(targets, ndim, ndim): each target's ridge frame (the image axes' nulls where it has no model)."""
    image_frame = np.diag([1.0 / ax.null for ax in axes])
    return np.array([image_frame if f is None else f for f in list(frames) + [None] * (len(peaks) - len(frames))])


class _Residues:
    """The maxima ``others`` (positions (n, ndim), values, ``is_max``: which are local maxima) that decide
    whether a maximum is the residue of a target's model: a link of a chain along its ridge
    (:meth:`on_a_chain`) or the skirt of its misfit (:meth:`in_a_misfit`). ``boxes``: per target, the half
    width of its fit box in nulls of its ridge frame, ``misfit_levels`` the strongest residual in its main
    lobe box (both empty: no misfit test)."""

    def __init__(
        self,
        others: np.ndarray,
        other_values: np.ndarray,
        is_max: np.ndarray,
        centres: np.ndarray,
        ridge_frames: np.ndarray,
        boxes: Sequence[float] = (),
        misfit_levels: Sequence[float] = (),
    ) -> None:
        self.others, self.values, self.is_max = others, other_values, is_max
        self.centres, self.frames = centres, ridge_frames
        self.boxes, self.misfit_levels = list(boxes), list(misfit_levels)
        self._coords: dict[int, np.ndarray] = {}
        self._chains: dict[tuple[int, int], np.ndarray] = {}

    def coords(self, m: int) -> np.ndarray:
        """(n, ndim): every one of ``others`` in target m's ridge coordinates (nulls)."""
        if m not in self._coords:
            self._coords[m] = (self.others - self.centres[m]) @ self.frames[m].T
        return self._coords[m]

    def chain(self, m: int, i: int) -> np.ndarray:
        """Which of ``others`` lie on target m's ridge that runs across axis i: within a null of its straight
        line, or followed from there along maxima as it bends (:data:`RIDGE_STEP_NULLS`,
        :data:`RIDGE_BEND_NULLS`)."""
        if (m, i) not in self._chains:
            c = self.coords(m)
            across, along = c[:, i], np.delete(c, i, axis=1)
            out = np.abs(across) < 1.0
            grow = self.is_max & ~out & (np.abs(across) <= RIDGE_BEND_NULLS)
            front = out & self.is_max
            reach = np.linalg.norm(along, axis=1)
            while front.any() and grow.any():
                cand, f = np.flatnonzero(grow), np.flatnonzero(front)
                near = (
                    (np.abs(across[cand][:, None] - across[f][None, :]) < 1.0)
                    & np.all(np.abs(along[cand][:, None, :] - along[f][None, :, :]) <= RIDGE_STEP_NULLS, axis=2)
                    & (reach[cand][:, None] > reach[f][None, :])
                )
                new = cand[near.any(axis=1)]
                out[new] = True
                grow[new] = False
                front = np.zeros_like(out)
                front[new] = True
            self._chains[(m, i)] = out
        return self._chains[(m, i)]

    def _index(self, k: np.ndarray) -> int | None:
        hit = np.flatnonzero(np.all(self.others == k, axis=1))
        return int(hit[0]) if hit.size else None

    def on_a_chain(self, k: np.ndarray, value: float, own_lobes: np.ndarray) -> bool:
        """True where ``k`` lies on a target's ridge (:meth:`chain`) on which another of ``others`` (outside
        ``own_lobes``, k's own main lobe and side lobes) stands within :data:`PEEL_MARGIN_DB` of ``value``: a
        link of the chain of maxima a model leaves along its target's ridge where it misses the spectral
        shape."""
        margin = 10 ** (PEEL_MARGIN_DB / 20)
        j = self._index(k)
        ridge = np.einsum("mij,mj->mi", self.frames, k - self.centres)  # nulls along each target's ridge axes
        for m, i in zip(*np.nonzero(np.abs(ridge) < RIDGE_BEND_NULLS)):  # near target m's ridge across axis i
            chain = self.chain(int(m), int(i))
            if abs(ridge[m, i]) >= 1.0 and (j is None or not chain[j]):
                continue
            band = ~own_lobes & chain
            if band.any() and value < margin * float(self.values[band].max()):
                return True
        return False

    def in_a_misfit(self, k: np.ndarray, value: float) -> bool:
        """True where ``k`` lies in a target's fit box (``boxes``, nulls of its ridge frame) and ``value`` does
        not stand :data:`PEEL_MARGIN_DB` over what that target's model leaves on its own main lobe box
        (``misfit_levels``): the skirt of that model's misfit, not a ghost."""
        margin = 10 ** (PEEL_MARGIN_DB / 20)
        for m, (box, level) in enumerate(zip(self.boxes, self.misfit_levels)):
            if value < margin * level and np.all(np.abs(self.frames[m] @ (k - self.centres[m])) <= box):
                return True
        return False


def _floor_beside_ghosts(
    mag: np.ndarray,
    guard: np.ndarray,
    maxima: np.ndarray,
    axes: Sequence[_Axis],
    peaks: Sequence[np.ndarray],
    params: EvaluateParams,
    frames: Sequence[np.ndarray | None] = (),
    misfit: Sequence[int] = (),
    boxes: Sequence[float] = (),
    misfit_levels: Sequence[float] = (),
) -> float:
    """The residual floor (amplitude): the strongest pixel of ``mag`` in ``guard`` once the ghosts standing
    there are set aside. The guard's strongest pixel, while it is one of ``maxima`` (the local maxima of the
    search region), is
    set aside with its own main lobe (+-exclusion cells) and side-lobe envelope
    (:data:`SIDE_LOBE_ALLOWANCE`, the nearest target's ridge frame), at most :data:`LIST_CAP` times; the floor
    is the strongest pixel left after the largest number m of these whose m-th stands :data:`PEEL_MARGIN_DB`
    over it (so two ghosts of like level are both set aside), none where none does. A maximum on a target's
    ridge (within a null of it) must also stand that margin over the rest of the ridge in the guard: a model
    that misses its target's spectral shape leaves a chain of maxima there (paired lobes, a defocused ridge),
    the floor's very subject, not ghosts. Nor is a maximum in a ``misfit`` target's guard window set aside:
    that model is known not to describe its target, and what it leaves reaches beyond its fit box. Nor is a
    maximum that follows a target's ridge as it bends, or one in a target's fit box (``boxes``: per target, its
    half width in nulls) that does not stand the margin over what its model leaves on its own main lobe box
    (``misfit_levels``; :class:`_Residues`)."""
    centres = np.array([np.asarray(p, dtype=float) for p in peaks])
    ridge_frames = _ridge_frames(axes, peaks, frames)
    own = np.array([ax.cells_to_samples(params.exclusion_cells) for ax in axes])
    reach = np.array([ax.cells_to_samples(params.guard_cells) for ax in axes])
    where = np.argwhere(guard)
    values = mag[guard]
    residues = _Residues(where, values, maxima[guard], centres, ridge_frames, boxes, misfit_levels)
    alive = np.ones(values.size, dtype=bool)
    margin = 10 ** (PEEL_MARGIN_DB / 20)
    tops = [float(values.max())]
    floor = tops[0]
    for _ in range(LIST_CAP):
        j = int(np.argmax(np.where(alive, values, -1.0)))
        k = where[j]
        if not maxima[tuple(k)] or any(np.all(np.abs(k - centres[i]) <= reach) for i in misfit):
            break
        offset = where - k
        frame = ridge_frames[_nearest_target(k.astype(float), axes, peaks)[0]]
        envelope = _ridge_envelope(offset.astype(float), frame)
        own_lobes = np.all(np.abs(offset) <= own, axis=1) | (values <= SIDE_LOBE_ALLOWANCE * envelope * values[j])
        if residues.on_a_chain(k, float(values[j]), own_lobes | ~alive) or residues.in_a_misfit(k, float(values[j])):
            return floor
        alive &= ~own_lobes
        if not alive.any():
            break
        tops.append(float(values[alive].max()))
        if tops[-2] >= margin * tops[-1]:
            floor = tops[-1]
    return floor


def _listed_false_targets(
    residual: np.ndarray,
    mag: np.ndarray,
    search: np.ndarray,
    maxima: np.ndarray,
    axes: Sequence[_Axis],
    peaks: Sequence[np.ndarray],
    reports: Sequence[TargetReport],
    half: Sequence[int],
    params: EvaluateParams,
    floor_db: float,
    frames: Sequence[np.ndarray | None] = (),
    boxes: Sequence[float] = (),
    misfit_levels: Sequence[float] = (),
) -> FalseTargetList:
    """:class:`FalseTargetList` of the residual: its local maxima (3 samples per axis) in ``search`` whose pixel
    is over ``floor_db`` + :data:`LIST_MARGIN_DB` and is no stronger one's main or side lobe, nor a link of a
    chain along a target's ridge (:meth:`_Residues.on_a_chain`; counted in ``on_ridges``) or the skirt of a
    target's model misfit (:meth:`_Residues.in_a_misfit`; ``in_misfits``), each refined like the single
    false target. ``maxima``: the local maxima of the search region. ``frames``: per target, its model's ridge
    frame (None: the image axes' nulls)."""
    from sarproc.quality.metrics import refine_false_target  # metrics imports this module

    ref = max(r.peak_amplitude for r in reports)
    threshold_db = floor_db + LIST_MARGIN_DB
    inside = np.where(search, mag, 0.0)  # zero outside, so an excluded main lobe hides no maximum beside it
    local = maxima & (inside > ref * 10 ** (threshold_db / 20))
    found = np.argwhere(local)
    found = found[np.argsort(-inside[local], kind="stable")]  # strongest first; ties in the argmax's order
    own = np.array([ax.cells_to_samples(params.exclusion_cells) for ax in axes])
    centres = np.array([np.asarray(p, dtype=float) for p in peaks])

    # the maxima a chain's links are compared with: down to PEEL_MARGIN_DB under the threshold
    others = np.argwhere(maxima & (inside > ref * 10 ** ((threshold_db - PEEL_MARGIN_DB) / 20)))
    other_values = inside[tuple(others.T)]
    ridge_frames = _ridge_frames(axes, peaks, frames)
    residues = _Residues(
        others, other_values, np.ones(len(others), dtype=bool), centres, ridge_frames, boxes, misfit_levels
    )
    kept: list[np.ndarray] = []
    stronger: list[np.ndarray] = []  # those kept and the chains' links: their lobes are not listed either
    stronger_frames: list[np.ndarray] = []
    on_ridges = in_misfits = 0
    for k in found:
        if stronger:
            offset = k - np.array(stronger)
            if np.any(np.all(np.abs(offset) <= own, axis=1)):  # a stronger one's main lobe
                continue
            c = np.abs(np.einsum("mij,mj->mi", np.array(stronger_frames), offset))
            envelope = np.prod(np.minimum(1.0, 1.0 / (np.pi * np.maximum(c, 1e-12))), axis=1)
            if np.any(inside[tuple(k)] <= SIDE_LOBE_ALLOWANCE * envelope * inside[tuple(np.array(stronger).T)]):
                continue  # under a stronger one's side-lobe envelope
        frame = ridge_frames[_nearest_target(k.astype(float), axes, peaks)[0]]
        offset = others - k
        own_lobes = np.all(np.abs(offset) <= own, axis=1) | (
            other_values <= SIDE_LOBE_ALLOWANCE * _ridge_envelope(offset.astype(float), frame) * inside[tuple(k)]
        )
        stronger.append(k)
        stronger_frames.append(frame)
        if residues.on_a_chain(k, float(inside[tuple(k)]), own_lobes):
            on_ridges += 1
            continue
        if residues.in_a_misfit(k, float(inside[tuple(k)])):
            in_misfits += 1
            continue
        kept.append(k)

    def entry(k: np.ndarray) -> ListedFalseTarget:
        pos, value = refine_false_target(residual, tuple(k), half)
        pixel = float(mag[tuple(k)])
        near, dist = _nearest_target(pos, axes, peaks)
        return ListedFalseTarget(
            level_db=float(20 * np.log10(max(abs(value), pixel) / ref)),
            pixel_level_db=float(20 * np.log10(pixel / ref)),
            position={ax.name: float(ax.to_coord(p)) for ax, p in zip(axes, pos)},
            index={ax.name: float(p) for ax, p in zip(axes, pos)},
            nearest_target=reports[near].name,
            nearest_cells=float(dist[near]),
        )

    return FalseTargetList(
        threshold_db=threshold_db,
        margin_db=LIST_MARGIN_DB,
        cap=LIST_CAP,
        entries=tuple(entry(k) for k in kept[:LIST_CAP]),
        beyond=max(len(kept) - LIST_CAP, 0),
        on_ridges=on_ridges,
        in_misfits=in_misfits,
    )
