"""Compiled, tiled, parallel backprojection kernel (numba).

Same sum as the float64 reference of :mod:`sarproc.focus.backprojection`, arranged for speed:

- Pixels are grouped into small spatial tiles. Per tile and pulse the range from the antenna to the
  tile centre R_0 and its unit vector u are computed in float64; a pixel at d from the centre then
  differs by dR = u.d + (|d|^2 - (u.d)^2) / (2 R_0) - u.d (|d|^2 - (u.d)^2) / (2 R_0^2) (third order in d)
  wherever the remainder keeps the phase error below EXPANSION_LIMIT_CYCLES, else by the exact root
  dR = R_0 a / (1 + sqrt(1 + a)), a = 2 u.d / R_0 + |d|^2 / R_0^2, both in float32 (micrometres).
- The range-sample position and the carrier phase are split the same way: float64 integer sample and
  reduced phase cycles per tile and pulse, float32 offsets per pixel.
- exp(j 2 pi cycles) comes from short minimax polynomials on a quarter cycle (|error| < 1e-6, vectorisable,
  no libm call).
- Linear interpolation (the default) reads a pair table built once per pulse over the window of samples the
  image can reach: entry k holds (x_s, x_{s+1} - x_s), so each pixel needs one 16-byte entry at an unsigned
  index (signed indices cost numba's negative-index wrap-around in the only scalar loop). Positions and
  indices, the gather (the entry's two complex halves into two arrays), and the interpolation + phasor +
  accumulation are three passes over L1-resident scratch, the first and last vectorised. Nearest sample and
  tabulated windowed-sinc / Knab kernels read the pulse itself.
- Tiles run in parallel (numba prange), each accumulating its pixels over pulses in a small float32 buffer;
  no BLAS, no Python in the hot loop.

Kernels are compiled on first use and cached on disk (``cache=CACHE``).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from sarproc.dsp.kernel_cache import CACHE, lean_cache_loads
from sarproc.dsp.phasor_kernels import cis_cycles32_short

INTERPOLATIONS = ("nearest", "linear", "cubic", "sinc", "lanczos", "knab")
# a leg's float32 geometry from _reference: unit vector (3), 1/R, R, 1/(2R), 1/(2R^2), whether to expand
_Leg = tuple[np.float32, np.float32, np.float32, np.float32, np.float32, np.float32, np.float32, bool]

_TABLE_STEPS = 256  # table entries per sample for the windowed-sinc kernels (linear in between)


# The pixel-to-centre path difference of a leg is expanded to third order in the pixel offset d when the
# fourth-order remainder, below h^4 / (8 r^3) for a tile of radius h at range r (taken as h^4 / r^3 here, 8 x
# margin), keeps the carrier phase error under this many cycles (6e-4 rad; float32 rounding alone is ~1e-4 rad);
# otherwise the exact root is evaluated.
EXPANSION_LIMIT_CYCLES = 1e-4


@numba.njit(fastmath=True, error_model="numpy", cache=CACHE)
def _offset(
    ux: np.float32,
    uy: np.float32,
    uz: np.float32,
    inv_r: np.float32,
    r0: np.float32,
    dx: np.float32,
    dy: np.float32,
    dz: np.float32,
    d2: np.float32,
) -> np.float32:
    """|c + d - p| - |c - p| for u = (c - p) / |c - p|, in float32 without cancellation."""
    a = np.float32(2.0) * (ux * dx + uy * dy + uz * dz) * inv_r + d2 * inv_r * inv_r
    return r0 * a / (np.float32(1.0) + np.sqrt(np.float32(1.0) + a))


@numba.njit(fastmath=True, error_model="numpy", cache=CACHE)
def _offset_expanded(
    ux: np.float32,
    uy: np.float32,
    uz: np.float32,
    half_inv_r: np.float32,
    half_inv_r2: np.float32,
    dx: np.float32,
    dy: np.float32,
    dz: np.float32,
    d2: np.float32,
) -> np.float32:
    """The same difference to third order in d: du + (|d|^2 - du^2) / (2r) - du (|d|^2 - du^2) / (2r^2), du = u.d
    (no square root or division; used where the remainder is negligible, see EXPANSION_LIMIT_CYCLES)."""
    du = ux * dx + uy * dy + uz * dz
    return du + (d2 - du * du) * (half_inv_r - du * half_inv_r2)


@numba.njit(error_model="numpy", cache=CACHE)
def _reference(cx: float, cy: float, cz: float, px: float, py: float, pz: float, h4kc: float) -> tuple[float, _Leg]:
    """float64 range from antenna p to tile centre c and the float32 leg geometry (unit vector, 1/R, R, 1/(2R),
    1/(2R^2), whether the expansion is accurate enough: kc h^4 / R^3 below the limit)."""
    ax, ay, az = cx - px, cy - py, cz - pz
    r = math.sqrt(ax * ax + ay * ay + az * az)
    ir = 1.0 / r
    expand = h4kc * ir * ir * ir < EXPANSION_LIMIT_CYCLES
    return r, (
        np.float32(ax * ir),
        np.float32(ay * ir),
        np.float32(az * ir),
        np.float32(ir),
        np.float32(r),
        np.float32(0.5 * ir),
        np.float32(0.5 * ir * ir),
        expand,
    )


@numba.njit(error_model="numpy", cache=CACHE)
def _pulse_reference(
    cx: float,
    cy: float,
    cz: float,
    tx: np.ndarray,
    rx: np.ndarray,
    p: int,
    monostatic: bool,
    scale: float,
    first: np.ndarray,
    kc: float,
    h4kc: float,
) -> tuple[np.int64, np.float32, np.float32, _Leg, _Leg]:
    """Per tile and pulse, float64: integer sample and float32 fraction of the centre's delay, its reduced
    carrier cycles, and the float32 geometry of both legs."""
    r_tx, geo_t = _reference(cx, cy, cz, tx[p, 0], tx[p, 1], tx[p, 2], h4kc)
    if monostatic:
        r_tot = 2.0 * r_tx
        geo_r = geo_t
    else:
        r_rx, geo_r = _reference(cx, cy, cz, rx[p, 0], rx[p, 1], rx[p, 2], h4kc)
        r_tot = r_tx + r_rx
    pos0 = r_tot * scale + first[p]
    base = math.floor(pos0)
    cyc = r_tot * kc
    cyc0 = np.float32(cyc - math.floor(cyc))
    return np.int64(base), np.float32(pos0 - base), cyc0, geo_t, geo_r


@numba.njit(fastmath=True, error_model="numpy", cache=CACHE)
def _add_leg(
    dr: np.ndarray,
    dx: np.ndarray,
    dy: np.ndarray,
    dz: np.ndarray,
    d2: np.ndarray,
    geo: _Leg,
    factor: np.float32,
    first_leg: bool,
) -> None:
    """dr (+)= factor x the leg's path difference per pixel; branch-free loops, so they vectorise."""
    ux, uy, uz, inv_r, r0, hir, hir2, expand = geo
    if expand and first_leg:
        for i in range(len(dr)):
            dr[i] = factor * _offset_expanded(ux, uy, uz, hir, hir2, dx[i], dy[i], dz[i], d2[i])
    elif expand:
        for i in range(len(dr)):
            dr[i] += _offset_expanded(ux, uy, uz, hir, hir2, dx[i], dy[i], dz[i], d2[i])
    elif first_leg:
        for i in range(len(dr)):
            dr[i] = factor * _offset(ux, uy, uz, inv_r, r0, dx[i], dy[i], dz[i], d2[i])
    else:
        for i in range(len(dr)):
            dr[i] += _offset(ux, uy, uz, inv_r, r0, dx[i], dy[i], dz[i], d2[i])


