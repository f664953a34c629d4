"""Resource plans of the focusers (preprocess, coarse-focus, fine-focus, backproject, pfa2, reconstruct,
array3d): output size, peak memory and run time from the input's header and the parameters, before any
data is read (sarproc.product.budget has the Plan and the process around it)."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from sarproc.product.budget import NUMBA_PROCESS, PROCESS, Plan, complex_bytes, header_shape, stored_bytes
from sarproc.product.errors import InputError
from sarproc.product.frames import image_axis
from sarproc.product.metadata import SINC_IRW_FACTOR
from sarproc.product.sorted_values import median, unique_integers

if TYPE_CHECKING:
    from typing import Any

    from sarproc.focus.backprojection import BackprojectionPlan
    from sarproc.product.model import Product


def preprocess_estimate(stage: str, header: Product, params: Any) -> Plan:
    from sarproc.focus.squint_deramp.preprocess import check_fixed_gate

    check_fixed_gate(header)  # --dry-run refuses what the run would
    n_az, n_rg = header_shape(header)
    b = complex_bytes(n_az, n_rg)
    block = complex_bytes(min(params.block_pulses, n_az), n_rg, itemsize=16) * 4
    return Plan(stage, stored_bytes(n_az, n_rg), 2 * b + block, n_az * n_rg * 40e-9, f"{n_az} x {n_rg} samples")


def coarse_focus_estimate(stage: str, header: Product, params: Any) -> Plan:
    n_az, n_rg = header_shape(header)
    n_out = params.azimuth_samples or 2 * n_az  # the default M is the PRF-limited length, at most about 2x
    out = complex_bytes(n_out, n_rg)
    block = complex_bytes(n_out, min(params.block_range, n_rg), itemsize=16) * 3
    return Plan(
        stage,
        stored_bytes(n_out, n_rg),
        complex_bytes(n_az, n_rg) + out + block,
        n_out * n_rg * 60e-9,
        f"{n_az} pulses -> ~{n_out} azimuth samples x {n_rg}",
    )


def fine_focus_estimate(stage: str, header: Product, params: Any) -> Plan:
    M, n_r = header_shape(header)
    r = header.radar
    N = n_r + int(math.ceil(r.pulse_duration * r.range_sampling_rate))
    if params.max_samples < M * N:
        raise InputError(
            f"fine_focus.max_samples: the working array {M} x {N} exceeds {params.max_samples}; "
            "raise it or shrink the scene"
        )
    work = complex_bytes(M, N, itemsize=8 if params.precision == "float32" else 16)
    flow = params.flow or _fine_focus_flow(header)
    # spectra, Stolt output and azimuth blocks: about three working arrays at the peak (measured 3.1 on
    # exp. 2 full); flow 2's NLCS tables and zero-padded azimuth blocks add a constant ~100 MB and ~1 s
    # (small scenes: 80-170 MB, 1-2 s) and ~0.07 us per working sample (exp. 2 full: 2.2 s of work on an
    # idle machine, CPU/wall 1.8; docs/performance.md)
    if flow == 2:
        memory, seconds = 3 * work + 100e6, 1.0 + M * N * 0.07e-6
    else:
        # flow 1: 0.12-0.37 us per sample of CPU (exp. 2; exp. 1 with and without Doppler correction)
        memory, seconds = 3 * work, M * N * params.stolt_length * 15e-9
    return Plan(
        stage, stored_bytes(M, N), complex_bytes(M, n_r) + memory, seconds, f"working array {M} x {N}, flow {flow}"
    )


def _fine_focus_flow(header: Product) -> int:
    """fine-focus's automatic flow (eq. 17): 1 when the scene fits its depth of focus."""
    from sarproc.focus.squint_deramp.fine_focus import scene_and_focus_depth

    try:
        half_adof, scene_half = scene_and_focus_depth(
            header.radar, [float(b) for b in header.attrs["scene_box"]], int(header.attrs["n_pulses"])
        )
    except (KeyError, ValueError, TypeError, ZeroDivisionError):
        return 1  # fine-focus itself reports a bad coarse product
    return 1 if scene_half <= half_adof else 2


