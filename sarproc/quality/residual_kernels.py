"""Compiled kernel (numba) of the residual's keystoned response: every order's strip sum at each point.

Computes what :func:`sarproc.quality.residual._keystone_columns` (numpy, the reference) computes, to
rounding (tests/quality/test_residual_reach.py): per point the sines and cosines are taken once per sign and
each order costs a few multiplications (angle addition), without numpy's temporaries. Imported only when
the residual is asked for.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from sarproc.product.kernel_cache import CACHE, lean_cache_loads


@numba.njit(error_model="numpy", cache=CACHE)
def _product_at(x: np.ndarray, kappa: np.ndarray, n_strips: int) -> complex:  # pragma: no cover - compiled
    """The strip sum at shifted coordinates x (ndim,): :func:`sarproc.quality.residual._keystone_product`."""
    ndim = x.shape[0]
    width = 1.0 / n_strips
    u0 = 0.5 * width - 0.5
    last = x[ndim - 1]
    total = 0j
    for s in range(1 << (ndim - 1)):
        theta = 2.0 * math.pi * width * last
        phase = 2.0 * math.pi * u0 * last
        sign = 1.0
        for a in range(ndim - 1):
            sg = 1.0 - 2.0 * ((s >> a) & 1)
            sign *= sg
            xa = x[a] if abs(x[a]) >= 1e-7 else 1e-7
            theta += math.pi * width * sg * kappa[a] * xa
            phase += math.pi * sg * (1.0 + kappa[a] * u0) * xa
        half = 0.5 * theta
        sn = math.sin(half)
        if abs(sn) < 1e-9:
            dirichlet = n_strips * math.cos(n_strips * half) / math.cos(half)
        else:
            dirichlet = math.sin(n_strips * half) / sn
        angle = phase + (n_strips - 1) * half
        total += sign * dirichlet * complex(math.cos(angle), math.sin(angle))
    arg = width * last
    sinc = 1.0 if arg == 0.0 else math.sin(math.pi * arg) / (math.pi * arg)
    den = 1.0 + 0j
    for a in range(ndim - 1):
        xa = x[a] if abs(x[a]) >= 1e-7 else 1e-7
        den *= 2j * math.pi * xa
    return total * width * sinc / den


@numba.njit(error_model="numpy", cache=CACHE)
def _strip_constants(
    orders: np.ndarray, kappa: np.ndarray, n_strips: int, ndim: int
) -> tuple:  # pragma: no cover - compiled
    """What the strip sums of :func:`keystone_columns` and :func:`keystone_box_sum` hold constant: per sign
    combination of the keystone axes their signs, and per sign and order the cos / sin of the half-angle
    step, of S times it, and the phase shift (times the signs' product); per order cos / sin of the last
    axis's half step."""
    n_orders = orders.shape[0]
    n_signs = 1 << (ndim - 1)
    width = 1.0 / n_strips
    u0 = 0.5 * width - 0.5
    cos_dh = np.empty((n_signs, n_orders))
    sin_dh = np.empty((n_signs, n_orders))
    cos_sdh = np.empty((n_signs, n_orders))
    sin_sdh = np.empty((n_signs, n_orders))
    shift = np.empty((n_signs, n_orders), dtype=np.complex128)
    signs = np.empty((n_signs, ndim))
    for s in range(n_signs):
        prod = 1.0
        for a in range(ndim - 1):
            signs[s, a] = 1.0 - 2.0 * ((s >> a) & 1)
            prod *= signs[s, a]
        signs[s, ndim - 1] = prod
        for q in range(n_orders):
            n_l = orders[q, ndim - 1]
            d_half = 0.5 * math.pi * width * n_l
            d_phase = math.pi * u0 * n_l
            for a in range(ndim - 1):
                d_half += 0.25 * math.pi * width * signs[s, a] * kappa[a] * orders[q, a]
                d_phase += 0.5 * math.pi * signs[s, a] * (1.0 + kappa[a] * u0) * orders[q, a]
            d_phase += (n_strips - 1) * d_half
            cos_dh[s, q], sin_dh[s, q] = math.cos(d_half), math.sin(d_half)
            cos_sdh[s, q], sin_sdh[s, q] = math.cos(n_strips * d_half), math.sin(n_strips * d_half)
            shift[s, q] = prod * complex(math.cos(d_phase), math.sin(d_phase))
    cos_l = np.empty(n_orders)
    sin_l = np.empty(n_orders)
    for q in range(n_orders):
        cos_l[q] = math.cos(0.5 * math.pi * width * orders[q, ndim - 1])
        sin_l[q] = math.sin(0.5 * math.pi * width * orders[q, ndim - 1])
    return signs, cos_dh, sin_dh, cos_sdh, sin_sdh, shift, cos_l, sin_l


@numba.njit(error_model="numpy", inline="always", cache=CACHE)
def _strip_angles(x: np.ndarray, signs: np.ndarray, kappa: np.ndarray, n_strips: int) -> tuple:  # pragma: no cover
    """(half, phase) of one sign combination ``signs`` (ndim,) at the ridge coordinates x (ndim,): the
    Dirichlet kernel's half angle and the strip sum's phase (:func:`residual._keystone_columns`), summed in
    one fixed order so every kernel rounds them alike."""
    ndim = x.shape[0]
    width = 1.0 / n_strips
    u0 = 0.5 * width - 0.5
    half = math.pi * width * x[ndim - 1]
    phase = 2.0 * math.pi * u0 * x[ndim - 1]
    for a in range(ndim - 1):
        half += 0.5 * math.pi * width * signs[a] * kappa[a] * x[a]
        phase += math.pi * signs[a] * (1.0 + kappa[a] * u0) * x[a]
    return half, phase + (n_strips - 1) * half


@numba.njit(error_model="numpy", inline="always", cache=CACHE)
def _dirichlet_ratio(
    sh: float, ch: float, ssh: float, csh: float, cdh: float, sdh: float, csdh: float, ssdh: float, n_strips: int
) -> float:  # pragma: no cover - compiled
    """The Dirichlet kernel sin(S h') / sin(h') (S = ``n_strips``) at h' = h + dh, from the sine and cosine of h
    (``sh``, ``ch``), of S h (``ssh``, ``csh``), of dh (``sdh``, ``cdh``) and of S dh (``ssdh``, ``csdh``) by angle
    addition; where |sin h'| < 1e-9 its limit S cos(S h') / cos(h'), the operands chosen before the one division
    (no branch: the loops of :func:`keystone_columns` and :func:`_row_sums` that inline it stay vectorised)."""
    den = sh * cdh + ch * sdh
    num = ssh * csdh + csh * ssdh
    pole = abs(den) < 1e-9
    num2 = n_strips * (csh * csdh - ssh * ssdh)
    den2 = ch * cdh - sh * sdh
    return (num2 if pole else num) / (den2 if pole else den)


COLUMN_BLOCK = 64  # samples evaluated side by side in keystone_columns


@numba.njit(error_model="numpy", cache=CACHE)
def keystone_columns(
    c: np.ndarray, orders: np.ndarray, kappa: np.ndarray, n_strips: int
) -> np.ndarray:  # pragma: no cover - compiled
    """(K, N) complex: the strip sum of order ``orders[k]`` at each column of ``c`` ((ndim, N) ridge
    coordinates in nulls), a keystone ``kappa`` (ndim - 1) and ``n_strips`` strips.

    Blocks of :data:`COLUMN_BLOCK` samples side by side: per sample and sign the sines of the half angle, of
    S times it and the phase's rotation, then per order and sign the Dirichlet kernels of the block, the sums
    and the order's factor, the samples innermost so the compiler vectorises the divisions and products. The
    Dirichlet kernel's |den| < 1e-9 limit is chosen operand by operand in the same loop (:func:`_dirichlet_ratio`,
    inlined: one division, no second pass), and each complex product is written out in real arithmetic as the
    complex one rounds it (without its products with a real factor's zero imaginary part, which add only zeros).
    Each sample's arithmetic is the per-sample loop's, in the same order (the signs summed within an order, then
    the factor): the same bits (tests/quality/test_residual_kernel_bits.py)."""
    ndim, n = c.shape
    n_orders = orders.shape[0]
    n_signs = 1 << (ndim - 1)
    width = 1.0 / n_strips
    # per sign and order: the constant angle shifts of :func:`residual._keystone_columns`
    signs, cos_dh, sin_dh, cos_sdh, sin_sdh, shift, cos_l, sin_l = _strip_constants(orders, kappa, n_strips, ndim)
    two_pi_pow = (2.0 * math.pi) ** (ndim - 1)
    j_pow = (-1j) ** (ndim - 1)
    out = np.empty((n_orders, n), dtype=np.complex128)
    block = COLUMN_BLOCK
    sh = np.empty((n_signs, block))
    ch = np.empty((n_signs, block))
    ssh = np.empty((n_signs, block))
    csh = np.empty((n_signs, block))
    rot = np.empty((n_signs, block), dtype=np.complex128)
    s_l = np.empty(block)
    c_l = np.empty(block)
    near = np.empty(block, dtype=np.bool_)
    accr = np.empty(block)
    acci = np.empty(block)
    x = np.empty(ndim)
    for i0 in range(0, n, block):
        m = min(block, n - i0)
        for j in range(m):
            i = i0 + j
            near[j] = False
            for a in range(ndim - 1):
                for q in range(n_orders):
                    if abs(c[a, i] + 0.5 * orders[q, a]) < 1e-7:
                        near[j] = True
            for s in range(n_signs):
                half, phase = _strip_angles(c[:, i], signs[s], kappa, n_strips)
                sh[s, j], ch[s, j] = math.sin(half), math.cos(half)
                ssh[s, j], csh[s, j] = math.sin(n_strips * half), math.cos(n_strips * half)
                rot[s, j] = complex(math.cos(phase), math.sin(phase))
            last = c[ndim - 1, i]
            s_l[j], c_l[j] = math.sin(math.pi * width * last), math.cos(math.pi * width * last)
        for q in range(n_orders):
            for j in range(m):
                accr[j] = 0.0
                acci[j] = 0.0
            for s in range(n_signs):
                cdh, sdh, csdh, ssdh = cos_dh[s, q], sin_dh[s, q], cos_sdh[s, q], sin_sdh[s, q]
                sr, si = shift[s, q].real, shift[s, q].imag
                for j in range(m):
                    d = _dirichlet_ratio(sh[s, j], ch[s, j], ssh[s, j], csh[s, j], cdh, sdh, csdh, ssdh, n_strips)
                    rr, ri = rot[s, j].real, rot[s, j].imag
                    er = rr * sr - ri * si
                    ei = rr * si + ri * sr
                    accr[j] += d * er
                    acci[j] += d * ei
            half_l, cos_lq, sin_lq = 0.5 * orders[q, ndim - 1], cos_l[q], sin_l[q]
            for j in range(m):
                i = i0 + j
                x_l = c[ndim - 1, i] + half_l
                small = abs(x_l) < 1e-12
                # width sinc(width x_l) / prod_a (2 j pi x_a): one real division; 1 / (2 j pi)^(ndim - 1) is
                # (-j / (2 pi))^(ndim - 1)
                den = 1.0
                for a in range(ndim - 1):
                    den *= c[a, i] + 0.5 * orders[q, a]
                den *= two_pi_pow
                factor = width / den if small else (s_l[j] * cos_lq + c_l[j] * sin_lq) / (math.pi * x_l * den)
                out[q, i] = complex(accr[j] * factor, acci[j] * factor) * j_pow
        for j in range(m):
            if near[j]:  # within 1e-7 of a removable singularity: the direct product evaluates the limit
                for q in range(n_orders):
                    for a in range(ndim):
                        x[a] = c[a, i0 + j] + 0.5 * orders[q, a]
                    out[q, i0 + j] = _product_at(x, kappa, n_strips)
    return out


RESEED = 16  # samples along a box row between exact angles in keystone_box_sum


@numba.njit(error_model="numpy", cache=CACHE)
def _row_sums(
    out: np.ndarray,
    i: int,
    n: int,
    cs: np.ndarray,
    near: np.ndarray,
    eh: np.ndarray,
    esh: np.ndarray,
    ep: np.ndarray,
    el: np.ndarray,
    orders: np.ndarray,
    kappa: np.ndarray,
    n_strips: int,
    tables: tuple,
    two_pi_pow: float,
    j_pow: complex,
    scratch: tuple,
) -> None:  # pragma: no cover - compiled
    """Row ``i`` (its first ``n`` samples) of :func:`keystone_box_sum` and :func:`keystone_warped_box_sum`: the
    strip sums at the ridge coordinates ``cs`` ((ndim, n)) from the rotations carried to each sample (``eh``,
    ``esh``, ``ep``: exp(j half), exp(j S half), exp(j phase) per sign and sample; ``el``: the last axis' half
    angle) and the strips' constants ``tables`` (:func:`_box_tables`); ``near``: the samples within 1e-7 of a
    removable singularity, which the direct product (:func:`_product_at`) evaluates instead.

    Each sample's arithmetic is the per-sample loop's (orders outermost, the signs summed within an order, then
    the order's factor), in the same order, so the sums are the same bits; the samples of the row innermost, so
    the compiler runs the divisions and products several samples at once (the Dirichlet kernel's limit, where
    its denominator is within 1e-9 of zero, chosen operand by operand before its one division: the
    :func:`_dirichlet_ratio` of :func:`keystone_columns`, inlined; the complex products written out in real
    arithmetic as :func:`keystone_columns` writes them)."""
    cos_dh, sin_dh, cos_sdh, sin_sdh, shift, cos_l, sin_l, coef = tables
    total, acc_r, acc_i, x = scratch
    ndim = cs.shape[0]
    n_orders = orders.shape[0]
    n_signs = eh.shape[0]
    width = 1.0 / n_strips
    for j in range(n):
        total[j] = 0j
    for q in range(n_orders):
        for j in range(n):
            acc_r[j] = 0.0
            acc_i[j] = 0.0
        for s in range(n_signs):
            cdh, sdh, csdh, ssdh = cos_dh[s, q], sin_dh[s, q], cos_sdh[s, q], sin_sdh[s, q]
            sr, si = shift[s, q].real, shift[s, q].imag
            for j in range(n):
                e_h, e_sh = eh[s, j], esh[s, j]
                d = _dirichlet_ratio(e_h.imag, e_h.real, e_sh.imag, e_sh.real, cdh, sdh, csdh, ssdh, n_strips)
                pr, pi_ = ep[s, j].real, ep[s, j].imag
                acc_r[j] += d * (pr * sr - pi_ * si)
                acc_i[j] += d * (pr * si + pi_ * sr)
        half_l, cos_lq, sin_lq = 0.5 * orders[q, ndim - 1], cos_l[q], sin_l[q]
        for j in range(n):
            x_l = cs[ndim - 1, j] + half_l
            den_a = two_pi_pow
            for a in range(ndim - 1):
                den_a *= cs[a, j] + 0.5 * orders[q, a]
            on_axis = abs(x_l) < 1e-12
            factor = width / den_a if on_axis else (el[j].imag * cos_lq + el[j].real * sin_lq) / (math.pi * x_l * den_a)
            total[j] += complex(acc_r[j] * factor, acc_i[j] * factor)
    for j in range(n):
        if near[j]:  # within 1e-7 of a removable singularity: the direct product evaluates the limit
            value = 0j
            for q in range(n_orders):
                for a in range(ndim):
                    x[a] = cs[a, j] + 0.5 * orders[q, a]
                value += coef[q] * _product_at(x, kappa, n_strips)
            out[i, j] = value
        else:
            out[i, j] = total[j] * j_pow


@numba.njit(error_model="numpy", inline="always", cache=CACHE)
def _near_singular(c: np.ndarray, orders: np.ndarray) -> bool:  # pragma: no cover - compiled
    """Whether the ridge coordinates ``c`` lie within 1e-7 of a keystoned factor's removable singularity."""
    for a in range(c.shape[0] - 1):
        for q in range(orders.shape[0]):
            if abs(c[a] + 0.5 * orders[q, a]) < 1e-7:
                return True
    return False


@numba.njit(error_model="numpy", cache=CACHE)
def _row_buffers(ndim: int, n_signs: int, n_cols: int) -> tuple:  # pragma: no cover - compiled
    """A row's per-sample arrays for :func:`_row_sums`: (cs, near, eh, esh, ep, el) and its scratch."""
    rows = (
        np.empty((ndim, n_cols)),
        np.empty(n_cols, dtype=np.bool_),
        np.empty((n_signs, n_cols), dtype=np.complex128),
        np.empty((n_signs, n_cols), dtype=np.complex128),
        np.empty((n_signs, n_cols), dtype=np.complex128),
        np.empty(n_cols, dtype=np.complex128),
    )
    scratch = (
        np.empty(n_cols, dtype=np.complex128),
        np.empty(n_cols),
        np.empty(n_cols),
        np.empty(ndim),
    )
    return rows, scratch


@numba.njit(error_model="numpy", inline="always", cache=CACHE)
def _box_tables(
    orders: np.ndarray, coef: np.ndarray, kappa: np.ndarray, n_strips: int, ndim: int
) -> tuple:  # pragma: no cover - compiled
    """The box kernels' constants: the signs, :func:`_row_sums`' ``tables`` (the strip constants, shift
    times coef) and the factors (2 pi)^(ndim - 1) and (-j)^(ndim - 1)."""
    signs, cos_dh, sin_dh, cos_sdh, sin_sdh, shift, cos_l, sin_l = _strip_constants(orders, kappa, n_strips, ndim)
    for q in range(orders.shape[0]):
        for sg in range(shift.shape[0]):
            shift[sg, q] = coef[q] * shift[sg, q]
    tables = (cos_dh, sin_dh, cos_sdh, sin_sdh, shift, cos_l, sin_l, coef)
    return signs, tables, (2.0 * math.pi) ** (ndim - 1), (-1j) ** (ndim - 1)


@numba.njit(error_model="numpy", inline="always", cache=CACHE)
def _set_rotations(
    e_half: np.ndarray,
    e_shalf: np.ndarray,
    e_phase: np.ndarray,
    s: int,
    half: float,
    phase: float,
    n_strips: int,
    scale: float,
) -> None:  # pragma: no cover - compiled
    """Sign ``s``'s three rotations of the box kernels, exp(j scale half), exp(j scale S half), exp(j scale
    phase) (S = ``n_strips``), into ``e_half``, ``e_shalf``, ``e_phase``. A scale of 1 or 2 is exact, so the
    angles round as when written out."""
    e_half[s] = complex(math.cos(scale * half), math.sin(scale * half))
    e_shalf[s] = complex(math.cos(scale * n_strips * half), math.sin(scale * n_strips * half))
    e_phase[s] = complex(math.cos(scale * phase), math.sin(scale * phase))


@numba.njit(error_model="numpy", cache=CACHE)
def keystone_box_sum(
    c0: np.ndarray,
    d_row: np.ndarray,
    d_col: np.ndarray,
    n_rows: int,
    n_cols: int,
    orders: np.ndarray,
    coef: np.ndarray,
    kappa: np.ndarray,
    n_strips: int,
) -> np.ndarray:  # pragma: no cover - compiled
    """(n_rows, n_cols) complex: sum_k coef[k] times the strip sum of order ``orders[k]`` (what
    :func:`keystone_columns` gives) at the ridge coordinates c0 + i d_row + j d_col (2D boxes, c affine
    in the image indices). Along a row every angle grows by a constant, so its sines and cosines are
    complex rotations, taken afresh at each row's start: no trigonometry per sample."""
    ndim = c0.shape[0]
    n_signs = 1 << (ndim - 1)
    width = 1.0 / n_strips
    signs, tables, two_pi_pow, j_pow = _box_tables(orders, coef, kappa, n_strips, ndim)

    out = np.empty((n_rows, n_cols), dtype=np.complex128)
    e_half = np.empty(n_signs, dtype=np.complex128)  # exp(j half), exp(j S half), exp(j phase) per sign
    e_shalf = np.empty(n_signs, dtype=np.complex128)
    e_phase = np.empty(n_signs, dtype=np.complex128)
    r_half = np.empty(n_signs, dtype=np.complex128)  # their steps along a row
    r_shalf = np.empty(n_signs, dtype=np.complex128)
    r_phase = np.empty(n_signs, dtype=np.complex128)
    zero = np.zeros(ndim)
    for s in range(n_signs):
        dh, dp = _strip_angles(d_col, signs[s], kappa, n_strips)
        # the angles' constant parts (zero: they are linear in c)
        dh0, dp0 = _strip_angles(zero, signs[s], kappa, n_strips)
        dh -= dh0
        dp -= dp0
        _set_rotations(r_half, r_shalf, r_phase, s, dh, dp, n_strips, 1.0)
    step_l = math.pi * width * d_col[ndim - 1]
    r_l = complex(math.cos(step_l), math.sin(step_l))
    c = np.empty(ndim)
    pix = np.empty(ndim)  # the sample's ridge coordinates
    (cs, near, eh, esh, ep, el), scratch = _row_buffers(ndim, n_signs, n_cols)
    e_l = 1.0 + 0j
    for i in range(n_rows):
        for a in range(ndim):
            c[a] = c0[a] + i * d_row[a]
        for j in range(n_cols):
            for a in range(ndim):
                pix[a] = c[a] + j * d_col[a]
                cs[a, j] = pix[a]
            if j % RESEED == 0:  # the rotations' rounding kept to ~1e-14: exact angles every RESEED samples
                for s in range(n_signs):
                    half, phase = _strip_angles(pix, signs[s], kappa, n_strips)
                    _set_rotations(e_half, e_shalf, e_phase, s, half, phase, n_strips, 1.0)
                arg = math.pi * width * pix[ndim - 1]
                e_l = complex(math.cos(arg), math.sin(arg))
            near[j] = _near_singular(pix, orders)
            for s in range(n_signs):
                eh[s, j], esh[s, j], ep[s, j] = e_half[s], e_shalf[s], e_phase[s]
            el[j] = e_l
            for s in range(n_signs):
                e_half[s] *= r_half[s]
                e_shalf[s] *= r_shalf[s]
                e_phase[s] *= r_phase[s]
            e_l *= r_l
        _row_sums(
            out, i, n_cols, cs, near, eh, esh, ep, el, orders, kappa, n_strips, tables, two_pi_pow, j_pow, scratch
        )
    return out


@numba.njit(error_model="numpy", cache=CACHE)
def keystone_warped_box_sum(
    c0: np.ndarray,
    d_row: np.ndarray,
    d_col: np.ndarray,
    w_rr: np.ndarray,
    w_rc: np.ndarray,
    w_cc: np.ndarray,
    n_rows: int,
    n_cols: int,
    orders: np.ndarray,
    coef: np.ndarray,
    kappa: np.ndarray,
    n_strips: int,
    carrier: np.ndarray,
) -> np.ndarray:  # pragma: no cover - compiled
    """:func:`keystone_box_sum` where the ridge coordinates are quadratic in the image indices (a warped model,
    :attr:`sarproc.quality.residual.ResponseModel.warp`): c0 + i d_row + j d_col + i^2 w_rr + i j w_rc + j^2
    w_cc. Along a row every angle is then quadratic in j, so its sines and cosines are complex rotations whose
    step turns by a constant: no trigonometry per sample, exact angles every :data:`RESEED` samples. The sum is
    multiplied by the model's carrier exp(j phi), phi = ``carrier`` . (1, i, j, i^2, i j, j^2) (the band centre's
    and the spatial chirp's phase, quadratic in the box's indices too), turned along each row the same way."""
    ndim = c0.shape[0]
    n_signs = 1 << (ndim - 1)
    width = 1.0 / n_strips
    signs, tables, two_pi_pow, j_pow = _box_tables(orders, coef, kappa, n_strips, ndim)

    out = np.empty((n_rows, n_cols), dtype=np.complex128)
    e_half = np.empty(n_signs, dtype=np.complex128)  # exp(j half), exp(j S half), exp(j phase) per sign
    e_shalf = np.empty(n_signs, dtype=np.complex128)
    e_phase = np.empty(n_signs, dtype=np.complex128)
    r_half = np.empty(n_signs, dtype=np.complex128)  # their steps to the next sample of the row
    r_shalf = np.empty(n_signs, dtype=np.complex128)
    r_phase = np.empty(n_signs, dtype=np.complex128)
    t_half = np.empty(n_signs, dtype=np.complex128)  # the steps' own turn from one sample to the next
    t_shalf = np.empty(n_signs, dtype=np.complex128)
    t_phase = np.empty(n_signs, dtype=np.complex128)
    for s in range(n_signs):  # the angles are linear in c without a constant part: twice w_cc's angles
        th, tp = _strip_angles(w_cc, signs[s], kappa, n_strips)
        _set_rotations(t_half, t_shalf, t_phase, s, th, tp, n_strips, 2.0)
    turn_l = 2.0 * math.pi * width * w_cc[ndim - 1]
    t_l = complex(math.cos(turn_l), math.sin(turn_l))
    t_car = complex(math.cos(2.0 * carrier[5]), math.sin(2.0 * carrier[5]))
    e_car = 1.0 + 0j
    r_car = 1.0 + 0j
    car = np.empty(n_cols, dtype=np.complex128)
    row = np.empty(ndim)  # the row's constant and linear coefficients in j
    lin = np.empty(ndim)
    c = np.empty(ndim)
    step = np.empty(ndim)
    (cs, near, eh, esh, ep, el), scratch = _row_buffers(ndim, n_signs, n_cols)
    e_l = 1.0 + 0j
    r_l = 1.0 + 0j
    for i in range(n_rows):
        for a in range(ndim):
            row[a] = c0[a] + i * d_row[a] + i * i * w_rr[a]
            lin[a] = d_col[a] + i * w_rc[a]
        car_row = carrier[0] + i * carrier[1] + i * i * carrier[3]
        car_lin = carrier[2] + i * carrier[4]
        for j in range(n_cols):
            for a in range(ndim):
                c[a] = row[a] + j * lin[a] + j * j * w_cc[a]
                cs[a, j] = c[a]
            if j % RESEED == 0:  # the rotations' rounding kept to ~1e-14: exact angles every RESEED samples
                for a in range(ndim):
                    step[a] = lin[a] + (2 * j + 1) * w_cc[a]  # c(j + 1) - c(j)
                for s in range(n_signs):
                    half, phase = _strip_angles(c, signs[s], kappa, n_strips)
                    _set_rotations(e_half, e_shalf, e_phase, s, half, phase, n_strips, 1.0)
                    dh, dp = _strip_angles(step, signs[s], kappa, n_strips)
                    _set_rotations(r_half, r_shalf, r_phase, s, dh, dp, n_strips, 1.0)
                arg = math.pi * width * c[ndim - 1]
                e_l = complex(math.cos(arg), math.sin(arg))
                arg = math.pi * width * step[ndim - 1]
                r_l = complex(math.cos(arg), math.sin(arg))
                arg = car_row + j * car_lin + j * j * carrier[5]
                e_car = complex(math.cos(arg), math.sin(arg))
                arg = car_lin + (2 * j + 1) * carrier[5]
                r_car = complex(math.cos(arg), math.sin(arg))
            near[j] = _near_singular(c, orders)
            for s in range(n_signs):
                eh[s, j], esh[s, j], ep[s, j] = e_half[s], e_shalf[s], e_phase[s]
            el[j] = e_l
            car[j] = e_car
            for s in range(n_signs):
                e_half[s] *= r_half[s]
                e_shalf[s] *= r_shalf[s]
                e_phase[s] *= r_phase[s]
                r_half[s] *= t_half[s]
                r_shalf[s] *= t_shalf[s]
                r_phase[s] *= t_phase[s]
            e_l *= r_l
            r_l *= t_l
            e_car *= r_car
            r_car *= t_car
        _row_sums(
            out, i, n_cols, cs, near, eh, esh, ep, el, orders, kappa, n_strips, tables, two_pi_pow, j_pow, scratch
        )
        for j in range(n_cols):
            out[i, j] *= car[j]
    return out


# Near a removable singularity the closed forms' derivatives cancel: below these the series or the
# interpolation of :func:`keystone_derivatives` take over (their error there ~1e-9 relative).
SERIES_E = 1e-3  # |h - m pi| below which the Dirichlet kernel and its derivative are its Taylor series
NEAR_X = 1e-3  # |x_a| (a keystoned axis) below which the derivatives are interpolated from +-NODE, +-2 NODE
NODE = 3e-3
# |sin h| at or above this puts h at least SERIES_E from every pole m pi (|sin e| <= |e|; the angle-added sines are
# within 1e-15 of sin h): the closed form, without :func:`_dirichlet`'s test
SERIES_SH = 1.001e-3


@numba.njit(error_model="numpy", cache=CACHE)
def _dirichlet(h: float, sh: float, ch: float, ssh: float, csh: float, n_strips: int) -> tuple:  # pragma: no cover
    """(D, dD/dh) of D(h) = sin(S h) / sin(h), given sin / cos of h and of S h; near h = m pi their Taylor
    series in e = h - m pi (D there is (-1)^(m (S - 1)) sin(S e) / sin(e))."""
    m = round(h / math.pi)
    e = h - m * math.pi
    if abs(e) < SERIES_E:
        s2 = float(n_strips) * n_strips
        r = 1.0 - 2.0 * ((int(m) * (n_strips - 1)) & 1)
        a2 = (s2 - 1.0) / 6.0
        a4 = (s2 - 1.0) * (3.0 * s2 - 7.0) / 360.0
        return r * n_strips * (1.0 - a2 * e * e + a4 * e**4), r * n_strips * (-2.0 * a2 * e + 4.0 * a4 * e**3)
    return ssh / sh, (n_strips * csh * sh - ssh * ch) / (sh * sh)


@numba.njit(error_model="numpy", cache=CACHE)
def _last_factor(x_l: float, s_x: float, c_x: float, width: float) -> tuple:  # pragma: no cover - compiled
    """(G, dG/dx) of G(x) = width sinc(width x) = sin(pi width x) / (pi x), given sin / cos of pi width x."""
    z = math.pi * width * x_l
    if abs(z) < SERIES_E:
        return width * (1.0 - z * z / 6.0 + z**4 / 120.0), -width * z * math.pi * width / 3.0 * (1.0 - z * z / 10.0)
    g = s_x / (math.pi * x_l)
    return g, (width * c_x - g) / x_l


@numba.njit(error_model="numpy", cache=CACHE)
def _derivatives_at(
    x: np.ndarray, kappa: np.ndarray, n_strips: int, d_x: np.ndarray, d_k: np.ndarray
) -> None:  # pragma: no cover - compiled
    """The strip sum's derivatives at shifted coordinates x (ndim,) (no |x_a| near 0, a < ndim - 1) with
    respect to x (into d_x) and kappa (into d_k), by direct trigonometry: :func:`keystone_derivatives`."""
    ndim = x.shape[0]
    n_k = ndim - 1
    width = 1.0 / n_strips
    u0 = 0.5 * width - 0.5
    last = x[n_k]
    t = 0j
    t_l = 0j
    t_a = np.zeros(n_k, dtype=np.complex128)
    t_k = np.zeros(n_k, dtype=np.complex128)
    for s in range(1 << n_k):
        half = math.pi * width * last
        phase = 2.0 * math.pi * u0 * last
        sign = 1.0
        for a in range(n_k):
            sg = 1.0 - 2.0 * ((s >> a) & 1)
            sign *= sg
            half += 0.5 * math.pi * width * sg * kappa[a] * x[a]
            phase += math.pi * sg * (1.0 + kappa[a] * u0) * x[a]
        phase += (n_strips - 1) * half
        d, dd = _dirichlet(
            half, math.sin(half), math.cos(half), math.sin(n_strips * half), math.cos(n_strips * half), n_strips
        )
        e = sign * complex(math.cos(phase), math.sin(phase))
        t += e * d
        t_l += e * (dd * math.pi * width + 1j * d * (2.0 * math.pi * u0 + (n_strips - 1) * math.pi * width))
        for a in range(n_k):
            sg = 1.0 - 2.0 * ((s >> a) & 1)
            h_a = 0.5 * math.pi * width * sg  # d half / d (kappa_a x_a)
            t_a[a] += e * (
                dd * h_a * kappa[a] + 1j * d * (math.pi * sg * (1.0 + kappa[a] * u0) + (n_strips - 1) * h_a * kappa[a])
            )
            t_k[a] += e * x[a] * (dd * h_a + 1j * d * (math.pi * sg * u0 + (n_strips - 1) * h_a))
    arg = math.pi * width * last
    g, dg = _last_factor(last, math.sin(arg), math.cos(arg), width)
    h = (-1j) ** n_k / (2.0 * math.pi) ** n_k
    for a in range(n_k):
        h /= x[a]
    for a in range(n_k):
        d_x[a] = (t_a[a] - t / x[a]) * g * h
        d_k[a] = t_k[a] * g * h
    d_x[n_k] = (t_l * g + t * dg) * h


DERIVATIVE_BLOCK = 64  # samples evaluated side by side in keystone_derivatives


@numba.njit(error_model="numpy", cache=CACHE)
def keystone_derivatives(
    c: np.ndarray, orders: np.ndarray, coef: np.ndarray, kappa: np.ndarray, n_strips: int
) -> np.ndarray:  # pragma: no cover - compiled
    """(2 ndim - 1, N) complex: the derivatives of sum_k coef[k] times the strip sum of order ``orders[k]``
    (what :func:`keystone_columns` gives) at each column of ``c`` ((ndim, N) ridge coordinates in nulls):
    with respect to each coordinate c_a (rows 0..ndim-1), then each keystone kappa_a (rows ndim..).

    Analytic, in the same pass as the strip sums (angle addition per order, as :func:`keystone_columns`);
    where a factor's closed form cancels, Taylor series (the Dirichlet kernel near its poles, the last axis'
    sinc near 0), or, within :data:`NEAR_X` of a keystoned axis' zero, interpolation from four points
    either side (the strip sum is analytic there).

    Blocks of :data:`DERIVATIVE_BLOCK` samples side by side (as :func:`keystone_columns`): per sample and sign
    the sines and the phase's rotation, then per order and sign loops over the block's samples without branches
    (the Dirichlet kernel's closed form for every sample, then the few within :data:`SERIES_SH` of a pole again
    through :func:`_dirichlet`, then the sums), then the order's terms (:func:`_last_factor`'s two branches as
    selects; a complex over a real divisor as the two real divisions numba's complex division makes of it),
    which the compiler vectorises: each complex product is written out in real arithmetic as the complex one
    rounds it (its products with the zero imaginary part of a real factor left out: they add only zeros), and
    each sample's sums take the orders in order, so the result is the per-order complex loop's bit for bit
    (tests/quality/test_evaluate_fast_paths.py, tests/quality/test_residual_aot.py). Over the orders (9-25 in
    evaluate's fits) instead of the samples, the same loops took 1.3-1.6 times as long."""
    ndim, n = c.shape
    n_k = ndim - 1
    n_orders = orders.shape[0]
    n_signs = 1 << n_k
    width = 1.0 / n_strips
    u0 = 0.5 * width - 0.5
    signs, cos_dh, sin_dh, cos_sdh, sin_sdh, shift, cos_l, sin_l = _strip_constants(orders, kappa, n_strips, ndim)
    d_half = np.empty((n_signs, n_orders))  # the orders' half-angle shifts (for the series' distance to a pole)
    for s in range(n_signs):
        for q in range(n_orders):
            d_half[s, q] = 0.5 * math.pi * width * orders[q, n_k]
            for a in range(n_k):
                d_half[s, q] += 0.25 * math.pi * width * signs[s, a] * kappa[a] * orders[q, a]
    shift_r = np.empty((n_signs, n_orders))
    shift_i = np.empty((n_signs, n_orders))
    for s in range(n_signs):
        for q in range(n_orders):
            shift_r[s, q] = shift[s, q].real
            shift_i[s, q] = shift[s, q].imag
    # the per-(sign, axis) constants of the derivative terms, as the complex expressions round them
    # t_l: e (dd pi width + j d (2 pi u0 + (S - 1) pi width))
    l_q = 2.0 * math.pi * u0 + (n_strips - 1) * math.pi * width
    a_p = np.empty((n_signs, max(n_k, 1)))  # h_a (times kappa_a: after dd h_a)
    a_q = np.empty((n_signs, max(n_k, 1)))
    k_q = np.empty((n_signs, max(n_k, 1)))
    for s in range(n_signs):
        for a in range(n_k):
            sg = signs[s, a]
            h_a = 0.5 * math.pi * width * sg
            a_p[s, a] = h_a
            a_q[s, a] = math.pi * sg * (1.0 + kappa[a] * u0) + (n_strips - 1) * h_a * kappa[a]
            k_q[s, a] = math.pi * sg * u0 + (n_strips - 1) * h_a
    h_const = (-1j) ** n_k / (2.0 * math.pi) ** n_k
    out = np.zeros((2 * ndim - 1, n), dtype=np.complex128)
    block = DERIVATIVE_BLOCK
    n_a = max(n_k, 1)
    halves = np.empty((n_signs, block))  # per sign and sample: the half angle, its sines, the phase's rotation
    sh = np.empty((n_signs, block))
    ch = np.empty((n_signs, block))
    ssh = np.empty((n_signs, block))
    csh = np.empty((n_signs, block))
    rr = np.empty((n_signs, block))
    ri = np.empty((n_signs, block))
    s_l = np.empty(block)
    c_l = np.empty(block)
    tr = np.empty(block)  # one order's sums over the signs, per sample
    ti = np.empty(block)
    tlr = np.empty(block)
    tli = np.empty(block)
    tar = np.empty((n_a, block))
    tai = np.empty((n_a, block))
    tkr = np.empty((n_a, block))
    tki = np.empty((n_a, block))
    dv = np.empty(block)
    ddv = np.empty(block)
    sq = np.empty(block)
    cq = np.empty(block)
    ssq = np.empty(block)
    csq = np.empty(block)
    xk = np.empty((n_a, block))
    near = np.empty(block, dtype=np.bool_)
    gq = np.empty(block)
    dgq = np.empty(block)
    hr = np.empty(block)
    hi = np.empty(block)
    ghr = np.empty(block)
    ghi = np.empty(block)
    x = np.empty(ndim)
    node = np.empty(ndim)
    d_x = np.empty(ndim, dtype=np.complex128)
    d_k = np.empty(n_a, dtype=np.complex128)
    weights = (-1.0 / 6.0, 2.0 / 3.0, 2.0 / 3.0, -1.0 / 6.0)  # Lagrange, nodes -2, -1, 1, 2 (times NODE), at 0
    for i0 in range(0, n, block):
        m = min(block, n - i0)
        for j in range(m):
            i = i0 + j
            for s in range(n_signs):
                half, phase = _strip_angles(c[:, i], signs[s], kappa, n_strips)
                halves[s, j] = half
                sh[s, j], ch[s, j] = math.sin(half), math.cos(half)
                ssh[s, j], csh[s, j] = math.sin(n_strips * half), math.cos(n_strips * half)
                rr[s, j], ri[s, j] = math.cos(phase), math.sin(phase)
            last = c[n_k, i]
            s_l[j], c_l[j] = math.sin(math.pi * width * last), math.cos(math.pi * width * last)
        for q in range(n_orders):
            for j in range(m):
                near[j] = False
                tr[j] = 0.0
                ti[j] = 0.0
                tlr[j] = 0.0
                tli[j] = 0.0
            for a in range(n_k):
                for j in range(m):
                    xk[a, j] = c[a, i0 + j] + 0.5 * orders[q, a]
                    if abs(xk[a, j]) < NEAR_X:
                        near[j] = True
                    tar[a, j] = 0.0
                    tai[a, j] = 0.0
                    tkr[a, j] = 0.0
                    tki[a, j] = 0.0
            for s in range(n_signs):
                cdh, sdh, csdh, ssdh = cos_dh[s, q], sin_dh[s, q], cos_sdh[s, q], sin_sdh[s, q]
                for j in range(m):
                    sq[j] = sh[s, j] * cdh + ch[s, j] * sdh
                    cq[j] = ch[s, j] * cdh - sh[s, j] * sdh
                    ssq[j] = ssh[s, j] * csdh + csh[s, j] * ssdh
                    csq[j] = csh[s, j] * csdh - ssh[s, j] * ssdh
                    dv[j] = ssq[j] / sq[j]
                    ddv[j] = (n_strips * csq[j] * sq[j] - ssq[j] * cq[j]) / (sq[j] * sq[j])
                for j in range(m):
                    if abs(sq[j]) < SERIES_SH and not near[j]:  # maybe within SERIES_E of a pole: as _dirichlet decides
                        dv[j], ddv[j] = _dirichlet(halves[s, j] + d_half[s, q], sq[j], cq[j], ssq[j], csq[j], n_strips)
                s_r, s_i = shift_r[s, q], shift_i[s, q]
                for j in range(m):
                    d = dv[j]
                    dd = ddv[j]
                    er = rr[s, j] * s_r - ri[s, j] * s_i
                    ei = rr[s, j] * s_i + ri[s, j] * s_r
                    tr[j] += er * d
                    ti[j] += ei * d
                    p = dd * math.pi * width
                    qq = d * l_q
                    tlr[j] += er * p - ei * qq
                    tli[j] += er * qq + ei * p
                for a in range(n_k):
                    ap, aq, kq, ka = a_p[s, a], a_q[s, a], k_q[s, a], kappa[a]
                    for j in range(m):
                        d = dv[j]
                        dd = ddv[j]
                        er = rr[s, j] * s_r - ri[s, j] * s_i
                        ei = rr[s, j] * s_i + ri[s, j] * s_r
                        p = dd * ap * ka
                        qq = d * aq
                        tar[a, j] += er * p - ei * qq
                        tai[a, j] += er * qq + ei * p
                        xr = er * xk[a, j]
                        xi = ei * xk[a, j]
                        p = dd * ap
                        qq = d * kq
                        tkr[a, j] += xr * p - xi * qq
                        tki[a, j] += xr * qq + xi * p
            # the order's terms, each complex expression's rounding written out in real arithmetic (over a real
            # divisor, numba's complex division is the two real divisions), added to each sample's sums in the
            # orders' order; _last_factor's two branches as selects
            cr, ci = coef[q].real, coef[q].imag
            for j in range(m):
                x_l = c[n_k, i0 + j] + 0.5 * orders[q, n_k]
                sx = s_l[j] * cos_l[q] + c_l[j] * sin_l[q]
                cx = c_l[j] * cos_l[q] - s_l[j] * sin_l[q]
                z = math.pi * width * x_l
                series = abs(z) < SERIES_E
                g_s = width * (1.0 - z * z / 6.0 + z**4 / 120.0)
                dg_s = -width * z * math.pi * width / 3.0 * (1.0 - z * z / 10.0)
                g_c = sx / (math.pi * x_l)
                dg_c = (width * cx - g_c) / x_l
                gq[j] = g_s if series else g_c
                dgq[j] = dg_s if series else dg_c
                hr[j] = h_const.real
                hi[j] = h_const.imag
            for a in range(n_k):
                for j in range(m):
                    hr[j] /= xk[a, j]
                    hi[j] /= xk[a, j]
            for j in range(m):
                g, dg = gq[j], dgq[j]
                cgr, cgi = cr * g, ci * g  # gh = coef g h
                ghr[j] = cgr * hr[j] - cgi * hi[j]
                ghi[j] = cgr * hi[j] + cgi * hr[j]
                vr = tlr[j] * g + tr[j] * dg  # coef (t_l g + t dg) h
                vi = tli[j] * g + ti[j] * dg
                wr = cr * vr - ci * vi
                wi = cr * vi + ci * vr
                keep = not near[j]
                re = out[n_k, i0 + j].real + (wr * hr[j] - wi * hi[j])
                im = out[n_k, i0 + j].imag + (wr * hi[j] + wi * hr[j])
                if keep:
                    out[n_k, i0 + j] = complex(re, im)
            for a in range(n_k):
                for j in range(m):
                    i = i0 + j
                    ur = tar[a, j] - tr[j] / xk[a, j]
                    ui = tai[a, j] - ti[j] / xk[a, j]
                    xr = out[a, i].real + (ur * ghr[j] - ui * ghi[j])
                    xi = out[a, i].imag + (ur * ghi[j] + ui * ghr[j])
                    kr = out[ndim + a, i].real + (tkr[a, j] * ghr[j] - tki[a, j] * ghi[j])
                    ki = out[ndim + a, i].imag + (tkr[a, j] * ghi[j] + tki[a, j] * ghr[j])
                    if not near[j]:
                        out[a, i] = complex(xr, xi)
                        out[ndim + a, i] = complex(kr, ki)
            for j in range(m):  # within NEAR_X of a keystoned axis' zero: interpolated
                if near[j]:
                    i = i0 + j
                    for a in range(ndim):
                        x[a] = c[a, i] + 0.5 * orders[q, a]
                    for w_i in range(4):
                        step = (w_i - 2 if w_i < 2 else w_i - 1) * NODE
                        for a in range(ndim):
                            node[a] = x[a] + step if a < n_k and abs(x[a]) < NEAR_X else x[a]
                        _derivatives_at(node, kappa, n_strips, d_x, d_k)
                        for a in range(ndim):
                            out[a, i] += weights[w_i] * coef[q] * d_x[a]
                        for a in range(n_k):
                            out[ndim + a, i] += weights[w_i] * coef[q] * d_k[a]
    return out


@numba.njit(error_model="numpy", cache=CACHE)
def spread_bins(
    c_re: np.ndarray,
    c_im: np.ndarray,
    u: np.ndarray,
    first: np.ndarray,
    grid_size: int,
    taps: int,
    beta: float,
    block: int,
) -> np.ndarray:  # pragma: no cover - compiled
    """(2, grid_size): the real and imaginary grids of :func:`sarproc.quality.linesum._spread`'s numpy
    reference (terms at grid positions ``u``, their first taps ``first = ceil(u - taps / 2)``), computed as it
    computes them: each weight exp(beta (sqrt(1 - z^2) - 1)) times (z^2 < 1) from the same operations in the
    same order (libm's exp, which numpy calls on machines without AVX-512), summed into each bin term after
    term in ``block``-sized blocks as its ``bincount`` does, each block's grid added to the total. The same
    grids bit for bit (tests/quality/test_residual_aot.py), without the (terms, taps + 1) temporaries."""
    half = taps / 2.0
    out = np.zeros((2, grid_size))
    part = np.empty((2, grid_size))
    for start in range(0, c_re.size, block):
        part[:] = 0.0
        for k in range(start, min(c_re.size, start + block)):
            f = first[k]
            lead = int(f)
            for t in range(taps + 1):
                z = (f + t - u[k]) / half
                z2 = min(z * z, 1.0)
                w = math.exp(beta * (math.sqrt(1.0 - z2) - 1.0)) * (1.0 if z2 < 1.0 else 0.0)
                g = (lead + t) % grid_size
                part[0, g] += c_re[k] * w
                part[1, g] += c_im[k] * w
        for g in range(grid_size):
            out[0, g] += part[0, g]
            out[1, g] += part[1, g]
    return out


lean_cache_loads(globals())  # cached kernels load without numba's context refresh (kernel_cache)
