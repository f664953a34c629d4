"""Compiled kernels of fast factorised backprojection (:mod:`sarproc.focus.ffbp`).

A subimage is a polar image around the in-plane foot (fx, fy) of its subaperture's centre, which is h above the
image plane: sample (a, k) is the point at range r = r0 + k dr from the centre and in-plane angle
theta = th_mid + th_lo + a dth, demodulated by the carrier of that range (exp(-j 2 pi kc2 r)), so that it is
band-limited in both coordinates. Geometry rows (float64): fx, fy, h, r0, dr, th_mid, th_lo, dth, cos th_mid,
sin th_mid, 1 / dr, 1 / dth; integer rows:
n_theta, n_range, offset into the level's flat complex64 buffer. A subimage with n_theta = 1 (a single pulse)
does not depend on the angle.

Reads are separable (range x angle) with tabulated weights (:func:`sarproc.focus.ffbp.read_table`): row c of a
(steps + 1, taps) table holds the weights of samples floor(p) + 1 - taps/2 + m for the fraction c / steps (the
nearest row is read), so one kernel serves linear, cubic Lagrange and Knab reads of any length.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from sarproc.dsp.kernel_cache import CACHE, lean_cache_loads
from sarproc.dsp.phasor_kernels import cis_cycles32_short


@numba.njit(fastmath=True, error_model="numpy", inline="always", cache=CACHE)
def _fill_weights(table: np.ndarray, pos: float, w: np.ndarray) -> int:
    """Weights of the table's taps at fractional sample ``pos`` (its nearest row) into w; returns the first
    sample's index."""
    steps = table.shape[0] - 1
    p0 = math.floor(pos)
    cell = int((pos - p0) * steps + 0.5)
    taps = table.shape[1]
    for m in range(taps):
        w[m] = table[cell, m]
    return int(p0) + 1 - taps // 2


@numba.njit(fastmath=True, error_model="numpy", inline="always", cache=CACHE)
def _atan_series(z: float) -> float:
    """arctan(z) for |z| <= 1/4 (error < 1e-10 rad), branch-free."""
    z2 = z * z
    return z * (
        1.0
        + z2
        * (
            -1.0 / 3
            + z2
            * (
                1.0 / 5
                + z2
                * (-1.0 / 7 + z2 * (1.0 / 9 + z2 * (-1.0 / 11 + z2 * (1.0 / 13 + z2 * (-1.0 / 15 + z2 * (1.0 / 17))))))
            )
        )
    )


@numba.njit(fastmath=True, error_model="numpy", inline="always", cache=CACHE)
def _relative_angle(dx: float, dy: float, cm: float, sm: float) -> float:
    """Angle of (dx, dy) from the direction (cm, sm), in (-pi, pi]: a series for |tan| <= 1/4 (error < 1e-10 rad;
    polar grids span a few degrees), atan2 beyond."""
    dot = dx * cm + dy * sm
    crs = dy * cm - dx * sm
    if dot > 0.0 and abs(crs) <= 0.25 * dot:
        return _atan_series(crs / dot)
    return math.atan2(crs, dot)


