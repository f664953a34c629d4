"""evaluate's fast numerics (normal-equation least squares, pruned orientation density) give the same
report as the reference path (EvaluateParams(exact=True): SVD least squares, full density)."""

from __future__ import annotations

import dataclasses
import itertools
import math

import numpy as np
from test_metrics import axis_coords, separable_image, sinc_psf

from sarproc.quality.metrics import (
    EvaluateParams,
    ResponseShapes,
    _ideal_response,
    evaluate_image,
    least_squares,
    principal_directions,
)


def _floats(d, prefix=""):
    if isinstance(d, dict):
        for k, v in d.items():
            yield from _floats(v, f"{prefix}/{k}")
    elif isinstance(d, (list, tuple)):
        for i, v in enumerate(d):
            yield from _floats(v, f"{prefix}[{i}]")
    else:
        yield prefix, d


def _assert_same(fast, exact):
    a, b = dict(_floats(fast.to_dict())), dict(_floats(exact.to_dict()))
    assert a.keys() == b.keys()
    for k in a:
        if k == "/params/exact":
            continue
        if isinstance(a[k], float) and isinstance(b[k], float):
            assert math.isclose(a[k], b[k], rel_tol=1e-9, abs_tol=1e-9), (k, a[k], b[k])
        else:
            assert a[k] == b[k], (k, a[k], b[k])


