"""Compiled kernels of fast factorised backprojection (:mod:`sarproc.focus.ffbp`).

A subimage is a polar image around the in-plane foot (fx, fy) of its subaperture's centre, which is h above the
image plane: sample (a, k) is the point at range r = r0 + k dr from the centre and in-plane angle
theta = th_mid + th_lo + a dth, demodulated by the carrier of that range (exp(-j 2 pi kc2 r)), so that it is
band-limited in both coordinates. Geometry rows (float64): fx, fy, h, r0, dr, th_mid, th_lo, dth, cos th_mid,
sin th_mid, 1 / dr, 1 / dth; integer rows:
n_theta, n_range, offset into the level's flat complex64 buffer. A subimage with n_theta = 1 (a single pulse)
does not depend on the angle.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from sarproc.dsp.kernel_cache import CACHE, lean_cache_loads
from sarproc.dsp.phasor import cis_cycles32_short

LINEAR, CUBIC = 1, 3


@numba.njit(fastmath=True, error_model="numpy", cache=CACHE)
def _weights(t, mode):
    """Interpolation weights of samples -1, 0, 1, 2 at fraction t in [0, 1): linear or cubic Lagrange."""
    one, two, six = type(t)(1.0), type(t)(2.0), type(t)(6.0)
    if mode == LINEAR:
        return t * 0, one - t, t, t * 0
    tm, t1, t2 = t + one, t - one, t - two
    return (-t * t1 * t2 / six, tm * t1 * t2 / two, -tm * t * t2 / two, tm * t * t1 / six)


@numba.njit(fastmath=True, error_model="numpy", cache=CACHE)
def _row_value(buf, base, n, i, w0, w1, w2, w3):
    """Samples i - 1 .. i + 2 of a row of n at buf[base:] weighted (zero outside the row; no checks inside it)."""
    if i >= 1 and i + 2 < n:
        v = w0 * buf[base + i - 1] + w1 * buf[base + i] + w2 * buf[base + i + 1] + w3 * buf[base + i + 2]
        return v.real, v.imag
    re = 0.0
    im = 0.0
    for m in range(4):
        j = i - 1 + m
        if j >= 0 and j < n:
            wm = w0 if m == 0 else (w1 if m == 1 else (w2 if m == 2 else w3))
            v = buf[base + j]
            re += wm * v.real
            im += wm * v.imag
    return re, im


@numba.njit(fastmath=True, error_model="numpy", cache=CACHE)
def _relative_angle(dx, dy, cm, sm):
    """Angle of (dx, dy) from the direction (cm, sm), in (-pi, pi]: a series for |tan| <= 1/4 (error < 1e-10 rad;
    polar grids span a few degrees), atan2 beyond."""
    dot = dx * cm + dy * sm
    crs = dy * cm - dx * sm
    if dot > 0.0 and abs(crs) <= 0.25 * dot:
        z = crs / dot
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
                    * (
                        -1.0 / 7
                        + z2 * (1.0 / 9 + z2 * (-1.0 / 11 + z2 * (1.0 / 13 + z2 * (-1.0 / 15 + z2 * (1.0 / 17)))))
                    )
                )
            )
        )
    return math.atan2(crs, dot)


@numba.njit(fastmath=True, error_model="numpy", cache=CACHE)
def _read(buf, geo, ints, c, x, y, z, r_ref, kc2, mode_r, mode_t):
    """Subimage c read at the plane point (x, y, z), re-modulated by the carrier of its range from c's centre and
    demodulated by that of ``r_ref``: its contribution exp(j 2 pi kc2 (r_c - r_ref)) x value."""
    dx = x - geo[c, 0]
    dy = y - geo[c, 1]
    dz = geo[c, 2] - z
    rc = math.sqrt(dx * dx + dy * dy + dz * dz)
    pos = (rc - geo[c, 3]) * geo[c, 10]
    n_t, n_r, off = ints[c, 0], ints[c, 1], ints[c, 2]
    p0 = math.floor(pos)
    i = np.int64(p0)
    w0, w1, w2, w3 = _weights(np.float32(pos - p0), mode_r)
    if n_t == 1:
        re, im = _row_value(buf, off, n_r, i, w0, w1, w2, w3)
    else:
        th = _relative_angle(dx, dy, geo[c, 8], geo[c, 9])
        ta = (th - geo[c, 6]) * geo[c, 11]
        a0 = math.floor(ta)
        wa = _weights(ta - a0, mode_t)
        a = np.int64(a0)
        re = 0.0
        im = 0.0
        for m in range(4):
            j = a - 1 + m
            if wa[m] != 0.0 and j >= 0 and j < n_t:
                vr, vi = _row_value(buf, off + j * n_r, n_r, i, w0, w1, w2, w3)
                re += wa[m] * vr
                im += wa[m] * vi
    cyc = kc2 * (rc - r_ref)
    cyc -= math.floor(cyc + 0.5)
    co, si = cis_cycles32_short(np.float32(cyc))
    return re * co - im * si, re * si + im * co


@numba.njit(parallel=True, fastmath=True, error_model="numpy", cache=CACHE)
def merge_level(cbuf, cgeo, cints, first_child, pgeo, pints, pbuf, row_parent, row_angle, kc2, mode_r, mode_t) -> None:
    """Each parent polar sample: the sum of its children read at its plane point (one job per parent row)."""
    for job in numba.prange(len(row_parent)):
        s = row_parent[job]
        a = row_angle[job]
        th = pgeo[s, 5] + pgeo[s, 6] + a * pgeo[s, 7]
        ct, st = math.cos(th), math.sin(th)
        n_r, off = pints[s, 1], pints[s, 2] + a * pints[s, 1]
        h2 = pgeo[s, 2] * pgeo[s, 2]
        for k in range(n_r):
            r = pgeo[s, 3] + k * pgeo[s, 4]
            rho = math.sqrt(max(r * r - h2, 0.0))
            x = pgeo[s, 0] + rho * ct
            y = pgeo[s, 1] + rho * st
            re = 0.0
            im = 0.0
            for c in range(first_child[s], first_child[s + 1]):
                vr, vi = _read(cbuf, cgeo, cints, c, x, y, 0.0, r, kc2, mode_r, mode_t)
                re += vr
                im += vi
            pbuf[off + k] = complex(re, im)


@numba.njit(parallel=True, fastmath=True, error_model="numpy", cache=CACHE)
def final_points(buf, geo, ints, px, py, pz, kc2, mode_r, mode_t, out) -> None:
    """out[i] = sum of the top subimages read at point i (plane coordinates px, py, normal offset pz), with the
    carrier of its exact range restored (exp(+j 2 pi kc2 r), as exact backprojection applies it)."""
    for i in numba.prange(len(px)):
        re = 0.0
        im = 0.0
        for c in range(geo.shape[0]):
            vr, vi = _read(buf, geo, ints, c, px[i], py[i], pz[i], 0.0, kc2, mode_r, mode_t)
            re += vr
            im += vi
        out[i] = complex(re, im)


lean_cache_loads(globals())  # cached kernels load without numba's context refresh (kernel_cache)