def image_pixels(header: Product, params: Any) -> tuple[int, int]:
    """(azimuth, range) pixels of the image a focuser's extents/spacings give (backproject, pfa2 share
    the keys and the rule, sarproc.product.frames.image_axis): about the image's theoretical IRW."""
    r = header.radar
    n_az = header_shape(header)[-2]
    t_ap = max(n_az / r.prf, 1e-9)
    irw_rg = r.range_resolution
    irw_az = (
        SINC_IRW_FACTOR
        * r.wavelength
        * r.reference_range
        / (2 * r.velocity * t_ap * max(math.cos(r.squint) ** 2, 1e-6))
    )
    n = []
    for ax, irw in (("azimuth", irw_az), ("range", irw_rg)):
        t = header.targets[ax] if len(header.targets) and ax in (header.targets.dtype.names or ()) else [0.0]
        _, _, pixels = image_axis(
            np.asarray(t, float),
            irw,
            params.oversample,
            params.margin_cells,
            getattr(params, f"{ax}_spacing"),
            0.0,  # the centre does not change the count
            getattr(params, f"{ax}_extent"),
        )
        n.append(pixels)
    return n[0], n[1]


def elevation_pixels(header: Product, params: Any) -> int:
    """Elevation planes of backproject's grid: 1 in a 2D frame; in the elevation frame (a raw_array's
    cross-track receivers) as the elevation keys and the array factor's IRW give them."""
    name = params.frame if params.frame != "product" else (header.attrs.get("frame") or {}).get("name", "squint")
    if name != "elevation":
        return 1
    v = np.sort(np.asarray(header.aux.get("rx_offset", np.zeros((1, 3))), float).reshape(-1, 3)[:, 1])
    span = float(np.ptp(v)) + (median(np.diff(v)) if len(v) > 1 else 0.0)
    # backproject itself refuses a product without a cross-track array; 0.01 rad: any width for the count
    irw = SINC_IRW_FACTOR * header.radar.wavelength / span if span > 0 else 0.01
    t = header.targets["elevation"] if len(header.targets) else [0.0]
    _, _, pixels = image_axis(
        np.asarray(t, float),
        irw,
        params.oversample,
        params.margin_cells,
        params.elevation_spacing,
        0.0,
        params.elevation_extent,
    )
    return pixels


# per pixel of an output block: its grid coordinates and float64 position, the kernel's tile order and offsets,
# two complex128 sums and the complex64 block (tracemalloc peak of backproject_rows: 127-136 B on 1024-2048 wide
# demo grids; 64 B, the old figure, let an 8192^2 run with --max-memory 384M peak at 466 MiB)
BACKPROJECT_BYTES_PER_PIXEL = 140.0


def _backproject_fixed_bytes(n_ch: int, n_az: int, n_rg: int, params: Any) -> float:
    raw = 4 * complex_bytes(n_ch, n_az, n_rg)
    up = complex_bytes(min(64, n_az), n_rg * params.range_upsample, itemsize=16)
    return raw + 2 * up


def grid_pixels(header: Product, params: Any, grid: BackprojectionPlan | None) -> tuple[int, int, int]:
    """(elevation, azimuth, range) pixels of backproject's grid: the run's plan's when given (its default grid
    covers what the header alone does not give: moving targets where they appear, a --targets subset), else
    what the extents and spacings give about the targets table (:func:`image_pixels`)."""
    if grid is not None:
        shape = tuple(int(v) for v in grid.shape)
        return (shape[0], shape[1], shape[2]) if len(shape) == 3 else (1, shape[0], shape[1])
    return (elevation_pixels(header, params), *image_pixels(header, params))