def test_3d_support_and_least_squares_same_as_reference():
    res, steps = (0.02, 1.0, 0.8), (0.012, 0.6, 0.5)
    bw = tuple(0.886 / r for r in res)
    coords = [axis_coords(40, steps[0]), axis_coords(40, steps[1]), axis_coords(40, steps[2])]
    doppler = (0.3 / steps[0], 0.45 / steps[1], -0.2 / steps[2])
    chip = separable_image(coords, [sinc_psf(b, f) for b, f in zip(bw, doppler)], [(0.0013, 0.21, -0.37)])
    nulls = [r / (0.886 * s) for r, s in zip(res, steps)]
    centers = [f * s for f, s in zip(doppler, steps)]
    V_fast, fc_fast = principal_directions(chip, centers, nulls)
    V_exact, fc_exact = principal_directions(chip, centers, nulls, exact=True)
    np.testing.assert_allclose(V_fast, V_exact, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(fc_fast, fc_exact)
    # a tall system like the neighbour fit's: shifted responses and their derivatives
    x = np.linspace(-20, 20, 4000)
    B = np.stack(
        [np.sinc(x - s) * np.exp(2j * np.pi * 0.3 * x) for s in np.linspace(-3, 3, 13)]
        + [x * np.sinc(x - s) for s in (-1.0, 0.0, 1.0)],
        axis=1,
    )
    y = B @ (np.arange(16) + 1j) + 1e-3 * np.cos(7 * x)
    np.testing.assert_allclose(least_squares(B, y), least_squares(B, y, exact=True), rtol=1e-9)


def test_crowded_skewed_2d_same_report():
    coords = [axis_coords(96, 0.4), axis_coords(96, 0.35)]
    a, r = np.meshgrid(coords[0], coords[1], indexing="ij")
    img = np.zeros(a.shape, dtype=complex)
    # 10.5 and 9.4 samples apart: each truth finds its own peak (the weaker one is outside the stronger one's
    # +-3 cell search window), and each chip holds the other's main lobe
    targets = [(0.3, -0.2), (4.5, 3.1)]
    for (ta, tr), amp in zip(targets, (1.0, 0.7j)):
        da, dr = a - ta, r - tr  # a skewed support: the range ridge leans on azimuth
        img += amp * np.sinc(0.886 * da) * np.sinc(0.886 / 0.8 * (dr + 0.15 * da)) * np.exp(2j * np.pi * 0.4 * da)
    fast = evaluate_image(img, ("azimuth", "range"), coords, (1.0, 0.8), targets)
    exact = evaluate_image(img, ("azimuth", "range"), coords, (1.0, 0.8), targets, params=EvaluateParams(exact=True))
    assert any(t.neighbours_removed for t in fast.targets)
    _assert_same(fast, exact)


def test_two_truths_on_one_peak_are_one_response():
    """A weaker truth whose search window holds a stronger target's peak finds that peak: the two are one
    response, not neighbours, so neither is subtracted from the other (that removed half the target)."""
    coords = [axis_coords(96, 0.4), axis_coords(96, 0.35)]
    a, r = np.meshgrid(coords[0], coords[1], indexing="ij")
    img = np.sinc(0.886 * (a - 0.3)) * np.sinc(0.886 / 0.8 * (r + 0.2)) + 0.2 * np.sinc(0.886 * (a - 2.1)) * np.sinc(
        0.886 / 0.8 * (r - 1.2)
    )
    rep = evaluate_image(img, ("azimuth", "range"), coords, (1.0, 0.8), [(0.3, -0.2), (2.1, 1.2)])
    assert rep.targets[0].peak_index == rep.targets[1].peak_index
    assert not any(t.neighbours_removed for t in rep.targets)
    assert abs(rep.targets[0].peak_amplitude - 1.0) < 0.01


def test_crowded_skewed_3d_same_report_as_reference_numerics():
    """The compiled paths (line values by non-uniform FFT, orientation density, ideal responses) against the
    numpy reference (exact=True: direct sums) on a crowded 3D cube with skewed supports and band offsets,
    where neighbours are fitted, subtracted and cut along oblique ridges (ideal neighbour models only: the
    response-model refit is the residual code's, tested there)."""
    steps, res = (0.5, 0.4, 0.3), (0.58, 0.46, 0.35)  # about 1.3 samples per null
    coords = [axis_coords(30, steps[0]), axis_coords(34, steps[1]), axis_coords(26, steps[2])]
    e, a, r = np.meshgrid(*coords, indexing="ij")
    img = np.zeros(e.shape, dtype=complex)
    targets = [(0.2, -0.3, 0.1), (0.2, 2.9, 0.1), (-3.8, -0.3, 0.4)]
    for (te, ta, tr), amp in zip(targets, (1.0, 0.6j, 0.8)):
        de, da, dr = e - te, a - ta, r - tr  # the range ridge leans on azimuth, the elevation one on range
        img += (
            amp
            * np.sinc(0.886 / res[0] * (de + 0.1 * dr))
            * np.sinc(0.886 / res[1] * da)
            * np.sinc(0.886 / res[2] * (dr + 0.12 * da))
            * np.exp(2j * np.pi * (0.3 / steps[1] * da - 0.2 / steps[0] * de))
        )
    dims = ("elevation", "azimuth", "range")
    params = EvaluateParams(neighbour_orders=0)
    fast = evaluate_image(img, dims, coords, res, targets, params=params)
    exact = evaluate_image(img, dims, coords, res, targets, params=dataclasses.replace(params, exact=True))
    assert sum(bool(t.neighbours_removed) for t in fast.targets) >= 2
    assert any(m.angle_deg > 1.0 for t in fast.targets for m in t.axes)  # oblique cuts taken
    _assert_same(fast, exact)


def test_compiled_box_responses_equal_pointwise():
    """The neighbour responses from per-axis tables (a chip box, the strided sample boxes of a group fit) equal
    the pointwise compiled response, unweighted and Hamming, including points on a ridge coordinate's zero."""
    from sarproc.quality import kernels

    rng = np.random.default_rng(3)
    V = np.eye(3) + 0.05 * rng.standard_normal((3, 3))
    ridge = np.linalg.inv(V.T) / np.array([2.5, 1.7, 1.2])[:, None]
    position, f_c = np.array([7.0, 5.3, 4.0]), np.array([0.11, -0.27, 0.43])  # integer coordinates: c = 0 there
    chirp = np.array([0.008, -0.011, 0.003])  # cycles/sample^2 (array3d's azimuth chirp is 0.008)
    origins, shapes = np.array([[0.0, 1.0, 2.0], [3.0, 1.0, 0.0]]), np.array([[7, 6, 5], [5, 8, 6]])
    step = np.array([2.0, 1.0, 1.0])
    boxes = [
        np.stack(
            [g.ravel() for g in np.meshgrid(*[o + s * np.arange(n) for o, s, n in zip(org, step, shp)], indexing="ij")]
        )
        for org, shp in zip(origins, shapes)
    ]
    points, inverse = np.unique(np.concatenate(boxes, axis=1), axis=1, return_inverse=True)
    # a tabulated shape along the third ridge over +-1.5 nulls (the sinc beyond), 8 points per null
    q = np.arange(-12, 13) / 8.0
    tabled = np.stack([np.zeros(25), np.zeros(25), np.sinc(q) * (1 - 0.1 * q**2)])
    plain = (np.zeros(3), np.zeros((3, 25)), np.zeros(3))
    known = (np.array([6.0, 0.0, 0.0]), tabled, np.array([0.0, 0.0, 8.0]))
    for hamming, (period, table, rate) in itertools.product((False, True), (plain, known)):
        ref = kernels.ideal_response(points, position, ridge, f_c, chirp, period, table, rate, hamming)
        numpy_ref = _ideal_response(
            points,
            position,
            V,
            [2.5, 1.7, 1.2],
            f_c,
            hamming,
            exact=True,
            chirp=chirp,
            shapes=ResponseShapes(period, table, rate),
        )
        np.testing.assert_allclose(ref, numpy_ref, rtol=0, atol=1e-13)
        got = kernels.ideal_response_boxes(
            origins,
            step,
            shapes,
            inverse.ravel().astype(np.int64),
            points.shape[1],
            position,
            ridge,
            f_c,
            chirp,
            period,
            table,
            rate,
            hamming,
        )
        np.testing.assert_allclose(got, ref, rtol=0, atol=1e-14)
        box = kernels.ideal_response_box(
            origins[1], step, shapes[1], position, ridge, f_c, chirp, period, table, rate, hamming
        ).ravel()
        np.testing.assert_allclose(
            box,
            kernels.ideal_response(boxes[1], position, ridge, f_c, chirp, period, table, rate, hamming),
            rtol=0,
            atol=1e-14,
        )


def test_blocked_orientation_density_equals_every_pair():
    """The compiled 3D orientation density skips a block of candidates with one dot product where a unit vector is
    out of every member's reach: bit for bit the sum over every pair in the same order (each candidate's terms in
    the order of the vectors), on the evaluation's grid and on candidates spread over the whole sphere, with
    vectors placed just inside and outside the pruning's reach of candidates."""
    import math

    from sarproc.quality import kernels
    from sarproc.quality.kernels_aot import DENSITY_PRUNE
    from sarproc.quality.metrics import _candidate_blocks, _orientation_grid

    rng = np.random.default_rng(7)
    sigma = math.radians(3.0)
    floor = 1.0 - DENSITY_PRUNE * sigma * sigma  # the kernel's expressions, so the same rounding
    scale = 1.0 / (2.0 * sigma * sigma)
    rho = math.acos(math.sqrt(floor))
    grid = _orientation_grid(3)[0]
    spread = rng.standard_normal((300, 3))
    spread /= np.linalg.norm(spread, axis=1)[:, None]
    for cand in (grid[::7], spread):
        cand = np.ascontiguousarray(cand)
        u = rng.standard_normal((150, 3))
        # vectors at rho -+ 1e-4 rad from some candidates: the pruning's edge, where a block must not skip
        for i, c in enumerate(cand[:40]):
            side = np.cross(c, [0.3, 0.5, 0.8])
            side /= np.linalg.norm(side)
            angle = rho + (1e-4 if i % 2 else -1e-4)
            u = np.vstack([u, math.cos(angle) * c + math.sin(angle) * side])
        u /= np.linalg.norm(u, axis=1)[:, None]
        w = rng.random(len(u))
        blocks = _candidate_blocks(cand.tobytes(), sigma)
        assert np.count_nonzero(blocks[3] > -1) > len(blocks[3]) // 2  # most blocks do skip
        got = kernels.orientation_density(cand, u, w, sigma, *blocks)
        want = np.zeros(len(cand))
        for i, c in enumerate(cand):
            s = 0.0
            for j in range(len(u)):
                d = 0.0
                for a in range(3):
                    d += float(c[a]) * float(u[j, a])
                if d * d > floor:
                    s += math.exp((d * d - 1.0) * scale) * float(w[j])
            want[i] = s
        assert np.array_equal(got, want)


def test_compiled_cone_sums_equal_numpys_selection():
    """The edge normals' cluster means in 3D (kernels.cone_sum, one pass) sum the same signed gradients in the same
    order as the numpy selection they replace, bit for bit, on gradients like a support's edges': most within a few
    degrees of three normals, on both sides of each (signs aligned), and a random rest."""
    from sarproc.quality import kernels

    rng = np.random.default_rng(11)
    normals = np.linalg.qr(rng.standard_normal((3, 3)))[0]
    u = np.concatenate([n + 0.05 * rng.standard_normal((3000, 3)) for n in normals] + [rng.standard_normal((500, 3))])
    u[::2] *= -1  # both sides of each edge
    u /= np.linalg.norm(u, axis=1)[:, None]
    g = u * rng.random(len(u))[:, None]
    cos_cone = math.cos(math.radians(8.0))
    for f in list(normals) + [u[7]]:
        for _ in range(4):
            c = u @ f
            sel = np.abs(c) > cos_cone
            want = (np.sign(c[sel])[:, None] * g[sel]).sum(axis=0)
            got = kernels.cone_sum(u, g, np.ascontiguousarray(f), cos_cone)
            assert got[3] == np.count_nonzero(sel) > 100
            assert np.array_equal(got[:3], want)
            f = want / np.linalg.norm(want)


def test_padded_neighbours_are_every_pair_within_reach():
    """The orientation grid's neighbour rows (formed against only the candidates whose last coordinate can be
    within reach) hold exactly the candidates within two kernel widths of each, +- alike, as every pair's product
    finds them, ascending, padded with the candidate's own index."""
    from sarproc.quality.metrics import _orientation_grid, _padded_neighbours

    for ndim in (2, 3):
        cand, sigma = _orientation_grid(ndim)
        near = np.abs(cand @ cand.T) > math.cos(2 * sigma)
        rows = _padded_neighbours(ndim)
        assert rows.shape == (len(cand), near.sum(axis=1).max())
        for i, row in enumerate(rows):
            count = int(near[i].sum())
            assert np.array_equal(row[:count], np.flatnonzero(near[i])) and np.all(row[count:] == i)


def _oblique_chip():
    """A Hamming-weighted response whose range ridge leans 25 deg in space (the squinted stripmap of
    tests/quality/test_oblique_tapered_ridges.py, smaller): the chip _ridges_in_space turns lines on."""
    from test_oblique_tapered_ridges import _oblique_tapered_image

    from sarproc.quality.metrics import _Chip

    img, coords = _oblique_tapered_image()
    peak = np.unravel_index(np.argmax(np.abs(img)), img.shape)
    return img, coords, _Chip(img, peak, (34, 20)), np.array(peak, dtype=float) + (0.13, -0.21)


def test_lines_through_a_point_equal_the_nufft_and_the_direct_sums():
    """_Chip.lines_through (one point, any direction: per-axis tables and a matrix product) against
    values_on_line (the non-uniform FFT the cuts take) and values_along (every term summed): centred lines of
    odd and even counts and an off-centre one, to 1e-13 of the peak."""
    _, _, chip, pos = _oblique_chip()
    through = chip.lines_through(pos)
    peak = abs(chip.values([[p] for p in pos]).item())
    for v, first, step, count in [
        ((0.42, 1.0), -80 * 0.2, 0.2, 161),
        ((1.0, -0.37), -30 * 0.35, 0.35, 60),
        ((1.0, 0.05), -7.3, 0.11, 97),
    ]:
        got = through(v, first, step, count)
        nufft = chip.values_on_line(pos, v, first, step, count)
        direct = chip.values_along(pos, v, first + step * np.arange(count))
        assert np.abs(got - direct).max() < 1e-13 * peak
        assert np.abs(got - nufft).max() < 1e-13 * peak


def test_ridges_in_space_same_with_the_nufft_lines(monkeypatch):
    """The oblique ridge search on lines_through's lines reports what it reported on values_on_line's (the
    search's comparisons do not see the lines' last bits): the same report."""
    import sarproc.quality.metrics as metrics

    img, coords, _, _ = _oblique_chip()
    args = (img, ("azimuth", "range"), coords, (0.39 * 1.3 * 0.9, 0.906 * 1.3 * 0.9), [(0.0, 0.0)])
    kw = dict(params=EvaluateParams(irw_factor=1.30, residual=False), metric=np.eye(2))
    fast = evaluate_image(*args, **kw)
    monkeypatch.setattr(
        metrics._Chip,
        "lines_through",
        lambda self, start: lambda v, first, step, count: self.values_on_line(start, v, first, step, count),
    )
    reference = evaluate_image(*args, **kw)
    assert dict(_floats(fast.to_dict())) == dict(_floats(reference.to_dict()))
    assert any(abs(m.angle_deg) > 20 for m in fast.targets[0].axes)  # the ridge was turned in space


def _close_targets_cube() -> tuple:
    """An oversampled 3D cube (3-4 samples per null on two axes, as paper 004's elevation and azimuth) of three
    targets two to three nulls apart, off the sample grid, with skewed ridges and band offsets."""
    steps, res = (0.25, 0.3, 0.3), (1.0, 1.0, 0.4)
    coords = [axis_coords(40, steps[0]), axis_coords(44, steps[1]), axis_coords(32, steps[2])]
    e, a, r = np.meshgrid(*coords, indexing="ij")
    img = np.zeros(e.shape, dtype=complex)
    targets = [(0.13, -0.21, 0.07), (0.13, 2.07, 0.07), (-2.61, -0.21, 0.95)]
    for (te, ta, tr), amp in zip(targets, (1.0, 0.7j, 0.5)):
        de, da, dr = e - te, a - ta, r - tr
        img += (
            amp
            * np.sinc(0.886 / res[0] * (de + 0.05 * dr))
            * np.sinc(0.886 / res[1] * da)
            * np.sinc(0.886 / res[2] * (dr + 0.1 * da))
            * np.exp(2j * np.pi * (0.2 / steps[1] * da - 0.3 / steps[0] * de + 0.1 / steps[2] * dr))
        )
    return img, coords, res, targets


def test_3d_peak_refinement_by_local_moments_equals_the_zooms():
    """A cube chip's peak refinement takes its zooms after the first from the spectrum's local moments: the same
    grid points as every zoom by the chip's values (the position to the bit), the peak value to rounding, on
    each of three close targets' chips (the neighbours' side lobes in each) and from starts off the peak."""
    from sarproc.quality.metrics import _Chip

    img, coords, _, targets = _close_targets_cube()
    steps = [c[1] - c[0] for c in coords]
    for t in targets:
        index = [int(round((x - c[0]) / s)) for x, c, s in zip(t, coords, steps)]
        chip = _Chip(img, index, (16, 14, 12))
        for offset in ((0, 0, 0), (1, -1, 0), (-1, 0, 1)):
            start = np.add(index, offset)
            pos, value = chip.refine_peak(start)
            ref_pos, ref_value = chip.refine_peak(start, exact=True)
            np.testing.assert_array_equal(pos, ref_pos)
            assert abs(value - ref_value) <= 1e-13 * abs(ref_value)


def test_rolled_magnitude_equals_numpys_roll():
    """The support spectrum's magnitude written where the roll puts it equals np.roll of np.abs, bit for bit."""
    from sarproc.quality.metrics import rolled_abs

    rng = np.random.default_rng(3)
    for shape in ((131, 105, 41), (9, 1, 4), (64, 33)):
        x = rng.standard_normal(shape) + 1j * rng.standard_normal(shape)
        for shift in itertools.islice(itertools.product(*[(0, 5, -7, 300)] * len(shape)), 12):
            expected = np.roll(np.abs(x), shift, axis=tuple(range(len(shape))))
            np.testing.assert_array_equal(rolled_abs(x, shift), expected)