@numba.njit(fastmath=True, error_model="numpy", inline="always", cache=CACHE)
def _read(
    buf: np.ndarray,
    geo: np.ndarray,
    ints: np.ndarray,
    c: int,
    x: float,
    y: float,
    z: float,
    r_ref: float,
    kc2: float,
    tab_r: np.ndarray,
    tab_t: np.ndarray,
    wr: np.ndarray,
    wt: np.ndarray,
) -> tuple[float, float]:
    """Subimage c read at the plane point (x, y, z), re-modulated by the carrier of its range from c's centre and
    demodulated by that of ``r_ref``: its contribution exp(j 2 pi kc2 (r_c - r_ref)) x value. wr, wt: scratch
    for the range and angle weights (zero outside the subimage)."""
    dx = x - geo[c, 0]
    dy = y - geo[c, 1]
    dz = geo[c, 2] - z
    rc = math.sqrt(dx * dx + dy * dy + dz * dz)
    n_t, n_r, off = ints[c, 0], ints[c, 1], ints[c, 2]
    taps_r = tab_r.shape[1]
    i0 = _fill_weights(tab_r, (rc - geo[c, 3]) * geo[c, 10], wr)
    if n_t == 1:
        taps_t = 1
        a0 = 0
        wt[0] = 1.0
    else:
        taps_t = tab_t.shape[1]
        th = _relative_angle(dx, dy, geo[c, 8], geo[c, 9])
        a0 = _fill_weights(tab_t, (th - geo[c, 6]) * geo[c, 11], wt)
    re = np.float32(0.0)
    im = np.float32(0.0)
    if i0 >= 0 and i0 + taps_r <= n_r and a0 >= 0 and a0 + taps_t <= n_t:
        for m in range(taps_t):
            base = off + (a0 + m) * n_r + i0
            sr = np.float32(0.0)
            si = np.float32(0.0)
            for j in range(taps_r):
                v = buf[base + j]
                sr += wr[j] * v.real
                si += wr[j] * v.imag
            re += wt[m] * sr
            im += wt[m] * si
    else:
        for m in range(taps_t):
            a = a0 + m
            if a < 0 or a >= n_t:
                continue
            sr = np.float32(0.0)
            si = np.float32(0.0)
            for j in range(taps_r):
                i = i0 + j
                if i >= 0 and i < n_r:
                    v = buf[off + a * n_r + i]
                    sr += wr[j] * v.real
                    si += wr[j] * v.imag
            re += wt[m] * sr
            im += wt[m] * si
    cyc = kc2 * (rc - r_ref)
    cyc -= math.floor(cyc + 0.5)
    co, si_ = cis_cycles32_short(np.float32(cyc))
    return re * co - im * si_, re * si_ + im * co


@numba.njit(fastmath=True, error_model="numpy", inline="always", cache=CACHE)
def _child_along_ray(
    cgeo: np.ndarray,
    c: int,
    pgeo: np.ndarray,
    s: int,
    ct: float,
    st: float,
    rho: np.ndarray,
    kc2: float,
    pos: np.ndarray,
    cos_: np.ndarray,
    sin_: np.ndarray,
) -> tuple[float, float, float, float, float, float]:
    """Child c's fractional range sample (pos) and carrier phasor (cos_, sin_) at each sample of parent s's ray
    (direction ct, st; in-plane ranges rho), branch-free so that it vectorises. Returns the parent foot's offset
    from the child's centre (dx0, dy0), u . d and |d|^2 + h^2 of it (ud, c0), and the least and largest pos."""
    dx0 = pgeo[s, 0] - cgeo[c, 0]
    dy0 = pgeo[s, 1] - cgeo[c, 1]
    ud = ct * dx0 + dy0 * st
    c0 = dx0 * dx0 + dy0 * dy0 + cgeo[c, 2] * cgeo[c, 2]
    for k in range(len(rho)):
        rc = math.sqrt(rho[k] * rho[k] + 2.0 * rho[k] * ud + c0)
        pos[k] = (rc - cgeo[c, 3]) * cgeo[c, 10]
        cy = kc2 * (rc - pgeo[s, 3] - k * pgeo[s, 4])
        cos_[k], sin_[k] = cis_cycles32_short(np.float32(cy - math.floor(cy + 0.5)))
    lo, hi = pos[0], pos[0]
    for k in range(len(rho)):  # a select, not min(): numba's min checks for NaN and stays scalar
        lo = pos[k] if pos[k] < lo else lo
        hi = pos[k] if pos[k] > hi else hi
    return dx0, dy0, ud, c0, lo, hi


@numba.njit(fastmath=True, error_model="numpy", inline="always", cache=CACHE)
def _add_pulse_linear(
    pulse: np.ndarray,
    i_lo: int,
    last: int,
    pos: np.ndarray,
    cos_: np.ndarray,
    sin_: np.ndarray,
    acc_re: np.ndarray,
    acc_im: np.ndarray,
) -> None:
    """Linear reads of a pulse (``pulse``: its samples i_lo .. last + i_lo + 1 as interleaved float32), the weights
    from the fraction itself, branch-free: the pair of samples j0, j0 + 1 nearest the read, weighted as the read's
    own taps where they are; each read turned by its carrier phasor and added to acc."""
    for k in range(len(pos)):
        f = math.floor(pos[k])
        t = np.float32(pos[k] - f)
        i0 = int(f) - i_lo
        j0 = min(max(i0, 0), last)
        one = np.float32(1.0)
        w0 = one - t if i0 == j0 else (t if i0 == j0 - 1 else np.float32(0.0))
        w1 = t if i0 == j0 else (one - t if i0 == j0 + 1 else np.float32(0.0))
        b = 2 * j0
        xr = w0 * pulse[b] + w1 * pulse[b + 2]
        xi = w0 * pulse[b + 1] + w1 * pulse[b + 3]
        acc_re[k] += xr * cos_[k] - xi * sin_[k]
        acc_im[k] += xr * sin_[k] + xi * cos_[k]