@numba.njit(fastmath=True, error_model="numpy", cache=CACHE)
def _path_differences(
    dr: np.ndarray,
    dx: np.ndarray,
    dy: np.ndarray,
    dz: np.ndarray,
    d2: np.ndarray,
    geo_t: _Leg,
    geo_r: _Leg,
    monostatic: bool,
) -> None:
    if monostatic:
        _add_leg(dr, dx, dy, dz, d2, geo_t, np.float32(2.0), True)
    else:
        _add_leg(dr, dx, dy, dz, d2, geo_t, np.float32(1.0), True)
        _add_leg(dr, dx, dy, dz, d2, geo_r, np.float32(1.0), False)


@numba.njit(fastmath=True, error_model="numpy", cache=CACHE)
def _positions(
    dr: np.ndarray,
    frac: np.ndarray,
    cos_: np.ndarray,
    sin_: np.ndarray,
    frac0: np.float32,
    cyc0: np.float32,
    scale32: np.float32,
    kc32: np.float32,
) -> None:
    """Per pixel of a tile, for one pulse: sample position offset (float32, from the tile's integer base
    sample) and carrier phasor."""
    half = np.float32(0.5)
    for i in range(len(dr)):
        frac[i] = frac0 + dr[i] * scale32
        c = cyc0 + dr[i] * kc32
        c = c - np.floor(c + half)
        co, si = cis_cycles32_short(c)
        cos_[i] = co
        sin_[i] = si


@numba.njit(fastmath=True, error_model="numpy", cache=CACHE)
def _entry(f: np.float32, base: np.float32, n_w: np.float32) -> np.uint32:
    """Table entry of the integer-valued sample offset f from ``base`` (the float32 base sample), clamped to the
    zero entries 0 and n_w, summed and clamped in float32 so that the loop vectorises (numba widens an int32 sum
    to int64, for which AVX2 has no min, max or conversion: ~1 ns a pixel). The sum is exact while |base| <
    2^24; beyond, it clamps to the same end as the integer sum."""
    return np.uint32(np.int32(min(max(f + base, np.float32(0.0)), n_w)))


@numba.njit(fastmath=True, error_model="numpy", cache=CACHE)
def _indices(
    dr: np.ndarray, jc: np.ndarray, frac0: np.float32, scale32: np.float32, ibase: np.int32, n_w: np.int32
) -> None:
    """Pair-table entry of each pixel, clipped to the zero entries 0 and n_w (reads outside the window add
    nothing)."""
    base, top = np.float32(ibase), np.float32(n_w)
    for i in range(len(dr)):
        jc[i] = _entry(np.floor(frac0 + dr[i] * scale32), base, top)


@numba.njit(fastmath=True, error_model="numpy", cache=CACHE)
def _weight_and_phasor(
    dr: np.float32, frac0: np.float32, cyc0: np.float32, scale32: np.float32, kc32: np.float32
) -> tuple[np.float32, np.float32, np.float32]:
    """A pixel's interpolation weight (fraction of its sample position) and carrier phasor from its path
    difference dr to the tile centre."""
    t = frac0 + dr * scale32
    c = cyc0 + dr * kc32
    co, si = cis_cycles32_short(c - np.floor(c + np.float32(0.5)))
    return t - np.floor(t), co, si


@numba.njit(fastmath=True, error_model="numpy", cache=CACHE)
def _combine_from_dr(
    acc_re: np.ndarray,
    acc_im: np.ndarray,
    a: np.ndarray,
    b: np.ndarray,
    dr: np.ndarray,
    frac0: np.float32,
    cyc0: np.float32,
    scale32: np.float32,
    kc32: np.float32,
) -> None:
    """acc += (x_s + w (x_{s+1} - x_s)) exp(j 2 pi cycles) per pixel, a holding x_s and b the difference (re, im
    interleaved, from _gather_pairs), w and the cycles recomputed from dr (cheaper than storing and reloading
    them)."""
    for i in range(len(acc_re)):
        w, co, si = _weight_and_phasor(dr[i], frac0, cyc0, scale32, kc32)
        vr = a[2 * i] + w * b[2 * i]
        vi = a[2 * i + 1] + w * b[2 * i + 1]
        acc_re[i] += vr * co - vi * si
        acc_im[i] += vr * si + vi * co


