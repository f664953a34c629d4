"""Compiled kernels of evaluate (numba) for 3D cubes: the orientation density of the support's edges and the
ideal response of a neighbour. Each computes what its numpy reference in :mod:`sarproc.quality.metrics`
computes (``EvaluateParams(exact=True)`` takes those), to rounding. Imported only for 3D images: loading
numba and the cached kernels costs about a second, more than 2D images gain from them.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from sarproc.product.kernel_cache import CACHE, lean_cache_loads
from sarproc.quality.kernels_aot import DENSITY_PRUNE


@numba.njit(error_model="numpy", parallel=True, cache=CACHE)
def orientation_density(
    cand: np.ndarray,
    u: np.ndarray,
    weight: np.ndarray,
    sigma: float,
    order: np.ndarray,
    starts: np.ndarray,
    centre: np.ndarray,
    reach: np.ndarray,
) -> np.ndarray:  # pragma: no cover - compiled
    """sum_j weight[j] exp((cos^2 - 1) / 2 sigma^2) over unit vectors u[j] at each candidate cand[i],
    terms below exp(-DENSITY_PRUNE / 2) of their weight left out.

    The candidates come in blocks (block b: cand[order[starts[b]:starts[b + 1]]], inside a cone about the unit
    vector centre[b]): a u with |u . centre[b]| below reach[b] is farther than the pruning's reach from every one
    of them (:func:`sarproc.quality.metrics._candidate_blocks`), so the block skips it with one dot product
    instead of one per candidate. Each candidate still sums its terms in the order of j, the same terms: the
    same result bit for bit as the loop over every pair."""
    out = np.zeros(cand.shape[0])
    floor = 1.0 - DENSITY_PRUNE * sigma * sigma
    scale = 1.0 / (2.0 * sigma * sigma)
    for b in numba.prange(starts.shape[0] - 1):
        for j in range(u.shape[0]):
            e = 0.0
            for a in range(u.shape[1]):
                e += centre[b, a] * u[j, a]
            if abs(e) < reach[b]:
                continue
            for k in range(starts[b], starts[b + 1]):
                i = order[k]
                d = 0.0
                for a in range(u.shape[1]):
                    d += cand[i, a] * u[j, a]
                d2 = d * d
                if d2 > floor:
                    out[i] += math.exp((d2 - 1.0) * scale) * weight[j]
    return out


@numba.njit(error_model="numpy", cache=CACHE)
def _derivative(mag: np.ndarray, i: int, j: int, k: int, axis: int, h: float) -> float:  # pragma: no cover
    """np.gradient of a 3D array along ``axis`` at (i, j, k), spacing h: central differences inside, one-sided
    at the edges (edge_order 1), the same operations."""
    n = mag.shape[axis]
    at = i if axis == 0 else (j if axis == 1 else k)
    lo = at - 1 if at > 0 else at
    hi = at + 1 if at < n - 1 else at
    if n < 2:
        return 0.0
    if axis == 0:
        a, b = mag[hi, j, k], mag[lo, j, k]
    elif axis == 1:
        a, b = mag[i, hi, k], mag[i, lo, k]
    else:
        a, b = mag[i, j, hi], mag[i, j, lo]
    return (a - b) / (2.0 * h) if hi - lo == 2 else (a - b) / h


@numba.njit(error_model="numpy", parallel=True, cache=CACHE)
def _gradient_norms(mag: np.ndarray, h: np.ndarray) -> np.ndarray:  # pragma: no cover - compiled
    out = np.empty(mag.shape)
    for p in numba.prange(mag.shape[0]):
        i = np.int64(p)  # prange's index may be unsigned; the derivative's indices are one signed type
        for j in range(mag.shape[1]):
            for k in range(mag.shape[2]):
                g0 = _derivative(mag, i, j, k, 0, h[0])
                g1 = _derivative(mag, i, j, k, 1, h[1])
                g2 = _derivative(mag, i, j, k, 2, h[2])
                out[i, j, k] = math.sqrt(g0 * g0 + g1 * g1 + g2 * g2)
    return out


@numba.njit(error_model="numpy", cache=CACHE)
def strong_gradients(mag: np.ndarray, h: np.ndarray, fraction: float) -> tuple:  # pragma: no cover - compiled
    """(g (m, 3), norm (m,)): np.gradient of the 3D array ``mag`` (spacings h) and its Euclidean norm at the m
    points (C order) where the norm exceeds ``fraction`` of its largest value, without the full gradient arrays
    (principal_directions' edge normals)."""
    return _strong_from_norms(mag, h, _gradient_norms(mag, h), fraction)


@numba.njit(error_model="numpy", cache=CACHE)
def _strong_from_norms(
    mag: np.ndarray, h: np.ndarray, norms: np.ndarray, fraction: float
) -> tuple:  # pragma: no cover - compiled
    """:func:`strong_gradients` given the gradient's norms (the serial part: the module compiled ahead of time
    calls the two parts itself, a parallel kernel being no callee of a serial export)."""
    limit = fraction * norms.max()
    m = 0
    for v in norms.ravel():
        if v > limit:
            m += 1
    g = np.empty((m, 3))
    norm = np.empty(m)
    n = 0
    for i in range(mag.shape[0]):
        for j in range(mag.shape[1]):
            for k in range(mag.shape[2]):
                if norms[i, j, k] > limit:
                    g[n, 0] = _derivative(mag, i, j, k, 0, h[0])
                    g[n, 1] = _derivative(mag, i, j, k, 1, h[1])
                    g[n, 2] = _derivative(mag, i, j, k, 2, h[2])
                    norm[n] = norms[i, j, k]
                    n += 1
    return g, norm


@numba.njit(error_model="numpy", cache=CACHE)
def cone_sum(u: np.ndarray, g: np.ndarray, f: np.ndarray, cos_cone: float) -> np.ndarray:  # pragma: no cover
    """(4,): the sum of the gradients ``g`` (m, 3) whose unit vectors ``u`` lie within the cone |u . f| > cos_cone
    about ``f``, each signed by its side (u . f < 0: subtracted), and their count: the cluster mean of
    principal_directions' edge normals (:func:`sarproc.quality.metrics._edge_normals`) in one pass, the same sum
    as numpy's ``(np.sign(c[sel])[:, None] * g[sel]).sum(axis=0)``, row by row in order, without the selections'
    arrays."""
    out = np.zeros(4)
    for j in range(u.shape[0]):
        c = u[j, 0] * f[0] + u[j, 1] * f[1] + u[j, 2] * f[2]
        if abs(c) > cos_cone:
            if c > 0:
                out[0] += g[j, 0]
                out[1] += g[j, 1]
                out[2] += g[j, 2]
            else:
                out[0] -= g[j, 0]
                out[1] -= g[j, 1]
                out[2] -= g[j, 2]
            out[3] += 1.0
    return out


@numba.njit(error_model="numpy", cache=CACHE)
def _shape(q: float, period: float, hamming: bool) -> float:  # pragma: no cover - compiled
    if hamming:
        return 0.54 * _sinc(q, period) + 0.23 * (_sinc(q - 1.0, period) + _sinc(q + 1.0, period))
    return _sinc(q, period)


@numba.njit(error_model="numpy", cache=CACHE)
def _sinc(q: float, period: float) -> float:  # pragma: no cover - compiled
    """sin(pi q) / (pi q), or with a period P > 0 (nulls) the periodic sinc sin(pi q) / (P sin(pi q / P)) (the array
    factor of P uniform receivers)."""
    if q == 0.0:
        return 1.0
    if period > 0.0:
        den = period * math.sin(math.pi * q / period)
        if abs(den) < 1e-12:  # a grating lobe: the limit
            return math.cos(math.pi * q) / math.cos(math.pi * q / period)
        return math.sin(math.pi * q) / den
    return math.sin(math.pi * q) / (math.pi * q)


@numba.njit(error_model="numpy", cache=CACHE)
def _tabled(q: float, row: np.ndarray, rate: float) -> float:  # pragma: no cover - compiled
    """The tabulated shape ``row`` (centred, ``rate`` points per null) at q nulls, linearly interpolated; NaN
    beyond the table."""
    t = q * rate + (row.shape[0] - 1) / 2.0
    i = int(math.floor(t))
    if i < 0 or i >= row.shape[0] - 1:
        return math.nan
    return row[i] + (t - i) * (row[i + 1] - row[i])


@numba.njit(error_model="numpy", cache=CACHE)
def _ideal_at(
    points: np.ndarray,
    k: int,
    position: np.ndarray,
    ridge: np.ndarray,
    f_c: np.ndarray,
    chirp: np.ndarray,
    period: np.ndarray,
    table: np.ndarray,
    rate: np.ndarray,
    hamming: bool,
) -> complex:  # pragma: no cover - compiled
    ndim = points.shape[0]
    amp = 1.0
    phase = 0.0
    for a in range(ndim):
        c = 0.0
        for b in range(ndim):
            c += ridge[a, b] * (points[b, k] - position[b])
        v = _tabled(c, table[a], rate[a]) if rate[a] > 0.0 else math.nan
        amp *= _shape(c, period[a], hamming) if math.isnan(v) else v
        d = points[a, k] - position[a]
        phase += f_c[a] * d + 0.5 * chirp[a] * d * d
    phase *= 2.0 * math.pi
    return complex(amp * math.cos(phase), amp * math.sin(phase))


@numba.njit(error_model="numpy", cache=CACHE)
def ideal_response_serial(
    points: np.ndarray,
    position: np.ndarray,
    ridge: np.ndarray,
    f_c: np.ndarray,
    chirp: np.ndarray,
    period: np.ndarray,
    table: np.ndarray,
    rate: np.ndarray,
    hamming: bool,
) -> np.ndarray:  # pragma: no cover - compiled
    """:func:`ideal_response` on one thread, for a few points (a cut line): a parallel launch costs more."""
    n = points.shape[1]
    out = np.empty(n, dtype=np.complex128)
    for k in range(n):
        out[k] = _ideal_at(points, k, position, ridge, f_c, chirp, period, table, rate, hamming)
    return out


@numba.njit(error_model="numpy", parallel=True, cache=CACHE)
def ideal_response(
    points: np.ndarray,
    position: np.ndarray,
    ridge: np.ndarray,
    f_c: np.ndarray,
    chirp: np.ndarray,
    period: np.ndarray,
    table: np.ndarray,
    rate: np.ndarray,
    hamming: bool,
) -> np.ndarray:  # pragma: no cover - compiled
    """prod_a shape((ridge @ d)_a) exp(2 pi i f_c . d + pi i sum_a chirp_a d_a^2), d = x - position, at each
    column x of points (ndim, N): the ideal response of :func:`sarproc.quality.metrics._ideal_response`,
    ``ridge`` the matrix taking image-index offsets to ridge coordinates in nulls, shape the sinc (or, where
    period_a > 0, the periodic sinc of that period in nulls) or its Hamming-weighted sum; where rate_a > 0 the
    tabulated shape table[a] (centred, rate_a points per null) inside the table, that beyond it."""
    n = points.shape[1]
    out = np.empty(n, dtype=np.complex128)
    for k in numba.prange(n):
        out[k] = _ideal_at(points, k, position, ridge, f_c, chirp, period, table, rate, hamming)
    return out


@numba.njit(error_model="numpy", cache=CACHE)
def _grid_shape(s: float, q: float, period: float, hamming: bool) -> float:  # pragma: no cover - compiled
    """_shape(q) given s = sin(pi q) (sin(pi (q -+ 1)) = -s); near q = 0 from math.sin itself, where s / (pi q)
    would lose digits to the rounding of s; a periodic sinc (period > 0) from math.sin throughout."""
    if abs(q) < 1e-3 or period > 0.0:
        return _shape(q, period, hamming)
    value = s / (math.pi * q)
    if hamming:
        lo = 1.0 if q == 1.0 else -s / (math.pi * (q - 1.0))
        hi = 1.0 if q == -1.0 else -s / (math.pi * (q + 1.0))
        return 0.54 * value + 0.23 * (lo + hi)
    return value


@numba.njit(error_model="numpy", cache=CACHE)
def _box_tables(
    origin: np.ndarray,
    step: np.ndarray,
    shape: np.ndarray,
    position: np.ndarray,
    ridge: np.ndarray,
    f_c: np.ndarray,
    chirp: np.ndarray,
    period: np.ndarray,
) -> tuple:  # pragma: no cover - compiled
    """Per-axis tables of a box: lin[a, b, i] = ridge[a, b] d_b, rot = exp(i pi lin), car[b, i] = exp(2 pi i
    (f_c[b] d_b + chirp[b] d_b^2 / 2)), d_b = origin[b] + step[b] i - position[b]; where period[a] > 0 also
    per[a, b, i] = exp(i pi lin / period[a]) (the periodic sinc's denominator; 1 elsewhere)."""
    longest = max(shape[0], max(shape[1], shape[2]))
    rot = np.empty((3, 3, longest), dtype=np.complex128)
    per = np.ones((3, 3, longest), dtype=np.complex128)
    lin = np.empty((3, 3, longest))
    car = np.empty((3, longest), dtype=np.complex128)
    for b in range(3):
        for i in range(shape[b]):
            d = origin[b] + step[b] * i - position[b]
            t = 2.0 * math.pi * f_c[b] * d + math.pi * chirp[b] * d * d
            car[b, i] = complex(math.cos(t), math.sin(t))
            for a in range(3):
                lin[a, b, i] = ridge[a, b] * d
                rot[a, b, i] = complex(math.cos(math.pi * lin[a, b, i]), math.sin(math.pi * lin[a, b, i]))
                if period[a] > 0.0:
                    u = math.pi * lin[a, b, i] / period[a]
                    per[a, b, i] = complex(math.cos(u), math.sin(u))
    return lin, rot, per, car


@numba.njit(error_model="numpy", cache=CACHE)
def _box_amp(
    lin: np.ndarray,
    rot: np.ndarray,
    per: np.ndarray,
    a: int,
    i: int,
    j: int,
    k: int,
    period: np.ndarray,
    table: np.ndarray,
    rate: np.ndarray,
    hamming: bool,
) -> tuple:  # pragma: no cover - compiled
    """(shape along ridge a at box sample (i, j, k), its ridge coordinate q, exp(i pi q)) from the tables."""
    q = lin[a, 0, i] + lin[a, 1, j] + lin[a, 2, k]
    e = rot[a, 0, i] * rot[a, 1, j] * rot[a, 2, k]  # exp(i pi q)
    p = per[a, 0, i] * per[a, 1, j] * per[a, 2, k]  # exp(i pi q / P)
    return _shape_at(q, e, p, period[a], table[a], rate[a], hamming), q, e


@numba.njit(error_model="numpy", cache=CACHE)
def _shape_at(
    q: float, e: complex, p: complex, period: float, row: np.ndarray, rate: float, hamming: bool
) -> float:  # pragma: no cover - compiled
    """The shape along one ridge at coordinate q given e = exp(i pi q) and p = exp(i pi q / period)."""
    v = _tabled(q, row, rate) if rate > 0.0 else math.nan
    if not math.isnan(v):
        return v
    if period > 0.0 and not hamming and abs(q) >= 1e-3:
        # the periodic sinc sin(pi q) / (P sin(pi q / P)) from the tables (its limit at a grating lobe)
        den = period * p.imag
        return e.real / p.real if abs(den) < 1e-12 else e.imag / den
    return _grid_shape(e.imag, q, period, hamming)


@numba.njit(error_model="numpy", cache=CACHE)
def _box_value(
    lin: np.ndarray,
    rot: np.ndarray,
    per: np.ndarray,
    car: np.ndarray,
    i: int,
    j: int,
    k: int,
    period: np.ndarray,
    table: np.ndarray,
    rate: np.ndarray,
    hamming: bool,
) -> complex:  # pragma: no cover - compiled
    amp = 1.0
    for a in range(3):
        amp *= _box_amp(lin, rot, per, a, i, j, k, period, table, rate, hamming)[0]
    return amp * (car[0, i] * car[1, j] * car[2, k])


@numba.njit(error_model="numpy", parallel=True, cache=CACHE)
def ideal_response_box(
    origin: np.ndarray,
    step: np.ndarray,
    shape: np.ndarray,
    position: np.ndarray,
    ridge: np.ndarray,
    f_c: np.ndarray,
    chirp: np.ndarray,
    period: np.ndarray,
    table: np.ndarray,
    rate: np.ndarray,
    hamming: bool,
) -> np.ndarray:  # pragma: no cover - compiled
    """:func:`ideal_response` of a 3D response on the image box origin + step * (i, j, k), i < shape[0] ...:
    the ridge coordinates are linear on the box, so sin(pi c_a) and the carrier are products of per-axis
    complex exponentials (9 + 3 short tables instead of 4 transcendental calls per sample; equal to rounding)."""
    lin, rot, per, car = _box_tables(origin, step, shape, position, ridge, f_c, chirp, period)
    out = np.empty((shape[0], shape[1], shape[2]), dtype=np.complex128)
    for i in numba.prange(shape[0]):
        for j in range(shape[1]):
            # _box_value's sums and products over the first two axes, taken once per row (the same operations)
            q0, q1, q2 = lin[0, 0, i] + lin[0, 1, j], lin[1, 0, i] + lin[1, 1, j], lin[2, 0, i] + lin[2, 1, j]
            e0, e1, e2 = rot[0, 0, i] * rot[0, 1, j], rot[1, 0, i] * rot[1, 1, j], rot[2, 0, i] * rot[2, 1, j]
            p0, p1, p2 = per[0, 0, i] * per[0, 1, j], per[1, 0, i] * per[1, 1, j], per[2, 0, i] * per[2, 1, j]
            c = car[0, i] * car[1, j]
            for k in range(shape[2]):
                amp = _shape_at(
                    q0 + lin[0, 2, k], e0 * rot[0, 2, k], p0 * per[0, 2, k], period[0], table[0], rate[0], hamming
                )
                amp *= _shape_at(
                    q1 + lin[1, 2, k], e1 * rot[1, 2, k], p1 * per[1, 2, k], period[1], table[1], rate[1], hamming
                )
                amp *= _shape_at(
                    q2 + lin[2, 2, k], e2 * rot[2, 2, k], p2 * per[2, 2, k], period[2], table[2], rate[2], hamming
                )
                out[i, j, k] = amp * (c * car[2, k])
    return out


@numba.njit(error_model="numpy", cache=CACHE)
def ideal_response_boxes(
    origins: np.ndarray,
    step: np.ndarray,
    shapes: np.ndarray,
    inverse: np.ndarray,
    count: int,
    position: np.ndarray,
    ridge: np.ndarray,
    f_c: np.ndarray,
    chirp: np.ndarray,
    period: np.ndarray,
    table: np.ndarray,
    rate: np.ndarray,
    hamming: bool,
) -> np.ndarray:  # pragma: no cover - compiled
    """:func:`ideal_response_box` on several boxes (rows of origins, shapes) whose points, in order, are the
    samples ``inverse`` of ``count`` (shared points written once per box, with the same value). Serial: the
    boxes are small and a parallel launch per call costs more than they do."""
    out = np.empty(count, dtype=np.complex128)
    n = 0
    for box in range(origins.shape[0]):
        shape = shapes[box]
        lin, rot, per, car = _box_tables(origins[box], step, shape, position, ridge, f_c, chirp, period)
        for i in range(shape[0]):
            for j in range(shape[1]):
                for k in range(shape[2]):
                    out[inverse[n]] = _box_value(lin, rot, per, car, i, j, k, period, table, rate, hamming)
                    n += 1
    return out


@numba.njit(error_model="numpy", cache=CACHE)
def _sinc_slope(q: float, s: float, c: float) -> float:  # pragma: no cover - compiled
    """d sinc(q) / dq given s = sin(pi q), c = cos(pi q); near q = 0 from its series."""
    if abs(q) < 1e-3:
        return -(math.pi**2) * q / 3.0 + math.pi**4 * q**3 / 30.0
    return (c - s / (math.pi * q)) / q


@numba.njit(error_model="numpy", cache=CACHE)
def _shape_slope(
    q: float, e: complex, period: float, row: np.ndarray, rate: float, hamming: bool
) -> float:  # pragma: no cover - compiled
    """d shape(q) / dq of :func:`_box_value`'s shape along one ridge (e = exp(i pi q)): a sinc's or its Hamming
    sum's in closed form; a tabulated or periodic shape's by central differences of 1e-5 nulls."""
    h = 1e-5
    if rate > 0.0 and not math.isnan(_tabled(q, row, rate)):
        hi = _tabled(q + h, row, rate)
        lo = _tabled(q - h, row, rate)
        hi = _shape(q + h, period, hamming) if math.isnan(hi) else hi
        lo = _shape(q - h, period, hamming) if math.isnan(lo) else lo
        return (hi - lo) / (2.0 * h)
    if period > 0.0:
        return (_shape(q + h, period, hamming) - _shape(q - h, period, hamming)) / (2.0 * h)
    slope = _sinc_slope(q, e.imag, e.real)
    if hamming:  # sin and cos of pi (q -+ 1) are -s and -c
        return 0.54 * slope + 0.23 * (_sinc_slope(q - 1.0, -e.imag, -e.real) + _sinc_slope(q + 1.0, -e.imag, -e.real))
    return slope


@numba.njit(error_model="numpy", cache=CACHE)
def ideal_response_boxes_slopes(
    origins: np.ndarray,
    step: np.ndarray,
    shapes: np.ndarray,
    inverse: np.ndarray,
    count: int,
    position: np.ndarray,
    ridge: np.ndarray,
    f_c: np.ndarray,
    chirp: np.ndarray,
    period: np.ndarray,
    table: np.ndarray,
    rate: np.ndarray,
    hamming: bool,
) -> np.ndarray:  # pragma: no cover - compiled
    """(4, count): row 0 :func:`ideal_response_boxes` (the same value), row 1 + a its derivative with respect to
    the ridge coordinate a (nulls), the other ridges' shapes and the carrier held: what a Gauss-Newton step on
    the position and ridges needs (the chain rule gives those columns), in one pass instead of a pair of
    responses per parameter."""
    out = np.empty((4, count), dtype=np.complex128)
    n = 0
    for box in range(origins.shape[0]):
        shape = shapes[box]
        lin, rot, per, car = _box_tables(origins[box], step, shape, position, ridge, f_c, chirp, period)
        for i in range(shape[0]):
            for j in range(shape[1]):
                for k in range(shape[2]):
                    carrier = car[0, i] * car[1, j] * car[2, k]
                    a0, q0, e0 = _box_amp(lin, rot, per, 0, i, j, k, period, table, rate, hamming)
                    a1, q1, e1 = _box_amp(lin, rot, per, 1, i, j, k, period, table, rate, hamming)
                    a2, q2, e2 = _box_amp(lin, rot, per, 2, i, j, k, period, table, rate, hamming)
                    at = inverse[n]
                    out[0, at] = a0 * a1 * a2 * carrier  # _box_value's operations
                    out[1, at] = _shape_slope(q0, e0, period[0], table[0], rate[0], hamming) * a1 * a2 * carrier
                    out[2, at] = a0 * _shape_slope(q1, e1, period[1], table[1], rate[1], hamming) * a2 * carrier
                    out[3, at] = a0 * a1 * _shape_slope(q2, e2, period[2], table[2], rate[2], hamming) * carrier
                    n += 1
    return out


@numba.njit(error_model="numpy", parallel=True, cache=CACHE)
def spread(
    coef: np.ndarray, x: np.ndarray, grid_size: int, taps: int, beta: float, chunks: int
) -> np.ndarray:  # pragma: no cover - compiled
    """:func:`sarproc.quality.linesum._spread` compiled: sum_k coef[k] phi((l - u_k) / (taps / 2)) on the
    periodic grid l, u_k = x_k grid_size / 2 pi, phi(z) = exp(beta (sqrt(1 - z^2) - 1)) for |z| < 1 (the same
    terms; summed per chunk (one per thread), then together)."""
    half = taps / 2.0
    grids = np.zeros((chunks, grid_size), dtype=np.complex128)
    size = (coef.size + chunks - 1) // chunks
    for chunk in numba.prange(chunks):
        for k in range(chunk * size, min(coef.size, (chunk + 1) * size)):
            u = (x[k] * grid_size / (2.0 * math.pi)) % grid_size
            first = math.ceil(u - half)
            for t in range(taps + 1):
                z = (first + t - u) / half
                z2 = min(z * z, 1.0)
                if z2 < 1.0:
                    grids[chunk, int(first + t) % grid_size] += coef[k] * math.exp(beta * (math.sqrt(1.0 - z2) - 1.0))
    return grids.sum(axis=0)


lean_cache_loads(globals())  # cached kernels load without numba's context refresh (kernel_cache)