@numba.njit(fastmath=True, error_model="numpy", inline="always", cache=CACHE)
def _add_pulse_one_sample(
    cbuf: np.ndarray,
    offc: int,
    i_lo: int,
    i_hi: int,
    pos: np.ndarray,
    cos_: np.ndarray,
    sin_: np.ndarray,
    acc_re: np.ndarray,
    acc_im: np.ndarray,
) -> None:
    """Linear reads of a pulse with one sample in reach (i_lo == i_hi), added to acc as in _add_pulse_linear."""
    for k in range(len(pos)):
        f = math.floor(pos[k])
        i0 = int(f)
        t = np.float32(pos[k] - f)
        if i0 >= i_lo and i0 + 1 <= i_hi:
            v0 = cbuf[offc + i0]
            v1 = cbuf[offc + i0 + 1]
            xr = v0.real + t * (v1.real - v0.real)
            xi = v0.imag + t * (v1.imag - v0.imag)
        else:
            xr = np.float32(0.0)
            xi = np.float32(0.0)
            if i0 >= i_lo and i0 <= i_hi:
                xr += (1 - t) * cbuf[offc + i0].real
                xi += (1 - t) * cbuf[offc + i0].imag
            if i0 + 1 >= i_lo and i0 + 1 <= i_hi:
                xr += t * cbuf[offc + i0 + 1].real
                xi += t * cbuf[offc + i0 + 1].imag
        acc_re[k] += xr * cos_[k] - xi * sin_[k]
        acc_im[k] += xr * sin_[k] + xi * cos_[k]


@numba.njit(fastmath=True, error_model="numpy", inline="always", cache=CACHE)
def _add_pulse_table(
    cbuf: np.ndarray,
    offc: int,
    i_lo: int,
    i_hi: int,
    tab_r: np.ndarray,
    wr: np.ndarray,
    pos: np.ndarray,
    cos_: np.ndarray,
    sin_: np.ndarray,
    acc_re: np.ndarray,
    acc_im: np.ndarray,
) -> None:
    """A pulse read by the range table (cubic): read by read, its samples a few apart (no runs); taps outside
    i_lo .. i_hi are left out. Each read turned by its carrier phasor and added to acc."""
    taps_r = tab_r.shape[1]
    for k in range(len(pos)):
        i0 = _fill_weights(tab_r, pos[k], wr)
        xr = np.float32(0.0)
        xi = np.float32(0.0)
        for j in range(taps_r):
            if i0 + j >= i_lo and i0 + j <= i_hi:
                v = cbuf[offc + i0 + j]
                xr += wr[j] * v.real
                xi += wr[j] * v.imag
        acc_re[k] += xr * cos_[k] - xi * sin_[k]
        acc_im[k] += xr * sin_[k] + xi * cos_[k]


@numba.njit(fastmath=True, error_model="numpy", inline="always", cache=CACHE)
def _crossing_angles(
    cgeo: np.ndarray,
    c: int,
    i_lo: int,
    n_i: int,
    dx0: float,
    dy0: float,
    ud: float,
    c0: float,
    ct: float,
    st: float,
    ang: np.ndarray,
) -> None:
    """Child c's fractional angle sample (ang) where the ray crosses its range samples i_lo .. i_lo + n_i - 1: by
    the arctangent's series, valid for |tan| <= 1/4 ahead of the child's centre line (polar grids span a few
    degrees); any other crossing (or none: disc < 0) is redone with atan2, a ray that never reaches a range
    getting a position that no tap reaches."""
    cm, sm = cgeo[c, 8], cgeo[c, 9]
    odd = 0
    for i in range(n_i):
        rci = cgeo[c, 3] + (i_lo + i) * cgeo[c, 4]
        disc = ud * ud - c0 + rci * rci
        rr = math.sqrt(max(disc, 0.0)) - ud
        dx = dx0 + rr * ct
        dy = dy0 + rr * st
        dot = dx * cm + dy * sm
        crs = dy * cm - dx * sm
        ang[i] = (_atan_series(crs / dot) - cgeo[c, 6]) * cgeo[c, 11]
        odd += (disc < 0.0) | (dot <= 0.0) | (abs(crs) > 0.25 * dot)
    if odd:
        for i in range(n_i):
            rci = cgeo[c, 3] + (i_lo + i) * cgeo[c, 4]
            disc = ud * ud - c0 + rci * rci
            rr = math.sqrt(max(disc, 0.0)) - ud
            th = _relative_angle(dx0 + rr * ct, dy0 + rr * st, cm, sm)
            ang[i] = (th - cgeo[c, 6]) * cgeo[c, 11] if disc >= 0.0 else -1e9