@numba.njit(fastmath=True, error_model="numpy", cache=CACHE)
def _path_indices_mono(
    dr: np.ndarray,
    jc: np.ndarray,
    dx: np.ndarray,
    dy: np.ndarray,
    dz: np.ndarray,
    d2: np.ndarray,
    geo: _Leg,
    frac0: np.float32,
    scale32: np.float32,
    ibase: np.int32,
    n_w: np.int32,
) -> None:
    """_path_differences and _indices in one pass for the common case: monostatic, expansion accurate."""
    ux, uy, uz, inv_r, r0, hir, hir2, expand = geo
    base, top = np.float32(ibase), np.float32(n_w)
    two = np.float32(2.0)
    for i in range(len(dr)):
        x = two * _offset_expanded(ux, uy, uz, hir, hir2, dx[i], dy[i], dz[i], d2[i])
        dr[i] = x
        jc[i] = _entry(np.floor(frac0 + x * scale32), base, top)


@numba.njit(fastmath=True, error_model="numpy", cache=CACHE)
def _combine_cubic(
    acc_re: np.ndarray,
    acc_im: np.ndarray,
    g: np.ndarray,
    dr: np.ndarray,
    frac0: np.float32,
    cyc0: np.float32,
    scale32: np.float32,
    kc32: np.float32,
) -> None:
    """As _combine_from_dr for the cubic table: value c0 + w (c1 + w (c2 + w c3)), g holding (c0 .. c3) per pixel."""
    for i in range(len(acc_re)):
        w, co, si = _weight_and_phasor(dr[i], frac0, cyc0, scale32, kc32)
        vr = g[8 * i] + w * (g[8 * i + 2] + w * (g[8 * i + 4] + w * g[8 * i + 6]))
        vi = g[8 * i + 1] + w * (g[8 * i + 3] + w * (g[8 * i + 5] + w * g[8 * i + 7]))
        acc_re[i] += vr * co - vi * si
        acc_im[i] += vr * si + vi * co


@numba.njit(fastmath=True, error_model="numpy", cache=CACHE)
def _gather_quads(coef: np.ndarray, base: np.uint64, jc: np.ndarray, g: np.ndarray) -> None:
    """g[2i], g[2i + 1] = coef[base + 2 jc[i]], coef[base + 2 jc[i] + 1]: one 32-byte cubic entry per pixel."""
    for i in range(len(jc)):
        k = base + np.uint64(2) * np.uint64(jc[i])
        g[2 * i] = coef[k]
        g[2 * i + 1] = coef[k + np.uint64(1)]


@numba.njit(fastmath=True, error_model="numpy", cache=CACHE)
def _gather_pairs(pairs: np.ndarray, base: np.uint64, jc: np.ndarray, a: np.ndarray, b: np.ndarray) -> None:
    """a[i], b[i] = the halves of pair entry jc[i] (sample, difference to the next; pairs: the tables' flat
    complex64 view, two per entry, this pulse's from ``base``), the only indirect loads. Two arrays of 8-byte
    halves rather than one of 16-byte entries: the combine pass then de-interleaves pairs of floats, not
    quadruples (~57 instead of ~115 instructions per 8 pixels; the kernel 11 % faster on an AVX2 host,
    docs/performance.md)."""
    for i in range(len(jc)):
        k = base + np.uint64(2) * np.uint64(jc[i])
        a[i] = pairs[k]
        b[i] = pairs[k + np.uint64(1)]


@numba.njit(fastmath=True, error_model="numpy", cache=CACHE)
def _accumulate_nearest(
    acc_re: np.ndarray,
    acc_im: np.ndarray,
    frac: np.ndarray,
    cos_: np.ndarray,
    sin_: np.ndarray,
    row: np.ndarray,
    ibase: np.int32,
    n_s: np.int32,
) -> None:
    zero = np.float32(0.0)
    for i in range(len(acc_re)):
        j = ibase + np.int32(np.floor(frac[i] + np.float32(0.5)))
        ok = (j >= 0) & (j < n_s)
        jc = np.uint32(2 * min(max(j, np.int32(0)), np.int32(n_s - 1)))
        vr = row[jc] if ok else zero
        vi = row[jc + 1] if ok else zero
        acc_re[i] += vr * cos_[i] - vi * sin_[i]
        acc_im[i] += vr * sin_[i] + vi * cos_[i]


@numba.njit(fastmath=True, error_model="numpy", cache=CACHE)
def _accumulate_table(
    acc_re: np.ndarray,
    acc_im: np.ndarray,
    frac: np.ndarray,
    cos_: np.ndarray,
    sin_: np.ndarray,
    row: np.ndarray,
    ibase: np.int32,
    n_s: np.int32,
    table: np.ndarray,
    taps: int,
) -> None:
    """Tabulated kernel: pixel i reads samples j - taps/2 + 1 .. j + taps/2 (row: complex64) with the weights
    of its fraction cell, one contiguous row of ``table`` (steps + 1, taps) per cell (sarproc.dsp.interp
    .tap_table), linearly interpolated between cells; the tap loop is a short contiguous dot product."""
    zero = np.float32(0.0)
    steps = np.float32(_TABLE_STEPS)
    half = taps // 2
    for i in range(len(acc_re)):
        fl = np.floor(frac[i])
        q = (frac[i] - fl) * steps
        qf = np.floor(q)
        cell = np.int32(qf)
        t = q - qf
        first = ibase + np.int32(fl) + np.int32(1 - half)
        vr = zero
        vi = zero
        wsum = zero
        if first >= 0 and first + taps <= n_s:
            uf = np.uint32(first)
            for m in range(taps):
                wt = table[cell, m] + (table[cell + 1, m] - table[cell, m]) * t
                wsum += wt
                v = row[uf + np.uint32(m)]
                vr += v.real * wt
                vi += v.imag * wt
        else:
            for m in range(taps):
                wt = table[cell, m] + (table[cell + 1, m] - table[cell, m]) * t
                wsum += wt
                k = first + m
                if k >= 0 and k < n_s:
                    v = row[k]
                    vr += v.real * wt
                    vi += v.imag * wt
        inv = np.float32(1.0) / wsum
        vr *= inv
        vi *= inv
        acc_re[i] += vr * cos_[i] - vi * sin_[i]
        acc_im[i] += vr * sin_[i] + vi * cos_[i]