def backproject_block_pixels(
    header: Product, params: Any, memory_limit: int | None, grid: BackprojectionPlan | None = None
) -> int:
    """Pixels per output block: ``params.block_pixels``, fewer (whole rows, at least one) when the blocks
    would not fit ``memory_limit`` (bytes) beside the pulses and the process itself; ``grid``: the run's plan
    (:func:`grid_pixels`)."""
    block = int(params.block_pixels)
    if memory_limit is None:
        return block
    n_az, n_rg = header_shape(header)[-2:]
    n_ch = header_shape(header)[0] if len(header_shape(header)) == 3 else 1
    process = PROCESS["backproject"][0] + NUMBA_PROCESS[0]  # numba's share counted: the blocks fit either run
    room = memory_limit - process - _backproject_fixed_bytes(n_ch, n_az, n_rg, params)
    n_el_px, n_az_px, n_rg_px = grid_pixels(header, params, grid)
    row = n_rg_px * (n_az_px if n_el_px > 1 else 1)  # a 3D grid's rows: elevation planes
    return max(row, min(block, int(room / BACKPROJECT_BYTES_PER_PIXEL) // row * row))


# The compiled engine's cost of one tile and pulse beyond its pixels' (wall s on two cores): 0.11-0.14 us of one core
# (0.17-0.3 before its views were made once a tile; scripts/tile_cost.py, docs/performance.md "Coarse pixels"),
# about 50 pixel-pulses' worth, so it counts where the carrier-cycle cap leaves tiles of tens of pixels (X band,
# metre pixels: 003's traffic grid, 26 a tile). On linear reads such tiles run in blocks of ~2000 pixels
# (focus.backprojection.tile_block): each block costs TILE_PULSE_SECONDS a pulse, and each further tile in it
# SUBTILE_PULSE_SECONDS: nothing is done per tile any more, but a block's pixels cost ~0.5 ns (one core) a pulse
# more than a large tile's (their lattice terms), ~40 pixels a tile (docs/performance.md "a lattice per block").
TILE_PULSE_SECONDS = 0.1e-6
SUBTILE_PULSE_SECONDS = 0.01e-6
# The compiled engine per pixel and pulse (wall s on two cores, tables, upsampling and writing included): idle
# session 25 runs (docs/performance.md) took 1.3 ns on a 2048^2 grid (stage 3.33 s) and 1.5 ns on the
# xu_small-like grid (1.62 s); 4 ns was fitted on loaded runs and planned those at 2-3x.
COMPILED_PIXEL_PULSE_SECONDS = 1.8e-9
# The plan's own theory of every target (and of the scene centre) before the pixels are summed
# (plan_backprojection): ~50 ms each (1.35 s for the 25 targets of scripts/bench.py's scene), 23 ms since the
# responses are summed at x >= 0 (the demo's 5 and its centre: 0.28 -> 0.14 s, best of 3 in process)
THEORY_SECONDS_PER_TARGET = 0.025


def _compiled_tile_seconds(header: Product, params: Any, grid: BackprojectionPlan | None) -> float:
    """Seconds a pulse the compiled engine's tiles and blocks cost on a 2D grid beyond its pixels (0 for the other
    engines, 3D grids and when no grid is planned)."""
    if params.engine != "compiled" or grid is None or grid.elevation is not None:
        return 0.0
    from sarproc.focus.backprojection import grid_block_count, grid_tile_count

    spacings = tuple(float(abs(a[1] - a[0])) if len(a) > 1 else 0.0 for a in (grid.azimuth, grid.range))
    fc = header.radar.carrier_frequency
    tiles = grid_tile_count(grid.shape, spacings, fc)
    # blocks on linear reads (monostatic; a bistatic run's tiles cost more than planned)
    blocks = min(tiles, grid_block_count(grid.shape, spacings, fc)) if params.interpolation == "linear" else tiles
    return blocks * TILE_PULSE_SECONDS + (tiles - blocks) * SUBTILE_PULSE_SECONDS


def backproject_estimate(
    stage: str,
    header: Product,
    params: Any,
    memory_limit: int | None = None,
    grid: BackprojectionPlan | None = None,
) -> Plan:
    """``memory_limit``: --max-memory (bytes), which sets the output blocks (:func:`backproject_block_pixels`);
    ``grid``: the run's plan (:func:`sarproc.focus.backprojection.plan_backprojection`), where ffbp's error is
    predicted (made here from the header when not given)."""
    from sarproc.focus.backprojection import check_params

    check_params(params)  # an odd ffbp_taps is an input error, not taps_of's ValueError below
    n_az, n_rg = header_shape(header)[-2:]
    n_ch = header_shape(header)[0] if len(header_shape(header)) == 3 else 1
    n_el, n_az_px, n_rg_px = grid_pixels(header, params, grid)
    n = (n_el, n_az_px * n_rg_px) if n_el > 1 else (n_az_px, n_rg_px)  # 3D: blocks of whole elevation planes
    n_pix = n[0] * n[1]
    if n_pix > params.max_pixels:
        raise InputError(
            f"backproject.max_pixels: the grid of ~{n[0]} x {n[1]} pixels exceeds {params.max_pixels}; "
            "set backproject azimuth/range (elevation) extents or spacings, or raise max_pixels"
        )
    # the raw data and its range-compressed copies (about four input-sized arrays, measured), at most
    # 64 pulses upsampled at a time, and per pixel of one output block its complex128 sum and float64
    # positions: the image itself is written block by block, never held whole
    block = backproject_block_pixels(header, params, memory_limit, grid)
    memory = _backproject_fixed_bytes(n_ch, n_az, n_rg, params) + BACKPROJECT_BYTES_PER_PIXEL * min(n_pix, block)
    per = COMPILED_PIXEL_PULSE_SECONDS if params.engine == "compiled" else 25e-9
    detail = f"~{n[0]} x {n[1]} pixels from {n_ch * n_az} pulses"
    if n_pix > block:
        detail += f", in {-(-n[0] // max(1, block // n[1]))} blocks of {max(1, block // n[1])} rows"
    seconds = n_ch * n_az * (n_pix * per + _compiled_tile_seconds(header, params, grid))
    if params.engine == "ffbp":
        from sarproc.focus.ffbp import error_bound, subaperture_lengths, taps_of

        lengths = subaperture_lengths(n_az, params.ffbp_factor, params.ffbp_first_factor)
        q = params.ffbp_oversample
        taps = taps_of(params.ffbp_interpolation, params.ffbp_taps)
        if grid is None:
            from sarproc.focus.backprojection import plan_backprojection

            grid = plan_backprojection(header, params)
        err = ffbp_predicted_error(header, params, grid, block)
        # all pulses upsampled at once, and two levels' polar images (at most ~q^2 samples per pixel each)
        memory += complex_bytes(n_az, n_rg * params.range_upsample) + 2 * complex_bytes(n_pix) * q * q
        # ~q^2 / 3 polar samples per pixel per level (pixels ~3 per resolution cell); one core's time per read
        # measured on the 1024^2 bench grid (scripts/bench.py ffbp stage times x 2 cores, the third round's
        # vectorised kernels): a pulse read of the first level ~6 ns, a two-pass polar read ~(taps + 12) ns, an
        # output point's 2D read ~0.85 taps^2 ns (every pixel: an upper bound where a coarse grid is read instead)
        per_sample = (params.ffbp_first_factor or params.ffbp_factor) * 6e-9 + (len(lengths) - 1) * (
            params.ffbp_factor * (taps + 12) * 1e-9
        )
        seconds = n_ch * (n_pix * q * q / 3 * per_sample + n_pix * 0.85e-9 * taps * taps)
        first = "" if params.ffbp_first_factor == params.ffbp_factor else f" (first {params.ffbp_first_factor})"
        reads = f"knab {taps}" if params.ffbp_interpolation == "knab" else params.ffbp_interpolation
        detail += (
            f"; ffbp: {len(lengths)} levels of {params.ffbp_factor}{first}, oversample {q:g}, "
            f"{reads}; predicted error against the exact image "
            f"{10 * math.log10(max(err, 1e-30)):.1f} dB (at most "
            f"{10 * math.log10(max(error_bound(err), 1e-30)):.1f})"
        )
    kernel_modules = None
    if params.engine == "compiled" and params.interpolation == "linear":
        from sarproc.focus import backprojection_aot

        # a small image runs the kernels compiled ahead of time (no numba, nothing to compile) once they are built
        if backprojection_aot.compiled_pays(n_az * min(n_pix, block)) and backprojection_aot.load():
            kernel_modules = ()
    seconds += THEORY_SECONDS_PER_TARGET * (len(header.targets) + 1)
    return Plan(stage, stored_bytes(*n), memory, seconds, detail, kernel_modules)


def ffbp_predicted_error(header: Product, params: Any, plan: BackprojectionPlan, block_pixels: int) -> float:
    """ffbp's predicted error against the exact image (power, relative) on the grid the run will use: the
    geometry's own tree (:func:`sarproc.focus.ffbp.predicted_image_error`; the geometry-free model is up to
    5.7 dB off at squint), each output block being its own tree, the worst of the first, middle and last."""
    from sarproc.focus.backprojection import row_blocks
    from sarproc.focus.ffbp import predicted_image_error, pulse_oversample

    az, rg = (plan.coords[d] for d in plan.dims)
    blocks = row_blocks(plan.shape, block_pixels)
    tx = header.aux["platform_position"] + header.aux.get("tx_offset", np.zeros(3))
    r = header.radar
    pulse_q = pulse_oversample(header_shape(header)[-1], params.range_upsample, r.range_sampling_rate, r.bandwidth)
    errors = []
    for i in sorted({0, len(blocks) // 2, len(blocks) - 1}):
        # the model reads the grid's plane and outline only: ~64 rows and columns of the block, its edges kept,
        # spare the plan the ~0.4 us per pixel of every point's position
        rows, cols = (
            unique_integers(np.linspace(0, n - 1, min(n, 64)).round().astype(int)) for n in (len(az), len(rg))
        )
        rows = rows[(rows >= blocks[i].start) & (rows < blocks[i].stop)]
        rows = unique_integers(np.r_[rows, blocks[i].start, blocks[i].stop - 1])
        grid = np.meshgrid(az[rows], rg[cols], indexing="ij")
        errors.append(
            predicted_image_error(
                tx,
                plan.frame.to_xyz(*(g.ravel() for g in grid)),
                r.carrier_frequency,
                r.bandwidth,
                grid_shape=grid[0].shape,
                factor=params.ffbp_factor,
                first_factor=params.ffbp_first_factor,
                oversample=params.ffbp_oversample,
                ffbp_interpolation=params.ffbp_interpolation,
                ffbp_taps=params.ffbp_taps,
                pulse_oversample=pulse_q,
                pulse_interpolation=params.interpolation,
            )
        )
    return max(errors)


def pfa2_estimate(stage: str, header: Product, params: Any) -> Plan:
    """The phase history and its polar-to-rectangular resampling, the image and its sub-images: about
    three input-sized and three image-sized complex64 arrays (fitted to nie2016_small, 385 MB, and the
    full Table 1 scene, 11.1 GB, docs/pfa.md); cost per input sample and per pixel (fitted to the small
    configs and the two full Table 1 scenes, 391 s and 190 s two-step)."""
    from sarproc.focus.pfa.chain import check_polar_support

    if header.kind == "raw" and "platform_position" in header.aux:
        check_polar_support(header)  # no common rectangle: refused here as the run would
    n_in = math.prod(header_shape(header))
    n = image_pixels(header, params)
    n_pix = n[0] * n[1]
    return Plan(
        stage,
        stored_bytes(*n),
        3 * complex_bytes(n_in) + 3 * complex_bytes(n_pix),
        0.5e-6 * n_in + 1.2e-6 * n_pix,
        f"~{n[0]} x {n[1]} pixels from {n_in} samples",
    )


def reconstruct_estimate(stage: str, header: Product, params: Any) -> Plan:
    """The channels' range spectra (zero-padded) in several complex64 copies at once: the deramped
    spectra, their azimuth FFT, the reconstructed N-PRF signal in (f_a, f_r) and (t, f_r), and for
    the modified method its range-time copies; about eight input-sized arrays (measured). With the clutter
    null and a chirp band narrower than the range sampling rate, one more copy of the zero-padded spectra:
    the in-band channels the detection, the velocity fit and the null fit read (reconstruct.py)."""
    from sarproc.focus.multichannel.reconstruct import range_padding

    n_ch, n_az, n_rg = header_shape(header)
    n = n_ch * n_az * n_rg
    memory = 8 * complex_bytes(n)
    r = header.radar
    if params.clutter_suppression and r.bandwidth < r.range_sampling_rate:
        times = np.asarray(header.coords["azimuth_time"], float)
        n_fft = range_padding(n_rg, r.velocity, r.squint, times, r.prf, r.range_sampling_rate)[0]
        memory += complex_bytes(n_ch, n_az, n_fft)
    # the filter bank, and the modified method's detection and velocity searches (refitted 2026-12-06: xu_small's
    # modified run took 0.53 s as a process on the idle machine against 1.1 s planned, 2.06x; now 0.84 s, 1.6x)
    per_sample = 0.3e-6
    if params.clutter_suppression:  # the clutter null's projections and the movers' searches after it
        per_sample = 2.5e-6  # (xu_clutter: 24 s of CPU for 9.7e6 samples)
    return Plan(
        stage,
        stored_bytes(n_ch * n_az, n_rg),
        memory,
        n * per_sample,
        f"{n_ch} channels x {n_az} pulses x {n_rg} samples -> {n_ch * n_az} pulses",
    )


def array3d_estimate(stage: str, header: Product, params: Any) -> Plan:
    n_ch, n_az, n_rg = header_shape(header)
    n_el = int(params.elevation_zero_padding * n_ch)
    raw = complex_bytes(n_ch, n_az, n_rg)
    cube = complex_bytes(n_el, n_az, n_rg)
    item = 8 if params.precision == "float32" else 16
    # the raw data, its range- and azimuth-compressed copies, one uncropped cube; the time is the
    # elevation DFT (n_el x n_ch per pixel, ~1.6 ns per complex multiply-add with its blocks
    # quiet, ~2.4 ns on the loaded shared machine: 2.0 keeps the plan within 2x of both)
    return Plan(
        stage,
        stored_bytes(n_el, n_az, n_rg),
        raw + 2 * complex_bytes(n_ch, n_az, n_rg, itemsize=item) + cube,
        n_ch * n_az * n_rg * 30e-9 + n_el * n_ch * n_az * n_rg * 2.0e-9,
        f"{n_ch} channels -> ~{n_el} elevation bins x {n_az} x {n_rg}",
    )