@numba.njit(fastmath=True, error_model="numpy", inline="always", cache=CACHE)
def _angle_pass(
    cbuf: np.ndarray,
    offc: int,
    n_tc: int,
    n_rc: int,
    i_lo: int,
    n_i: int,
    ang: np.ndarray,
    tab_t: np.ndarray,
    a0: np.ndarray,
    wta: np.ndarray,
    row_re: np.ndarray,
    row_im: np.ndarray,
    pad: int,
) -> None:
    """Pass 1: the child read in angle at fractional angle samples ang[:n_i] of its range samples i_lo .., into the
    row (offset by pad). Runs of equal first angle sample (the crossings drift by about a sample over the image):
    each tap of a run reads one child row contiguously."""
    taps_t = tab_t.shape[1]
    steps_t = tab_t.shape[0] - 1
    for i in range(n_i):
        p = min(max(ang[i], -2.0 * taps_t), n_tc + 2.0 * taps_t)
        f = math.floor(p)
        a0[i] = int(f) + 1 - taps_t // 2
        cl = int((p - f) * steps_t + 0.5)
        for m in range(taps_t):
            wta[m, i] = tab_t[cl, m]
        row_re[pad + i] = 0.0
        row_im[pad + i] = 0.0
    i = 0
    while i < n_i:
        e = i + 1
        while e < n_i and a0[e] == a0[i]:
            e += 1
        dst_re = row_re[pad + i : pad + e]
        dst_im = row_im[pad + i : pad + e]
        for m in range(taps_t):
            aa = a0[i] + m
            if aa < 0 or aa >= n_tc:
                continue
            b = offc + aa * n_rc + i_lo
            src = cbuf[b + i : b + e]
            w = wta[m, i:e]
            for u in range(e - i):
                dst_re[u] += w[u] * src[u].real
                dst_im[u] += w[u] * src[u].imag
        i = e