@numba.njit(parallel=True, error_model="numpy", cache=CACHE)
def pulse_windows(
    first: np.ndarray,
    scale: float,
    tx: np.ndarray,
    rx: np.ndarray,
    monostatic: bool,
    centres: np.ndarray,
    radius: np.ndarray,
    n_s: int,
    reach: int,
) -> tuple[np.ndarray, np.ndarray]:
    """Per pulse, the first and last table sample any pixel's entry starts at (lo, hi: int64, within -reach ..
    n - 2 + reach; an entry at s reads samples s + 1 - reach .. s + reach), from the tiles' centres and radii:
    |path - path_centre| <= 2 radius (one radius per leg), two samples of margin. An empty window (no pixel
    reads the pulse) has lo = hi = 0. reach: 1 for linear pairs, 2 for cubic entries."""
    n_p = tx.shape[0]
    lo = np.zeros(n_p, np.int64)
    hi = np.zeros(n_p, np.int64)
    for p in numba.prange(n_p):
        a = np.inf
        b = -np.inf
        for t in range(centres.shape[0]):
            rt = math.sqrt(
                (centres[t, 0] - tx[p, 0]) ** 2 + (centres[t, 1] - tx[p, 1]) ** 2 + (centres[t, 2] - tx[p, 2]) ** 2
            )
            if monostatic:
                r = 2.0 * rt
            else:
                r = rt + math.sqrt(
                    (centres[t, 0] - rx[p, 0]) ** 2 + (centres[t, 1] - rx[p, 1]) ** 2 + (centres[t, 2] - rx[p, 2]) ** 2
                )
            a = min(a, (r - 2.0 * radius[t]) * scale + first[p])
            b = max(b, (r + 2.0 * radius[t]) * scale + first[p])
        s0 = max(math.floor(a) - 2, -float(reach))  # entries this far out still touch sample 0
        s1 = min(math.floor(b) + 3, n_s - 2.0 + reach)
        if s1 >= s0:
            lo[p] = np.int64(s0)
            hi[p] = np.int64(s1)
    return lo, hi


@numba.njit(parallel=True, error_model="numpy", cache=CACHE)
def pair_table(pulses: np.ndarray, lo: np.ndarray, pairs: np.ndarray) -> None:
    """pairs[p, k] = (x_s, x_{s+1} - x_s) for the pulse's sample s = lo[p] + k - 1 (4 float32), samples outside the
    pulse taken as zero (so s = -1 and s = n - 1 interpolate towards zero, as the reference does), and always
    zero at k = 0 and k = W, where clipped positions land (pairs: (n, W + 1, 4))."""
    n_p, n_s = pulses.shape
    n_w = pairs.shape[1] - 1
    zero = np.complex64(0.0)
    for p in numba.prange(n_p):
        for k in range(n_w + 1):
            s = lo[p] + k - 1
            if k == 0 or k == n_w or s < -1 or s >= n_s:
                for m in range(4):
                    pairs[p, k, m] = 0.0
            else:
                a = pulses[p, s] if s >= 0 else zero
                b = pulses[p, s + 1] if s + 1 < n_s else zero
                pairs[p, k, 0] = a.real
                pairs[p, k, 1] = a.imag
                pairs[p, k, 2] = b.real - a.real
                pairs[p, k, 3] = b.imag - a.imag


@numba.njit(parallel=True, error_model="numpy", cache=CACHE)
def cubic_table(pulses: np.ndarray, lo: np.ndarray, coef: np.ndarray) -> None:
    """coef[p, k] = the cubic Lagrange polynomial through samples s - 1 .. s + 2 (s = lo[p] + k - 1) as
    (c0, c1, c2, c3), value c0 + w c1 + w^2 c2 + w^3 c3 at s + w (4 complex64 = 8 float32), samples outside the
    pulse taken as zero; zero at k = 0 and k = W (coef: (n, W + 1, 8))."""
    n_p, n_s = pulses.shape
    n_w = coef.shape[1] - 1
    zero = np.complex64(0.0)
    third = np.float32(1.0 / 3.0)
    sixth = np.float32(1.0 / 6.0)
    half = np.float32(0.5)
    for p in numba.prange(n_p):
        for k in range(n_w + 1):
            s = lo[p] + k - 1
            if k == 0 or k == n_w or s < -2 or s > n_s:
                for m in range(8):
                    coef[p, k, m] = 0.0
                continue
            xm = pulses[p, s - 1] if 0 <= s - 1 < n_s else zero
            x0 = pulses[p, s] if 0 <= s < n_s else zero
            x1 = pulses[p, s + 1] if 0 <= s + 1 < n_s else zero
            x2 = pulses[p, s + 2] if 0 <= s + 2 < n_s else zero
            c1 = x1 - xm * third - x0 * half - x2 * sixth
            c2 = (xm + x1) * half - x0
            c3 = (x0 - x1) * half + (x2 - xm) * sixth
            coef[p, k, 0] = x0.real
            coef[p, k, 1] = x0.imag
            coef[p, k, 2] = c1.real
            coef[p, k, 3] = c1.imag
            coef[p, k, 4] = c2.real
            coef[p, k, 5] = c2.imag
            coef[p, k, 6] = c3.real
            coef[p, k, 7] = c3.imag


