"""Resource plans of evaluate and quicklook (sarproc.product.budget has the Plan and the process around it)."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from sarproc.product.aot import NUMBA_STARTUP_S
from sarproc.product.budget import Plan, header_shape
from sarproc.product.errors import InputError
from sarproc.product.io import PREVIEW_BLOCK_BYTES, preview_shape
from sarproc.quality import kernels_aot, residual_aot

if TYPE_CHECKING:
    from typing import Any

    from sarproc.product.model import Product


# what running a cube's kernels through numba adds to evaluate's peak RSS (the same runs, SARPROC_AOT=0 against
# 1): du2010_wide_swath +110 MB, paper 004's cube +123 MB
NUMBA_CUBE_BYTES = 120e6
# what starting numba adds to a 2D evaluate beyond its residual's fitted time (0.4 s of numba's import, runtime
# and kernels less the ~0.3 s those runs already held: NUMBA_STARTUP_S); kept when session 37 refitted
# product.budget.NUMBA_PROCESS for the stages, whose figures are runs without numba
EVALUATE_NUMBA_S = 0.1


def evaluate_estimate(stage: str, header: Product, params: Any) -> Plan:
    """The image and its magnitude; per target its chips (raw, neighbour-cleaned, their spectra, the
    support's gradients: held for every target) and the largest 1-D cut, whose interpolation kernel is
    (cut points) x (chip length) complex samples. Constants fitted to measured runs (docs/plans.md)."""
    from sarproc.quality.metrics import _make_axes

    shape = header_shape(header)
    n, n_tg = math.prod(shape), len(header.targets)
    irw = header.attrs.get("theoretical_irw")
    if irw is None:  # the same refusal evaluate_product makes, before any work
        raise InputError(f"image attribute 'theoretical_irw' is missing (expected one IRW per axis {header.dims})")
    axes = _make_axes(shape, header.dims, header.coords, irw, params.irw_factor)
    lengths = [2 * ax.nulls_to_samples(params.islr_nulls + params.margin_nulls) + 1 for ax in axes]
    chip = math.prod(lengths)
    cut = max(
        (2 * math.ceil((params.islr_nulls + 2) * ax.null * params.upsample) + 1) * L for ax, L in zip(axes, lengths)
    )
    if len(shape) < 3:
        memory = 15.0 * n + 160.0 * n_tg * chip + 32.0 * cut
    else:
        # fitted to two cubes with the kernels compiled ahead of time (session 26, peak RSS less PROCESS's):
        # du2010_wide_swath 252 MB (3 targets, 6.2 M voxels), paper 004's 417 MB (7, 1.8 M), where the former
        # 30 B a voxel and 160 B a chip sample planned them at 2.3x / 1.9x; through numba (its runtime, threads
        # and cached kernels) 362 / 540 MB
        memory = 4.0 * n + 80.0 * n_tg * chip + 32.0 * cut
        if not kernels_aot.runs_compiled(n_tg, 0 if params.exact else chip):
            memory += NUMBA_CUBE_BYTES
    # neighbours are fitted jointly, so a target's work grows with how many there are (up to the few
    # whose chips can overlap it)
    # (constants halved after the residual-model merge, measured on an idle 2-core machine: demo 1.0 s,
    # bp_squint30 1.2 s, the du2010 cube 14.8 s of wall time with the process, against 2.3 / 1.5 / 30 s planned;
    # halved again after the cuts became non-uniform FFTs: demo 0.37 s of CPU in process, 0.76 s as a process;
    # x0.6 after the one-thread BLAS and Gram-update fits: the demo's whole process 0.40-0.44 s on an idle machine)
    seconds = 0.6 * (n * 10e-9 + n_tg * (0.025 + 0.75e-7 * cut) + 0.6e-6 * chip * n_tg * (1 + min(n_tg, 8) / 4))
    residual = bool(params.residual and len(shape) == 2)
    if residual:
        # the residual (default on 2D images): per target its model's fit, and its subtraction where it
        # reaches, about the image for each of the first few targets (measured: the demo, 5 targets on
        # 189 k pixels, 0.8 s in process on an idle machine; 002 two-step, 25 on 1.76 M, about 4 s). Since the
        # fits run to convergence (session 14) a fit costs about 4e-5 s per chip sample: whole processes on an
        # idle 2-core machine, demo 2.84 s (5 targets, chips 93 x 93), bp_squint30 1.37 s (3, 75 x 75),
        # nie2016_small 6.81 s (25, 77 x 73), against 1.2 / 0.72 / 8.1 s planned before. Refitted in session 30:
        # the demo's process 1.21-1.31 s (kernels compiled ahead of time) and 1.42 s (numba's, CI's fresh clone)
        # against 2.5 / 2.9 s planned, bp_squint30's 0.62 s against 1.0, so a quiet machine ran the demo over
        # twice as fast as planned (tests/cli/test_plans.py failed at 2.04x): 2.5e-5 s per chip sample. Sessions
        # 37-39 cut the fits (the demo's evaluate 1.3 -> 0.95 s CPU); session 39's idle CI run of the demo through
        # numba took 1.015 s wall against 2.2 s planned (2.17x, failed): 0.06 s and 1.7e-5 s per chip sample plan
        # it at 1.8 s (1.8x). With the kernels compiled ahead (scripts/evaluate_speed.py's CPU seconds, ev39a):
        # demo 1.4 s against 0.96 (1.5x), bp_squint30 0.6 / 0.47, 000 small 1.3 / 0.97, 002 small plain 6.8 /
        # 4.04, bp_stripmap 0.59 / 1.00 (0.6x); bp_beam_edge 0.98 / 3.23 (0.3x; 0.4x before this refit: its fits'
        # time does not follow the chip's size)
        seconds += n_tg * (0.06 + 1.7e-5 * chip) + 0.15e-6 * n * min(n_tg, 8)
        memory += 24.0 * n  # the residual image (complex128) and its masks
    # the residual's kernels compiled ahead of time, once built (sarproc.quality.residual_aot): no numba to load,
    # nothing to compile; else numba's runtime and its cached kernels, loaded only here (demo: 70 -> 185 MB)
    aot = residual and residual_aot.RESIDUAL.load() is not None
    if residual and not aot:
        memory += 60e6
    if aot:  # the residual's time above was fitted to runs that started numba (~0.3 s), which this one skips
        seconds = max(0.5 * seconds, seconds - NUMBA_STARTUP_S)
    elif residual:  # numba's start measured whole (xu_small's run 0.64 s AOT, 1.29 s through numba)
        seconds += EVALUATE_NUMBA_S
    # the JSON report: about 3 kB per target (figures are not counted)
    return Plan(
        stage,
        1e3 + 3.5e3 * n_tg,
        memory,
        seconds,
        f"{n_tg} targets on {n} pixels, chips of {' x '.join(map(str, lengths))}",
        # the residual's kernels only: sarproc.quality.kernels serve 3D cubes, whose plan checks none
        kernel_modules=("sarproc.quality.residual_kernels",) if residual and not aot else (),
    )


# (bytes, seconds) matplotlib's figure and Agg canvas add to a quicklook process: demo 1.32 against 0.45 s and
# 59 MB builtin (docs/performance.md, twelfth round)
MATPLOTLIB_IMPORT = (45e6, 0.7)


def quicklook_estimate(stage: str, header: Product, max_pixels: int, renderer: str = "builtin") -> Plan:
    """The picture: every drawn pixel (2D: the image reduced to max_pixels per axis; 3D: its three
    projections) drawn and PNG-encoded, ~32 bytes and 0.14 us each with the builtin renderer (a 2048 x 2048
    noisy preview: 0.35 s drawing, 0.22 s zlib), ~75 bytes and 0.3 us through matplotlib's, whose import adds
    MATPLOTLIB_IMPORT; the image read block by block, ~15 ns a pixel since the magnitude is cleaned in place
    (session 25, idle: a 4096^2 image's process 0.90 s, the du2010 cube's 0.26 s, against 1.7 / 0.61 s planned
    at 50 ns; all measured)."""
    shape = header_shape(header)
    side = [min(n, max_pixels) for n in shape]
    drawn = math.prod(side) if len(side) < 3 else side[0] * side[1] + side[0] * side[2] + side[1] * side[2]
    per_pixel = (75.0, 0.3e-6) if renderer == "matplotlib" else (32.0, 0.14e-6)
    base = MATPLOTLIB_IMPORT if renderer == "matplotlib" else (0.0, 0.0)
    # the preview (float32, every axis reduced: a 3D cube's is the whole cube, not only the projections drawn)
    # and the block being read (sarproc.product.io.PREVIEW_BLOCK_BYTES): the du2010 cube 52 -> 131 MB measured
    preview = math.prod(preview_shape(shape, max_pixels)[1])
    reading = 2.5 * min(PREVIEW_BLOCK_BYTES, 8 * math.prod(shape)) + 4.0 * preview
    return Plan(
        stage,
        1e5,
        base[0] + per_pixel[0] * drawn + reading,
        base[1] + per_pixel[1] * drawn + 15e-9 * math.prod(shape),
        f"{drawn} pixels drawn from {math.prod(shape)}",
    )