@numba.njit(fastmath=True, error_model="numpy", inline="always", cache=CACHE)
def _range_pass(
    row_re: np.ndarray,
    row_im: np.ndarray,
    pad: int,
    i_lo: int,
    i_hi: int,
    n_i: int,
    pos: np.ndarray,
    tab_r: np.ndarray,
    first: np.ndarray,
    wra: np.ndarray,
    vr: np.ndarray,
    vi: np.ndarray,
) -> None:
    """Pass 2: the row (the child along the ray at its range samples i_lo .. i_hi, zero-padded by pad) read in range
    at the parent's fractional samples pos, into (vr, vi). Runs of equal offset between the parent's and the
    child's samples (they drift by a few samples over the image): each tap of a run reads the row contiguously."""
    taps_r = tab_r.shape[1]
    steps_r = tab_r.shape[0] - 1
    n_r = len(pos)
    for i in range(pad):
        row_re[pad + n_i + i] = 0.0
        row_im[pad + n_i + i] = 0.0
    for k in range(n_r):
        p = min(max(pos[k], i_lo - 2.0 * pad), i_hi + 2.0 * pad)
        f = math.floor(p)
        first[k] = min(max(int(f) + 1 - taps_r // 2 - i_lo, -pad), n_i) + pad
        cl = int((p - f) * steps_r + 0.5)
        for j in range(taps_r):
            wra[j, k] = tab_r[cl, j]
        vr[k] = 0.0
        vi[k] = 0.0
    k = 0
    while k < n_r:
        e = k + 1
        while e < n_r and first[e] - e == first[k] - k:
            e += 1
        d = first[k] - k
        dst_re = vr[k:e]
        dst_im = vi[k:e]
        for j in range(taps_r):
            src_re = row_re[k + d + j : e + d + j]
            src_im = row_im[k + d + j : e + d + j]
            w = wra[j, k:e]
            for u in range(e - k):
                dst_re[u] += w[u] * src_re[u]
                dst_im[u] += w[u] * src_im[u]
        k = e


@numba.njit(parallel=True, fastmath=True, error_model="numpy", cache=CACHE)
def merge_level(
    cbuf: np.ndarray,
    cgeo: np.ndarray,
    cints: np.ndarray,
    first_child: np.ndarray,
    pgeo: np.ndarray,
    pints: np.ndarray,
    pbuf: np.ndarray,
    row_parent: np.ndarray,
    row_angle: np.ndarray,
    kc2: float,
    tab_r: np.ndarray,
    tab_t: np.ndarray,
    max_child_range: int,
    linear_pulses: bool,
) -> None:
    """Each parent polar sample: the sum of its children read at its plane point (one job per parent row).

    A parent row is a ray from its foot; along it a child's range grows monotonically (the platform does not pass
    over the image), so a child is read in two 1D passes instead of one 2D one: first in angle at its own range
    samples, at the point where the ray crosses each (the row's values as a function of the child's range, band
    limited like the child's rows since the ray's angle from the child drifts by about a sample over the whole
    image), then in range at the parent's samples: taps_r + taps_t multiply-adds a read instead of their product.
    ``linear_pulses``: single-pulse children are read linearly with weights from the fraction itself.

    Both passes loop over samples innermost and over taps outside (gathers of the tables' weights and of the
    samples, taps outside a child masked to zero), so that they vectorise."""
    taps_r = tab_r.shape[1]
    taps_t = tab_t.shape[1]
    cf = cbuf.view(np.float32)
    pad = max(taps_r, 2)
    # scratch along a child's range (children of more than one pulse): its angle reads and its row
    n_ang = max_child_range if cints[:, 0].max() > 1 else 1
    n_row = max_child_range + 2 * pad if n_ang > 1 else 1
    for job in numba.prange(len(row_parent)):
        s = row_parent[job]
        a = row_angle[job]
        th = pgeo[s, 5] + pgeo[s, 6] + a * pgeo[s, 7]
        ct, st = math.cos(th), math.sin(th)
        n_r, off = pints[s, 1], pints[s, 2] + a * pints[s, 1]
        h2 = pgeo[s, 2] * pgeo[s, 2]
        rho = np.empty(n_r)
        for k in range(n_r):
            r = pgeo[s, 3] + k * pgeo[s, 4]
            rho[k] = math.sqrt(max(r * r - h2, 0.0))
        acc_re = np.zeros(n_r, np.float32)
        acc_im = np.zeros(n_r, np.float32)
        pos = np.empty(n_r)
        cos_ = np.empty(n_r, np.float32)
        sin_ = np.empty(n_r, np.float32)
        vr = np.empty(n_r, np.float32)
        vi = np.empty(n_r, np.float32)
        first = np.empty(n_r, np.int64)
        wr = np.empty(taps_r, np.float32)
        wra = np.empty((taps_r, n_r), np.float32)
        wta = np.empty((taps_t, n_ang), np.float32)
        # the ray's values along the child's range samples, zero-padded by ``pad`` on each side
        row_re = np.zeros(n_row, np.float32)
        row_im = np.zeros(n_row, np.float32)
        ang = np.empty(n_ang)
        a0 = np.empty(n_ang, np.int64)
        for c in range(first_child[s], first_child[s + 1]):
            n_tc, n_rc, offc = cints[c, 0], cints[c, 1], cints[c, 2]
            dx0, dy0, ud, c0, lo, hi = _child_along_ray(cgeo, c, pgeo, s, ct, st, rho, kc2, pos, cos_, sin_)
            i_lo = max(0, int(math.floor(lo)) + 1 - taps_r // 2)
            i_hi = min(n_rc - 1, int(math.floor(hi)) + taps_r // 2)
            if i_lo > i_hi:
                continue
            if n_tc == 1 and linear_pulses and i_hi > i_lo:
                pulse = cf[2 * (offc + i_lo) : 2 * (offc + i_hi + 1)]  # a zero-based view: no index wrap
                _add_pulse_linear(pulse, i_lo, i_hi - i_lo - 1, pos, cos_, sin_, acc_re, acc_im)
                continue
            if n_tc == 1 and linear_pulses:
                _add_pulse_one_sample(cbuf, offc, i_lo, i_hi, pos, cos_, sin_, acc_re, acc_im)
                continue
            if n_tc == 1:
                _add_pulse_table(cbuf, offc, i_lo, i_hi, tab_r, wr, pos, cos_, sin_, acc_re, acc_im)
                continue
            n_i = i_hi - i_lo + 1
            _crossing_angles(cgeo, c, i_lo, n_i, dx0, dy0, ud, c0, ct, st, ang)
            _angle_pass(cbuf, offc, n_tc, n_rc, i_lo, n_i, ang, tab_t, a0, wta, row_re, row_im, pad)
            _range_pass(row_re, row_im, pad, i_lo, i_hi, n_i, pos, tab_r, first, wra, vr, vi)
            for k in range(n_r):
                acc_re[k] += vr[k] * cos_[k] - vi[k] * sin_[k]
                acc_im[k] += vr[k] * sin_[k] + vi[k] * cos_[k]
        dst = pbuf[off : off + n_r]
        for k in range(n_r):
            dst[k] = complex(acc_re[k], acc_im[k])


@numba.njit(fastmath=True, error_model="numpy", inline="always", cache=CACHE)
def _chunk_positions(
    geo: np.ndarray,
    c: int,
    px: np.ndarray,
    py: np.ndarray,
    pz: np.ndarray,
    lo: int,
    kc2: float,
    restore: bool,
    p_r: np.ndarray,
    p_t: np.ndarray,
    cos_: np.ndarray,
    sin_: np.ndarray,
) -> None:
    """Fractional range and angle samples (p_r, p_t) in subimage c of points lo .. lo + len(p_r) - 1, and their
    carrier phasors (see final_points' ``restore``): branch-free and vectorised (the arctangent's series; a point
    outside its range is redone with atan2)."""
    cm, sm = geo[c, 8], geo[c, 9]
    odd = 0
    for j in range(len(p_r)):
        i = lo + j
        dx = px[i] - geo[c, 0]
        dy = py[i] - geo[c, 1]
        dz = geo[c, 2] - pz[i]
        rc = math.sqrt(dx * dx + dy * dy + dz * dz)
        p_r[j] = (rc - geo[c, 3]) * geo[c, 10]
        dot = dx * cm + dy * sm
        crs = dy * cm - dx * sm
        p_t[j] = (_atan_series(crs / dot) - geo[c, 6]) * geo[c, 11]
        odd += (dot <= 0.0) | (abs(crs) > 0.25 * dot)
        ex = px[i] - geo[0, 0]
        ey = py[i] - geo[0, 1]
        ez = geo[0, 2] - pz[i]
        r_ref = 0.0 if restore else math.sqrt(ex * ex + ey * ey + ez * ez)
        cy = kc2 * (rc - r_ref)
        cos_[j], sin_[j] = cis_cycles32_short(np.float32(cy - math.floor(cy + 0.5)))
    if odd:
        for j in range(len(p_r)):
            i = lo + j
            th = _relative_angle(px[i] - geo[c, 0], py[i] - geo[c, 1], cm, sm)
            p_t[j] = (th - geo[c, 6]) * geo[c, 11]


@numba.njit(fastmath=True, error_model="numpy", inline="always", cache=CACHE)
def _add_polar_reads(
    buf: np.ndarray,
    fbuf: np.ndarray,
    off: int,
    n_t: int,
    n_r: int,
    p_r: np.ndarray,
    p_t: np.ndarray,
    cos_: np.ndarray,
    sin_: np.ndarray,
    tab_r: np.ndarray,
    tab_t: np.ndarray,
    col: np.ndarray,
    acc_re: np.ndarray,
    acc_im: np.ndarray,
) -> None:
    """A polar subimage (n_t x n_r samples at ``off``) read at fractional samples (p_r, p_t) by the tables' nearest
    rows (views, no copy), turned by the carrier phasors and added to acc; taps outside the subimage are left out.
    col: scratch of 2 taps_r floats."""
    taps_r = tab_r.shape[1]
    taps_t = tab_t.shape[1]
    steps_r, steps_t = tab_r.shape[0] - 1, tab_t.shape[0] - 1
    for j in range(len(p_r)):
        f_r, f_t = math.floor(p_r[j]), math.floor(p_t[j])
        i0 = int(f_r) + 1 - taps_r // 2
        a0 = int(f_t) + 1 - taps_t // 2
        wr = tab_r[int((p_r[j] - f_r) * steps_r + 0.5)]
        wt = tab_t[int((p_t[j] - f_t) * steps_t + 0.5)]
        re = np.float32(0.0)
        im = np.float32(0.0)
        if i0 >= 0 and i0 + taps_r <= n_r and a0 >= 0 and a0 + taps_t <= n_t:
            # rows weighted in angle first: contiguous (re, im) runs of 2 taps_r floats, vectorised
            col[:] = 0.0
            for q in range(taps_t):
                base = 2 * (off + (a0 + q) * n_r + i0)
                src = fbuf[base : base + 2 * taps_r]  # a view indexed from zero: no index wrap, vectorised
                w = wt[q]
                for k in range(2 * taps_r):
                    col[k] += w * src[k]
            for k in range(taps_r):
                re += wr[k] * col[2 * k]
                im += wr[k] * col[2 * k + 1]
        else:
            for q in range(taps_t):
                a = a0 + q
                if a < 0 or a >= n_t:
                    continue
                sr = np.float32(0.0)
                si = np.float32(0.0)
                for k in range(taps_r):
                    if i0 + k >= 0 and i0 + k < n_r:
                        v = buf[off + a * n_r + i0 + k]
                        sr += wr[k] * v.real
                        si += wr[k] * v.imag
                re += wt[q] * sr
                im += wt[q] * si
        acc_re[j] += re * cos_[j] - im * sin_[j]
        acc_im[j] += re * sin_[j] + im * cos_[j]


@numba.njit(parallel=True, fastmath=True, error_model="numpy", cache=CACHE)
def final_points(
    buf: np.ndarray,
    fbuf: np.ndarray,
    geo: np.ndarray,
    ints: np.ndarray,
    px: np.ndarray,
    py: np.ndarray,
    pz: np.ndarray,
    kc2: float,
    tab_r: np.ndarray,
    tab_t: np.ndarray,
    out: np.ndarray,
    restore: bool,
) -> None:
    """out[i] = sum of the top subimages read at point i (plane coordinates px, py, normal offset pz), with the
    carrier of its exact range restored (exp(+j 2 pi kc2 r), as exact backprojection applies it) if ``restore``,
    else referred to the carrier of the range from subimage 0's centre (a band-limited, baseband image). fbuf: buf
    viewed as float32 (re, im pairs)."""
    n = len(px)
    chunk = 1024
    for b in numba.prange((n + chunk - 1) // chunk):
        wr1 = np.empty(tab_r.shape[1], np.float32)  # scratch of the one-pulse reads
        wt1 = np.empty(max(tab_t.shape[1], 1), np.float32)
        lo, hi = b * chunk, min(n, (b + 1) * chunk)
        m = hi - lo
        acc_re = np.zeros(m)
        acc_im = np.zeros(m)
        p_r = np.empty(m)
        p_t = np.empty(m)
        cos_ = np.empty(m, np.float32)
        sin_ = np.empty(m, np.float32)
        col = np.empty(2 * tab_r.shape[1], np.float32)
        for c in range(geo.shape[0]):
            n_t, n_r, off = ints[c, 0], ints[c, 1], ints[c, 2]
            if n_t == 1:  # a single pulse's image (a one-pulse aperture): the plain read
                for i in range(lo, hi):
                    r_ref = 0.0
                    if not restore:
                        dx, dy, dz = px[i] - geo[0, 0], py[i] - geo[0, 1], geo[0, 2] - pz[i]
                        r_ref = math.sqrt(dx * dx + dy * dy + dz * dz)
                    vr, vi = _read(buf, geo, ints, c, px[i], py[i], pz[i], r_ref, kc2, tab_r, tab_t, wr1, wt1)
                    acc_re[i - lo] += vr
                    acc_im[i - lo] += vi
                continue
            _chunk_positions(geo, c, px, py, pz, lo, kc2, restore, p_r, p_t, cos_, sin_)
            _add_polar_reads(buf, fbuf, off, n_t, n_r, p_r, p_t, cos_, sin_, tab_r, tab_t, col, acc_re, acc_im)
        for j in range(m):
            out[lo + j] = complex(acc_re[j], acc_im[j])


@numba.njit(parallel=True, fastmath=True, error_model="numpy", cache=CACHE)
def upsample_restore(
    low: np.ndarray,
    ia: np.ndarray,
    wa: np.ndarray,
    ib: np.ndarray,
    wb: np.ndarray,
    x0: float,
    y0: float,
    ax: float,
    ay: float,
    bx: float,
    by: float,
    fx: float,
    fy: float,
    h: float,
    kc2: float,
    scale: float,
    out: np.ndarray,
) -> None:
    """The coarse baseband image ``low`` (n_a, n_b) upsampled separably to the output grid and remodulated:
    out[i n1 + j] = scale exp(j 2 pi kc2 r) sum_m sum_l wa[i, m] wb[j, l] low[ia[i] + m, ib[j] + l] for the grid
    point (x0 + i ax + j bx, y0 + i ay + j by) of the plane, r its range from (fx, fy, h) (h off the plane).
    The coarse rows are read at the output columns first (n_a rows, fewer than the output's), then each output row
    combines them (contiguous, vectorised) and is remodulated in a separate vectorised loop."""
    n0, n1 = len(ia), len(ib)
    n_a = low.shape[0]
    ta, tb = wa.shape[1], wb.shape[1]
    lf = low.view(np.float32)  # (n_a, 2 n_b): re, im pairs
    t_re = np.empty((n_a, n1), np.float32)
    t_im = np.empty((n_a, n1), np.float32)
    for r in numba.prange(n_a):
        for j in range(n1):
            re = np.float32(0.0)
            im = np.float32(0.0)
            src = lf[r, 2 * ib[j] : 2 * ib[j] + 2 * tb]  # zero-based views: no index wrap
            w = wb[j]
            for q in range(tb):
                re += w[q] * src[2 * q]
                im += w[q] * src[2 * q + 1]
            t_re[r, j] = re
            t_im[r, j] = im
    for i in numba.prange(n0):
        row_re = np.zeros(n1, np.float32)
        row_im = np.zeros(n1, np.float32)
        for m in range(ta):
            w = wa[i, m]
            src_re = t_re[ia[i] + m]
            src_im = t_im[ia[i] + m]
            for j in range(n1):
                row_re[j] += w * src_re[j]
                row_im[j] += w * src_im[j]
        dx0 = x0 + i * ax - fx
        dy0 = y0 + i * ay - fy
        h2 = h * h
        dst = out[i * n1 : (i + 1) * n1]  # a view indexed from zero: no index wrap, vectorised
        for j in range(n1):
            dx = dx0 + j * bx
            dy = dy0 + j * by
            cyc = kc2 * math.sqrt(dx * dx + dy * dy + h2)
            co, si = cis_cycles32_short(np.float32(cyc - math.floor(cyc + 0.5)))
            vr, vi = scale * row_re[j], scale * row_im[j]
            dst[j] = complex(vr * co - vi * si, vr * si + vi * co)


@numba.njit(parallel=True, error_model="numpy", cache=CACHE)
def lattice_deviation(points: np.ndarray, p0: np.ndarray, a: np.ndarray, b: np.ndarray, n1: int) -> float:
    """The largest distance of points[i n1 + j] (n, 3), C-contiguous, from the lattice point p0 + i a + j b in any
    coordinate (inf where a point is not finite). Row by row through zero-based views (no index wrap)."""
    n0 = len(points) // n1
    flat = points.reshape(-1)
    dev = np.zeros(n0)
    for i in numba.prange(n0):
        seg = flat[3 * i * n1 : 3 * (i + 1) * n1]
        x0, y0, z0 = p0[0] + i * a[0], p0[1] + i * a[1], p0[2] + i * a[2]
        m = 0.0
        total = 0.0  # NaN if any point is
        for j in range(n1):
            ex = abs(seg[3 * j] - (x0 + j * b[0]))
            ey = abs(seg[3 * j + 1] - (y0 + j * b[1]))
            ez = abs(seg[3 * j + 2] - (z0 + j * b[2]))
            m = max(m, max(ex, max(ey, ez)))
            total += ex + ey + ez
        dev[i] = m if total == total and total < np.inf else np.inf
    return dev.max() if n0 else 0.0


lean_cache_loads(globals())  # cached kernels load without numba's context refresh (kernel_cache)