@numba.njit(fastmath=True, error_model="numpy", cache=CACHE)
def _positions_block(
    w: np.ndarray,
    cyc: np.ndarray,
    jc: np.ndarray,
    nx: np.ndarray,
    ny: np.ndarray,
    nz: np.ndarray,
    ex: np.ndarray,
    ey: np.ndarray,
    ez: np.ndarray,
    x2: np.ndarray,
    flat: bool,
    u: tuple[np.float32, np.float32, np.float32, np.float32, np.float32],
    steps: tuple[np.float32, np.float32, np.float32, np.float32, np.float32, np.float32],
    frac0: np.float32,
    cyc0: np.float32,
    scale2: np.float32,
    kc2: np.float32,
    ibase: np.int32,
    n_w: np.int32,
) -> None:
    """The first pass of a block (monostatic, expansion accurate over the block): each pixel's offset from the
    block centre is x = n h + e (n small integers); its two-way path difference 2 (u.x + (|x|^2 - (u.x)^2) (1/2R -
    u.x / 2R^2)) gives the weight w and table entry jc; its carrier cycles are the block centre's plus n.a
    (``steps`` a: the lattice steps' cycles, reduced in float64; b: the steps' u_k h_k) plus the rest's, whose
    float32 rounding is that of u.e (|e| < h). ``flat``: n_z and e_z are all zero (a level grid), not read."""
    ux, uy, uz, hir, hir2 = u
    a0, a1, a2, b0, b1, b2 = steps
    base, top = np.float32(ibase), np.float32(n_w)
    if flat:
        for i in range(len(w)):
            du = ux * ex[i] + uy * ey[i]
            ul = du + b0 * nx[i] + b1 * ny[i]
            q = (x2[i] - ul * ul) * (hir - ul * hir2)
            t = frac0 + (ul + q) * scale2
            f = np.floor(t)
            w[i] = t - f
            cyc[i] = cyc0 + a0 * nx[i] + a1 * ny[i] + (du + q) * kc2
            jc[i] = _entry(f, base, top)
    else:
        for i in range(len(w)):
            du = ux * ex[i] + uy * ey[i] + uz * ez[i]
            ul = du + b0 * nx[i] + b1 * ny[i] + b2 * nz[i]
            q = (x2[i] - ul * ul) * (hir - ul * hir2)
            t = frac0 + (ul + q) * scale2
            f = np.floor(t)
            w[i] = t - f
            cyc[i] = cyc0 + a0 * nx[i] + a1 * ny[i] + a2 * nz[i] + (du + q) * kc2
            jc[i] = _entry(f, base, top)


@numba.njit(fastmath=True, error_model="numpy", cache=CACHE)
def _combine_block(
    acc_re: np.ndarray, acc_im: np.ndarray, a: np.ndarray, b: np.ndarray, w: np.ndarray, cyc: np.ndarray
) -> None:
    """_combine_from_dr with each pixel's weight and carrier cycles from _positions_block."""
    half = np.float32(0.5)
    for i in range(len(acc_re)):
        c = cyc[i]
        co, si = cis_cycles32_short(c - np.floor(c + half))
        vr = a[2 * i] + w[i] * b[2 * i]
        vi = a[2 * i + 1] + w[i] * b[2 * i + 1]
        acc_re[i] += vr * co - vi * si
        acc_im[i] += vr * si + vi * co


@numba.njit(error_model="numpy", cache=CACHE)
def _block_reference(
    cx: float, cy: float, cz: float, tx: np.ndarray, p: int, scale: float, first: np.ndarray, kc: float
) -> tuple[np.int64, float, float, float, float, float, float]:
    """Per block and pulse, monostatic, float64: integer sample, fraction and reduced carrier cycles of the block
    centre's delay, the unit vector to it and its range."""
    ax, ay, az = cx - tx[p, 0], cy - tx[p, 1], cz - tx[p, 2]
    r = math.sqrt(ax * ax + ay * ay + az * az)
    ir = 1.0 / r
    pos0 = 2.0 * r * scale + first[p]
    base = math.floor(pos0)
    cyc = 2.0 * r * kc
    return np.int64(base), pos0 - base, cyc - math.floor(cyc), ax * ir, ay * ir, az * ir, r


@numba.njit(error_model="numpy", cache=CACHE)
def _tile_pulse(
    pulses: np.ndarray,
    halves: np.ndarray,
    quads: np.ndarray,
    per_pulse: np.uint64,
    first: np.ndarray,
    scale: float,
    kc: float,
    tx: np.ndarray,
    rx: np.ndarray,
    monostatic: bool,
    centre: np.ndarray,
    h4kc: float,
    p: int,
    dx: np.ndarray,
    dy: np.ndarray,
    dz: np.ndarray,
    d2: np.ndarray,
    mode: int,
    table: np.ndarray,
    taps: int,
    n_s: np.int32,
    acc_re: np.ndarray,
    acc_im: np.ndarray,
    dr: np.ndarray,
    frac: np.ndarray,
    cos_: np.ndarray,
    sin_: np.ndarray,
    jc: np.ndarray,
    gq: np.ndarray,
    ga: np.ndarray,
    gb: np.ndarray,
    g: np.ndarray,
    ga32: np.ndarray,
    gb32: np.ndarray,
) -> None:
    """One tile's sums += one pulse's contributions (the arrays: the tile's pixels; dr .. sin_ and the gather
    buffers: room for them; g, ga32, gb32: the float32 views of gq, ga, gb): a block's tiles one by one where
    the expansion does not hold over the block (backproject_tiles writes the same steps out for a tile alone)."""
    scale32 = np.float32(scale)
    kc32 = np.float32(kc)
    ibase, frac0, cyc0, geo_t, geo_r = _pulse_reference(
        centre[0], centre[1], centre[2], tx, rx, p, monostatic, scale, first, kc, h4kc
    )
    # the tile's base sample, clipped so that int32 offsets cannot overflow (far reads add nothing anyway)
    ib = np.int32(min(max(ibase, -(1 << 28)), 1 << 28))
    fused = (mode == 1 or mode == 3) and monostatic and geo_t[7]
    if fused:
        _path_indices_mono(dr, jc, dx, dy, dz, d2, geo_t, frac0, scale32, ib, n_s)
    else:
        _path_differences(dr, dx, dy, dz, d2, geo_t, geo_r, monostatic)
    if mode == 1 or mode == 3:
        if not fused:
            _indices(dr, jc, frac0, scale32, ib, n_s)
        if mode == 1:
            _gather_pairs(halves, np.uint64(p) * per_pulse, jc, ga, gb)
            _combine_from_dr(acc_re, acc_im, ga32, gb32, dr, frac0, cyc0, scale32, kc32)
        else:
            _gather_quads(quads, np.uint64(p) * per_pulse, jc, gq)
            _combine_cubic(acc_re, acc_im, g, dr, frac0, cyc0, scale32, kc32)
    else:
        _positions(dr, frac, cos_, sin_, frac0, cyc0, scale32, kc32)
        row = pulses[p]
        if mode == 0:
            _accumulate_nearest(acc_re, acc_im, frac, cos_, sin_, row.view(np.float32), ib, n_s)
        else:
            _accumulate_table(acc_re, acc_im, frac, cos_, sin_, row, ib, n_s, table, taps)


@numba.njit(error_model="numpy", cache=CACHE)
def _max_norm2(d2: np.ndarray) -> float:
    h2 = 0.0
    for i in range(len(d2)):
        h2 = max(h2, float(d2[i]))
    return h2


@numba.njit(parallel=True, error_model="numpy", cache=CACHE)
def backproject_tiles(
    pulses: np.ndarray,
    pairs: np.ndarray,
    first: np.ndarray,
    scale: float,
    kc: float,
    tx: np.ndarray,
    rx: np.ndarray,
    monostatic: bool,
    centres: np.ndarray,
    tile_start: np.ndarray,
    block_start: np.ndarray,
    d: np.ndarray,
    mode: int,
    table: np.ndarray,
    taps: int,
    acc: np.ndarray,
) -> None:
    """Add the pulses' contributions to ``acc`` (complex128, one entry per sorted pixel).

    pulses: (n_pulses, n_samples) complex64, sample j at range-delay index j (reads outside 0 .. n_samples-1 add
    nothing), read by modes 0 and 2; pairs: (n_pulses, W + 1, 4) float32, :func:`pair_table`, read by mode 1, or
    (n_pulses, W + 1, 8), :func:`cubic_table`, read by mode 3 (entry k at sample position k of ``first``'s count,
    i.e. first shifted by the window start);
    first: (n_pulses,) float64, sample position of zero two-way path; scale: samples per metre of two-way path
    (fs / c); kc: carrier cycles per metre (f_c / c); tx, rx: (n_pulses, 3) float64 relative to the
    tiles' origin; centres: (n_tiles, 3) float64; tile_start: (n_tiles + 1,) int64 into the sorted pixels;
    block_start: the blocks of tiles to run (make_tiles; a slice of its array: those blocks only);
    d: (4, n_pixels) float32 rows dx, dy, dz, |d|^2 of each pixel from its tile centre;
    mode: 0 nearest, 1 linear, 2 tabulated kernel of ``taps`` taps with ``table`` (steps + 1, taps), 3 cubic.

    A block of several tiles (make_tiles' ``block``: tiles under the carrier-cycle cap, coarse pixels) on linear
    monostatic reads runs as one tile where the expansion holds over it: per pulse its centre's range in float64
    and the carrier cycles of the steps of a lattice (x = n h + e, n small integers, each pixel's offset from the
    block centre) reduced in float64; per pixel n.a + u.e + the block-wide second- and third-order terms in
    float32, which round ~10x finer than a tile's u.d (|e| < h ~ 1 m, not a tile radius); one pass over all the
    block's pixels, with nothing per tile.
    """
    n_pulses = len(first)
    n_s = np.int32(pairs.shape[1] - 1) if mode in (1, 3) else np.int32(pulses.shape[1])
    scale32 = np.float32(scale)
    kc32 = np.float32(kc)
    # the tables as flat arrays of their entries' halves (linear) or entries (cubic), pulse p's from 2 p (W + 1):
    # views made once, not per tile and pulse (each view costs its reference count's atomic updates)
    flat = pairs.reshape(-1)
    halves = flat.view(np.complex64)
    quads = flat.view(np.complex128)
    per_pulse = np.uint64(2 * pairs.shape[1])
    for blk in numba.prange(len(block_start) - 1):
        t0, t1 = block_start[blk], block_start[blk + 1]
        s0, s1 = tile_start[t0], tile_start[t1]
        n = s1 - s0
        acc_re = np.zeros(n, np.float32)
        acc_im = np.zeros(n, np.float32)
        scratch = np.empty((4, n), np.float32)
        jc = np.empty(n, np.uint32)
        gq = np.empty(2 * n if mode == 3 else 0, np.complex128)  # 32-byte cubic entries, moved bit for bit
        ga = np.empty(n if mode == 1 else 0, np.complex64)  # the linear entries' halves
        gb = np.empty(n if mode == 1 else 0, np.complex64)
        g, ga32, gb32 = gq.view(np.float32), ga.view(np.float32), gb.view(np.float32)
        dr, frac, cos_, sin_ = scratch[0], scratch[1], scratch[2], scratch[3]
        dx, dy, dz, d2 = d[0, s0:s1], d[1, s0:s1], d[2, s0:s1], d[3, s0:s1]
        h4kc = np.empty(t1 - t0)
        for t in range(t0, t1):
            h2 = _max_norm2(d[3, tile_start[t] : tile_start[t + 1]])
            h4kc[t - t0] = h2 * h2 * kc
        if t1 - t0 == 1:  # a tile alone: _tile_pulse written out (called, its array arguments cost ~0.2 us)
            cx, cy, cz = centres[t0, 0], centres[t0, 1], centres[t0, 2]
            for p in range(n_pulses):
                ibase, frac0, cyc0, geo_t, geo_r = _pulse_reference(
                    cx, cy, cz, tx, rx, p, monostatic, scale, first, kc, h4kc[0]
                )
                # the tile's base sample, clipped so that int32 offsets cannot overflow (far reads add nothing)
                ib = np.int32(min(max(ibase, -(1 << 28)), 1 << 28))
                fused = (mode == 1 or mode == 3) and monostatic and geo_t[7]
                if fused:
                    _path_indices_mono(dr, jc, dx, dy, dz, d2, geo_t, frac0, scale32, ib, n_s)
                else:
                    _path_differences(dr, dx, dy, dz, d2, geo_t, geo_r, monostatic)
                if mode == 1 or mode == 3:
                    if not fused:
                        _indices(dr, jc, frac0, scale32, ib, n_s)
                    if mode == 1:
                        _gather_pairs(halves, np.uint64(p) * per_pulse, jc, ga, gb)
                        _combine_from_dr(acc_re, acc_im, ga32, gb32, dr, frac0, cyc0, scale32, kc32)
                    else:
                        _gather_quads(quads, np.uint64(p) * per_pulse, jc, gq)
                        _combine_cubic(acc_re, acc_im, g, dr, frac0, cyc0, scale32, kc32)
                else:
                    _positions(dr, frac, cos_, sin_, frac0, cyc0, scale32, kc32)
                    row = pulses[p]
                    if mode == 0:
                        _accumulate_nearest(acc_re, acc_im, frac, cos_, sin_, row.view(np.float32), ib, n_s)
                    else:
                        _accumulate_table(acc_re, acc_im, frac, cos_, sin_, row, ib, n_s, table, taps)
        else:
            # the block's centre (its tiles' centres' box) and the pixels' offsets x from it, as n h + e on a lattice
            # of step h: per pulse the lattice steps' carrier cycles are reduced in float64, so a pixel's float32
            # cycles round as u.e's (|e| < h) and n.a's (small integers n), not as u.x's over the whole block.
            # h = sqrt(radius / kc) balances the two (about 0.8 m on 1.4 x 2.2 m X-band pixels, rounding ~10 x
            # below the tile by tile pass's u.d), and no per-tile step is left in a pulse.
            cb = np.empty(3)
            for k in range(3):
                cb[k] = 0.5 * (centres[t0:t1, k].min() + centres[t0:t1, k].max())
            hb2 = 0.0
            for t in range(t0, t1):
                for i in range(tile_start[t] - s0, tile_start[t + 1] - s0):
                    r2 = 0.0
                    for k in range(3):
                        v = centres[t, k] - cb[k] + d[k, s0 + i]
                        r2 += v * v
                    hb2 = max(hb2, r2)
            h4kc_b = hb2 * hb2 * kc
            step = math.sqrt(max(math.sqrt(hb2), 1e-3) / kc)
            lat = np.empty((7, n), np.float32)  # rows n_x, n_y, n_z, e_x, e_y, e_z, |x|^2
            for t in range(t0, t1):
                for i in range(tile_start[t] - s0, tile_start[t + 1] - s0):
                    r2 = 0.0
                    for k in range(3):
                        v = centres[t, k] - cb[k] + d[k, s0 + i]
                        m = math.floor(v / step + 0.5)
                        lat[k, i] = m
                        lat[3 + k, i] = v - m * step
                        r2 += v * v
                    lat[6, i] = r2
            nx, ny, nz, ex, ey, ez, x2 = lat[0], lat[1], lat[2], lat[3], lat[4], lat[5], lat[6]
            level = not (np.any(nz) or np.any(ez))  # a level grid's block: its z terms are zero, not read
            w, cyc = frac, cos_
            scale2, kc2 = np.float32(2.0 * scale), np.float32(2.0 * kc)
            for p in range(n_pulses):
                ibase, frac0, cyc0, ux, uy, uz, r = _block_reference(cb[0], cb[1], cb[2], tx, p, scale, first, kc)
                if mode == 1 and monostatic and h4kc_b / (r * r * r) < EXPANSION_LIMIT_CYCLES:
                    ib = np.int32(min(max(ibase, -(1 << 28)), 1 << 28))
                    u = (np.float32(ux), np.float32(uy), np.float32(uz), np.float32(0.5 / r), np.float32(0.5 / (r * r)))
                    av = (2.0 * kc * step * ux, 2.0 * kc * step * uy, 2.0 * kc * step * uz)
                    steps = (
                        np.float32(av[0] - math.floor(av[0] + 0.5)),
                        np.float32(av[1] - math.floor(av[1] + 0.5)),
                        np.float32(av[2] - math.floor(av[2] + 0.5)),
                        np.float32(step * ux),
                        np.float32(step * uy),
                        np.float32(step * uz),
                    )
                    _positions_block(
                        w, cyc, jc, nx, ny, nz, ex, ey, ez, x2, level, u, steps, np.float32(frac0), np.float32(cyc0),
                        scale2, kc2, ib, n_s,
                    )  # fmt: skip
                    _gather_pairs(halves, np.uint64(p) * per_pulse, jc, ga, gb)
                    _combine_block(acc_re, acc_im, ga32, gb32, w, cyc)
                else:  # tile by tile
                    for t in range(t0, t1):
                        a, b = tile_start[t] - s0, tile_start[t + 1] - s0
                        qa, qb = (2 * a, 2 * b) if mode == 3 else (0, 0)
                        la, lb = (a, b) if mode == 1 else (0, 0)
                        _tile_pulse(
                            pulses, halves, quads, per_pulse, first, scale, kc, tx, rx, monostatic, centres[t],
                            h4kc[t - t0], p, dx[a:b], dy[a:b], dz[a:b], d2[a:b], mode, table, taps, n_s, acc_re[a:b],
                            acc_im[a:b], dr[a:b], frac[a:b], cos_[a:b], sin_[a:b], jc[a:b], gq[qa:qb], ga[la:lb],
                            gb[la:lb], g[4 * qa : 4 * qb], ga32[2 * la : 2 * lb], gb32[2 * la : 2 * lb],
                        )  # fmt: skip
        for i in range(n):
            acc[s0 + i] += complex(acc_re[i], acc_im[i])


@numba.njit(parallel=True, error_model="numpy", cache=CACHE)
def scatter_scaled(acc: np.ndarray, order: np.ndarray, divisor: float, out: np.ndarray) -> None:
    """out[order[i]] = acc[i] / divisor: the tile-sorted sums back in the points' order, in one parallel pass."""
    for i in numba.prange(len(acc)):
        out[order[i]] = acc[i] / divisor


@numba.njit(fastmath=True, error_model="numpy", cache=CACHE)
def bounds(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(min, max) over points (n, 3) float64 per coordinate, in one vectorised pass (points must be finite: under
    fastmath a NaN is not propagated, so the result does not tell whether one was there)."""
    lo = np.full(3, np.inf)
    hi = np.full(3, -np.inf)
    if points.shape[0] == 0:
        return lo, hi
    for k in range(3):
        a = points[0, k]
        b = points[0, k]
        for i in range(points.shape[0]):
            v = points[i, k]
            a = min(a, v)
            b = max(b, v)
        lo[k] = a
        hi[k] = b
    return lo, hi


@numba.njit(parallel=True, error_model="numpy", cache=CACHE)
def _tile_layout(
    points: np.ndarray,
    origin: np.ndarray,
    lo: np.ndarray,
    hi: np.ndarray,
    tile_size: float,
    max_tile: int,
    block: int,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Counting sort of the points by spatial cell (lo, hi: the points' bounds relative to ``origin``), tiles of
    at most ``max_tile`` points, each tile's bounding-box centre and the points' float32 offsets from it, and the
    tiles in blocks of ``block`` cells a side (consecutive; each tile its own block where ``block`` is 1). The
    cell keys and the per-tile passes run in parallel; the sort itself is one serial counting pass."""
    n = points.shape[0]
    g = max(np.int64(block), np.int64(1))
    dims = np.empty(3, np.int64)
    for k in range(3):
        dims[k] = -(-(np.int64(math.floor((hi[k] - lo[k]) / tile_size)) + 1) // g) * g  # whole blocks
    key = np.empty(n, np.int64)
    zero = np.int64(0)
    for i in numba.prange(n):
        c0 = max(np.int64(math.floor((points[i, 0] - origin[0] - lo[0]) / tile_size)), zero)
        c1 = max(np.int64(math.floor((points[i, 1] - origin[1] - lo[1]) / tile_size)), zero)
        c2 = max(np.int64(math.floor((points[i, 2] - origin[2] - lo[2]) / tile_size)), zero)
        c0, c1, c2 = min(c0, dims[0] - 1), min(c1, dims[1] - 1), min(c2, dims[2] - 1)
        outer = ((c0 // g) * (dims[1] // g) + c1 // g) * (dims[2] // g) + c2 // g
        key[i] = outer * g * g * g + ((c0 % g) * g + c1 % g) * g + c2 % g  # a block's cells consecutive
    n_keys = dims[0] * dims[1] * dims[2]
    count = np.zeros(n_keys + 1, np.int64)
    for i in range(n):
        count[key[i] + 1] += 1
    for k in range(n_keys):
        count[k + 1] += count[k]
    order = np.empty(n, np.int64)
    fill = count[:-1].copy()
    for i in range(n):  # stable: points keep their order inside a cell
        order[fill[key[i]]] = i
        fill[key[i]] += 1
    n_tiles = 0
    n_blocks = 0
    g3 = g * g * g
    for k in range(n_keys):
        m = count[k + 1] - count[k]
        n_tiles += (m + max_tile - 1) // max_tile
        if g > 1 and k % g3 == 0 and count[k + g3] > count[k]:
            n_blocks += 1
    if g == 1:
        n_blocks = n_tiles
    tile_start = np.empty(n_tiles + 1, np.int64)
    block_start = np.empty(n_blocks + 1, np.int64)
    t = 0
    nb = 0
    for k in range(n_keys):
        if g > 1 and k % g3 == 0 and count[k + g3] > count[k]:
            block_start[nb] = t
            nb += 1
        for s in range(count[k], count[k + 1], max_tile):
            if g == 1:
                block_start[t] = t
            tile_start[t] = s
            t += 1
    tile_start[n_tiles] = n
    block_start[n_blocks] = n_tiles
    centres = np.empty((n_tiles, 3))
    d = np.empty((4, n), np.float32)
    for t in numba.prange(n_tiles):
        a = np.full(3, np.inf)
        b = np.full(3, -np.inf)
        for j in range(tile_start[t], tile_start[t + 1]):
            for k in range(3):
                v = points[order[j], k] - origin[k]
                a[k] = min(a[k], v)
                b[k] = max(b[k], v)
        for k in range(3):
            centres[t, k] = 0.5 * (a[k] + b[k])
        for j in range(tile_start[t], tile_start[t + 1]):
            r2 = 0.0
            for k in range(3):
                v = points[order[j], k] - origin[k] - centres[t, k]
                d[k, j] = v
                r2 += v * v
            d[3, j] = r2
    return order, tile_start, centres, d, block_start


def make_tiles(
    points: np.ndarray, tile_size: float, max_tile: int = 1024, block: int = 1
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Group points into spatial tiles of about ``tile_size`` metres (at most ``max_tile`` points each).

    Returns (order, tile_start, centres, origin, d, block_start): points[order] are grouped by tile, tile t
    holding sorted indices tile_start[t] .. tile_start[t+1]-1; centres (n_tiles, 3) float64 relative to
    ``origin``; d (4, n) float32: offsets of the sorted points from their tile centre and their squared norm;
    block b: tiles block_start[b] .. block_start[b+1]-1, those of ``block`` x ``block`` (x ``block``) cells (each
    tile its own block at 1), which backproject_tiles runs together.
    """
    points = np.ascontiguousarray(np.asarray(points, float).reshape(-1, 3))
    n = len(points)
    if n == 0:
        return (
            np.zeros(0, np.int64),
            np.zeros(1, np.int64),
            np.zeros((0, 3)),
            np.zeros(3),
            np.zeros((4, 0), np.float32),
            np.zeros(1, np.int64),
        )
    if not np.isfinite(points).all():  # not from bounds(): its fastmath min/max skip a NaN after the first point
        raise ValueError("points must be finite")
    lo, hi = bounds(points)
    origin = 0.5 * (lo + hi)
    order, tile_start, centres, d, block_start = _tile_layout(
        points, origin, lo - origin, hi - origin, float(tile_size), int(max_tile), int(block)
    )
    return order, tile_start, centres, origin, d, block_start


lean_cache_loads(globals())  # cached kernels load without numba's context refresh (kernel_cache)
