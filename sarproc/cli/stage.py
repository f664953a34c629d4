"""The order every processing subcommand follows, and each stage's resource estimate.

1. parameters (``--config`` section), 2. the input's header (every layout check, no data read),
3. the output location (exists? writable?), 4. the plan (output size, peak memory, run time;
printed with -v, refused when it cannot fit), 5. the data, 6. the work, 7. the atomic write.
So a bad scene or config is reported before "output exists", and nothing is computed for an
output that cannot be written. Errors from the core that name no file get the input's name.

A plan is for the whole process, as ``/usr/bin/time`` would measure it: peak RSS and wall time. Each
stage's estimate models its own arrays (sizes times the copies it holds at its peak) and its work
(FFT and kernel rates); :func:`whole_process` adds what every run costs besides, measured on the
reference machine (2-core x86-64, 2026-12; ``scripts/plan_accuracy.py``): the interpreter with
numpy, scipy, h5py, numba and the stage's modules, and, while the compiled kernels are not yet in
numba's cache, their compilation. ``make plan-accuracy`` sets every plan against the measured run
(docs/plans.md); the aim is within 2x of both.
"""

from __future__ import annotations

import contextlib
import dataclasses
import math
from pathlib import Path
from typing import TYPE_CHECKING

import click

from sarproc.cli.options import dry_run, info, load_config, max_memory
from sarproc.product.budget import Plan, check_plan, complex_bytes, stored_bytes
from sarproc.product.errors import InputError

if TYPE_CHECKING:
    from collections.abc import Callable, Iterable, Iterator, Sequence
    from typing import Any

    from sarproc.product.model import Product
    from sarproc.simulation.scene import Scene

C = 299_792_458.0


@contextlib.contextmanager
def naming(
    input_path: str | Path | None, config_path: str | Path | None = None, section: str | None = None
) -> Iterator[None]:
    """Give a core InputError the file it is about: the config for ``section.key`` messages, else the input."""
    try:
        yield
    except InputError as exc:
        msg = str(exc)
        if str(input_path) in msg or (config_path is not None and str(config_path) in msg):
            raise
        if config_path is not None and section and msg.startswith((section + ".", section + ":")):
            raise InputError(f"{config_path}: {msg}") from None
        raise InputError(f"{input_path}: {msg}") from None


def prepare(
    stage: str,
    input_path: Path,
    outputs: Sequence[Path | None],
    config_path: Path | None,
    overwrite: bool,
    kinds: tuple[str, ...],
    params_cls: type,
    section: str,
    estimate: Callable[..., Plan] | None = None,
) -> tuple[Any, Product]:
    """Steps 1-5 above; returns (params, product) ready for the work."""
    from sarproc.product.io import read_product

    params: Any = load_config(params_cls, config_path, section=section)
    header = read_product(input_path, kinds=kinds, load=False)
    plan_outputs(
        input_path,
        outputs,
        overwrite,
        lambda: (estimate or generic_estimate)(stage, header, params),
        config_path=config_path,
        section=section,
    )
    product = read_product(input_path, kinds=kinds)
    return params, product


def plan_outputs(
    input_path: str | Path,
    outputs: Sequence[Path | None],
    overwrite: bool,
    estimate: Callable[[], Plan],
    inputs: Sequence[Path] | None = None,
    config_path: Path | None = None,
    section: str | None = None,
) -> Plan:
    """Steps 3-4 above for a checked input: every output writable, then ``estimate()``'s plan printed
    with -v and refused when it cannot fit. ``inputs``: the files the outputs must not replace
    (default ``[input_path]``). Returns the plan."""
    from sarproc.product.io import check_output_path

    paths = [Path(o) for o in outputs if o is not None]
    for out in paths:
        check_output_path(out, [input_path] if inputs is None else inputs, overwrite)
    with naming(input_path, config_path, section):
        plan = estimate()
    report_plan(plan, paths, input_path)
    return plan


# stage: (peak RSS bytes, seconds) of a run on a tiny scene with the kernels cached: imports (numpy,
# scipy, h5py ~75 MB, numba ~90 MB more, 0.5-1 s), reading and writing the products, the kernels loaded.
PROCESS = {
    "simulate": (185e6, 0.9),
    "preprocess": (225e6, 1.1),
    "coarse-focus": (195e6, 0.8),
    "fine-focus": (230e6, 1.1),
    "backproject": (240e6, 1.1),
    "pfa2": (290e6, 1.4),
    "reconstruct": (255e6, 0.9),
    "array3d": (215e6, 1.0),
    "evaluate": (135e6, 0.9),
    "export-sicd": (85e6, 0.9),
    "export-cphd": (125e6, 1.7),
    "import-cphd": (120e6, 0.8),
    "import-gotcha": (88e6, 0.6),
    "quicklook": (105e6, 1.1),
}
# stage: (the numba modules it runs, seconds and bytes to compile them when numba's cache lacks them)
KERNELS = {
    "simulate": (("sarproc.simulation.echo_kernel",), 12.0, 60e6),
    "preprocess": (("sarproc.dsp.phasor",), 0.5, 10e6),
    "fine-focus": (
        (
            "sarproc.focus.squint_deramp.stolt",
            "sarproc.focus.squint_deramp.block_copies",
            "sarproc.focus.squint_deramp.fine_focus",
            "sarproc.dsp.interp",
            "sarproc.dsp.phasor",
        ),
        10.0,
        70e6,
    ),
    "backproject": (("sarproc.focus.backprojection_kernel", "sarproc.dsp.phasor"), 14.0, 105e6),
}


def kernels_cached(modules: Iterable[str]) -> bool:
    """Whether numba's cache holds the kernels of ``modules``: each module with cached kernels has
    the index file of at least one (a kernel a stage never calls, e.g. cubic interpolation's table
    in a linear run, is never compiled, so not every index exists after a run)."""
    import importlib
    import os

    from numba.core.registry import CPUDispatcher

    for name in modules:
        indexes = [
            obj._cache._cache_file._index_path
            for obj in vars(importlib.import_module(name)).values()
            if isinstance(obj, CPUDispatcher) and hasattr(obj._cache, "_cache_file")
        ]
        if indexes and not any(os.path.exists(p) for p in indexes):
            return False
    return True


def whole_process(plan: Plan) -> Plan:
    """``plan`` (the stage's own arrays and work) plus the process around it (see the module doc)."""
    memory, seconds = PROCESS.get(plan.stage, (200e6, 1.0))
    detail = plan.detail
    modules, compile_s, compile_bytes = KERNELS.get(plan.stage, ((), 0.0, 0.0))
    if modules and not kernels_cached(modules):
        seconds += compile_s
        memory += compile_bytes
        detail = (detail + "; " if detail else "") + f"compiling its kernels first (~{compile_s:.0f} s, then cached)"
    return dataclasses.replace(
        plan, memory_bytes=plan.memory_bytes + memory, seconds=plan.seconds + seconds, detail=detail
    )


def report_plan(plan: Plan, outputs: Sequence[Path], input_path: str | Path | None) -> None:
    """Step 4: the plan printed (with -v), refused when it cannot fit; with --dry-run printed on
    stdout, and the run ends here (exit 0, nothing computed or written)."""
    plan = whole_process(plan)
    if not dry_run():
        info(plan.describe())
    with naming(input_path):
        check_plan(plan, [Path(o) for o in outputs if o is not None], max_memory())
    if dry_run():
        click.echo(plan.describe())
        raise click.exceptions.Exit(0)


def _shape(header: Product) -> tuple[int, ...]:
    """The data's shape, from a header read with load=False or from a loaded product."""
    return tuple(int(n) for n in header.attrs.get("shape", header.data.shape))


def generic_estimate(stage: str, header: Product, params: Any) -> Plan:
    """Output as large as the input, four input-sized arrays in memory, FFT-like cost."""
    n = math.prod(_shape(header))
    b = complex_bytes(n)
    return Plan(stage, b, 4 * b, n * 60e-9 * max(1.0, math.log2(max(n, 2)) / 10))


def preprocess_estimate(stage: str, header: Product, params: Any) -> Plan:
    n_az, n_rg = _shape(header)
    b = complex_bytes(n_az, n_rg)
    block = complex_bytes(min(params.block_pulses, n_az), n_rg, itemsize=16) * 4
    return Plan(stage, stored_bytes(n_az, n_rg), 2 * b + block, n_az * n_rg * 40e-9, f"{n_az} x {n_rg} samples")


def coarse_focus_estimate(stage: str, header: Product, params: Any) -> Plan:
    n_az, n_rg = _shape(header)
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
    M, n_r = _shape(header)
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


def image_grid(header: Product, params: Any) -> tuple[int, int]:
    """(azimuth, range) pixels of the image a focuser's extents/spacings give (backproject, pfa2 share
    the keys): the targets' extent plus margin_cells, spaced IRW / oversample unless set."""
    r = header.radar
    n_az = _shape(header)[-2]
    t_ap = max(n_az / r.prf, 1e-9)
    irw_rg = r.range_resolution
    irw_az = 0.886 * r.wavelength * r.reference_range / (2 * r.velocity * t_ap * max(math.cos(r.squint) ** 2, 1e-6))
    n = []
    for ax, irw in (("azimuth", irw_az), ("range", irw_rg)):
        spacing = getattr(params, f"{ax}_spacing") or irw / params.oversample
        extent = getattr(params, f"{ax}_extent")
        if extent is None:
            t = header.targets[ax] if len(header.targets) and ax in (header.targets.dtype.names or ()) else [0.0]
            extent = (max(t) - min(t)) + 2 * params.margin_cells * irw
        n.append(max(1, int(extent / spacing) + 1))
    return n[0], n[1]


# per pixel of an output block: its grid coordinates and float64 position, the kernel's tile order and offsets,
# two complex128 sums and the complex64 block (tracemalloc peak of backproject_rows: 127-136 B on 1024-2048 wide
# demo grids; 64 B, the old figure, let an 8192^2 run with --max-memory 384M peak at 466 MiB)
BACKPROJECT_BYTES_PER_PIXEL = 140.0


def _backproject_fixed_bytes(n_ch: int, n_az: int, n_rg: int, params: Any) -> float:
    raw = 4 * complex_bytes(n_ch, n_az, n_rg)
    up = complex_bytes(min(64, n_az), n_rg * params.upsample, itemsize=16)
    return raw + 2 * up


def backproject_block_pixels(header: Product, params: Any, memory_limit: int | None) -> int:
    """Pixels per output block: ``params.block_pixels``, fewer (whole rows, at least one) when the blocks
    would not fit ``memory_limit`` (bytes) beside the pulses and the process itself."""
    block = int(params.block_pixels)
    if memory_limit is None:
        return block
    n_az, n_rg = _shape(header)[-2:]
    n_ch = _shape(header)[0] if len(_shape(header)) == 3 else 1
    room = memory_limit - PROCESS["backproject"][0] - _backproject_fixed_bytes(n_ch, n_az, n_rg, params)
    row = image_grid(header, params)[1]
    return max(row, min(block, int(room / BACKPROJECT_BYTES_PER_PIXEL) // row * row))


def backproject_estimate(stage: str, header: Product, params: Any) -> Plan:
    n_az, n_rg = _shape(header)[-2:]
    n_ch = _shape(header)[0] if len(_shape(header)) == 3 else 1
    n = image_grid(header, params)
    n_pix = n[0] * n[1]
    if n_pix > params.max_pixels:
        raise InputError(
            f"backproject.max_pixels: the grid of ~{n[0]} x {n[1]} pixels exceeds {params.max_pixels}; "
            "set backproject azimuth/range extents or spacings, or raise max_pixels"
        )
    # the raw data and its range-compressed copies (about four input-sized arrays, measured), at most
    # 64 pulses upsampled at a time, and per pixel of one output block its complex128 sum and float64
    # positions: the image itself is written block by block, never held whole
    block = backproject_block_pixels(header, params, max_memory())
    memory = _backproject_fixed_bytes(n_ch, n_az, n_rg, params) + BACKPROJECT_BYTES_PER_PIXEL * min(n_pix, block)
    per = 4e-9 if params.engine == "compiled" else 25e-9
    detail = f"~{n[0]} x {n[1]} pixels from {n_ch * n_az} pulses"
    if n_pix > block:
        detail += f", in {-(-n[0] // max(1, block // n[1]))} blocks of {max(1, block // n[1])} rows"
    seconds = n_ch * n_az * n_pix * per
    if params.engine == "ffbp":
        from sarproc.focus.ffbp import error_bound, levels, predicted_error

        n_lev = levels(n_az, params.ffbp_factor)
        q = params.ffbp_oversample
        err = predicted_error(n_az, params.ffbp_factor, q, params.ffbp_interpolation)
        # all pulses upsampled at once, and two levels' polar images (at most ~q^2 samples per pixel each)
        memory += complex_bytes(n_az, n_rg * params.upsample) + 2 * complex_bytes(n_pix) * q * q
        # ~q^2 / 3 polar samples per pixel per level, factor reads each, ~100 ns a read (measured on the bench scene)
        seconds = n_ch * n_pix * n_lev * q * q / 3 * params.ffbp_factor * 100e-9
        detail += (
            f"; ffbp: {n_lev} levels of {params.ffbp_factor}, oversample {q:g}, "
            f"{params.ffbp_interpolation}; predicted error against the exact image "
            f"{10 * math.log10(max(err, 1e-30)):.1f} dB (at most "
            f"{10 * math.log10(max(error_bound(err), 1e-30)):.1f})"
        )
    return Plan(stage, stored_bytes(*n), memory, seconds, detail)


def pfa2_estimate(stage: str, header: Product, params: Any) -> Plan:
    """The phase history and its polar-to-rectangular resampling, the image and its sub-images: about
    three input-sized and three image-sized complex64 arrays (fitted to nie2016_small, 385 MB, and the
    full Table 1 scene, 11.1 GB, docs/pfa.md); cost per input sample and per pixel (fitted to the small
    configs and the two full Table 1 scenes, 391 s and 190 s two-step)."""
    n_in = math.prod(_shape(header))
    n = image_grid(header, params)
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
    the modified method its range-time copies; about eight input-sized arrays (measured)."""
    n_ch, n_az, n_rg = _shape(header)
    n = n_ch * n_az * n_rg
    # the modified method's detection and velocity searches nearly double the filter bank's time (measured)
    per_sample = 0.55e-6 if params.method == "modified" else 0.3e-6
    if params.clutter_suppression:  # the clutter null's projections and the movers' searches after it
        per_sample = 2.5e-6  # (xu_clutter: 24 s of CPU for 9.7e6 samples)
    return Plan(
        stage,
        stored_bytes(n_ch * n_az, n_rg),
        8 * complex_bytes(n),
        n * per_sample,
        f"{n_ch} channels x {n_az} pulses x {n_rg} samples -> {n_ch * n_az} pulses",
    )


def array3d_estimate(stage: str, header: Product, params: Any) -> Plan:
    n_ch, n_az, n_rg = _shape(header)
    n_el = int(params.elevation_zero_padding * n_ch)
    raw = complex_bytes(n_ch, n_az, n_rg)
    cube = complex_bytes(n_el, n_az, n_rg)
    item = 8 if params.precision == "float32" else 16
    # the raw data, its range- and azimuth-compressed copies, one uncropped cube; the time is the
    # elevation DFT (n_el x n_ch per pixel, measured ~4.5 ns per complex multiply-add with its blocks)
    return Plan(
        stage,
        stored_bytes(n_el, n_az, n_rg),
        raw + 2 * complex_bytes(n_ch, n_az, n_rg, itemsize=item) + cube,
        n_ch * n_az * n_rg * 30e-9 + n_el * n_ch * n_az * n_rg * 4.5e-9,
        f"{n_ch} channels -> ~{n_el} elevation bins x {n_az} x {n_rg}",
    )


def evaluate_estimate(stage: str, header: Product, params: Any) -> Plan:
    """The image and its magnitude; per target its chips (raw, neighbour-cleaned, their spectra, the
    support's gradients: held for every target) and the largest 1-D cut, whose interpolation kernel is
    (cut points) x (chip length) complex samples. Constants fitted to measured runs (docs/plans.md)."""
    from sarproc.quality.metrics import _make_axes

    shape = _shape(header)
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
    memory = (15.0 if len(shape) < 3 else 30.0) * n + 160.0 * n_tg * chip + 32.0 * cut
    # neighbours are fitted jointly, so a target's work grows with how many there are (up to the few
    # whose chips can overlap it)
    # (constants halved after the residual-model merge, measured on an idle 2-core machine: demo 1.0 s,
    # bp_squint30 1.2 s, the du2010 cube 14.8 s of wall time with the process, against 2.3 / 1.5 / 30 s planned)
    seconds = n * 10e-9 + n_tg * (0.05 + 1.5e-7 * cut) + 1.25e-6 * chip * n_tg * (1 + min(n_tg, 8) / 4)
    # the JSON report: about 3 kB per target (figures are not counted)
    return Plan(
        stage,
        1e3 + 3.5e3 * n_tg,
        memory,
        seconds,
        f"{n_tg} targets on {n} pixels, chips of {' x '.join(map(str, lengths))}",
    )


def quicklook_estimate(stage: str, header: Product, max_pixels: int) -> Plan:
    """The picture: every drawn pixel (2D: the image reduced to max_pixels per axis; 3D: its three
    projections) through matplotlib's rendering, ~75 bytes and 0.3 us each (measured), the image read
    block by block."""
    shape = _shape(header)
    side = [min(n, max_pixels) for n in shape]
    drawn = math.prod(side) if len(side) < 3 else side[0] * side[1] + side[0] * side[2] + side[1] * side[2]
    return Plan(
        stage,
        1e5,
        75.0 * drawn,
        0.3e-6 * drawn + 50e-9 * math.prod(shape),
        f"{drawn} pixels drawn from {math.prod(shape)}",
    )


def simulate_estimate(scene: Scene) -> Plan:
    """Raw product size, memory and time of ``scene`` before planning it (cheap: three pulses)."""
    import numpy as np

    r = scene.radar
    n_p = scene.n_pulses
    n_tg = len(scene.target_xyz)
    acq = scene.params.acquisition
    fs = r.range_sampling_rate
    n_ch = max(1, int(r.n_channels))
    for e in scene.effects:  # receive channels of array effects
        tx, rx = e.channels(np.zeros(3), np.zeros((1, 3)))
        n_ch = max(n_ch, len(np.asarray(rx).reshape(-1, 3)))
    if acq.range_window is not None:
        span = 2 * (acq.range_window.end - acq.range_window.start) / C
    elif n_tg:
        t = scene.azimuth_time()[[0, n_p // 2, -1]]
        pos = np.stack([r.velocity * t, np.zeros(3), np.full(3, r.altitude)], axis=1)
        d = 2 * np.linalg.norm(scene.target_xyz[None, :, :] - pos[:, None, :], axis=-1) / C
        span = float(d.max() - d.min()) + r.pulse_duration + 4 * acq.range_margin / C
    else:
        span = 2 * r.pulse_duration
    n_rg = int(math.ceil(span * fs)) + 1
    n_env = min(int(math.ceil(r.pulse_duration * fs)) + 2, n_rg)
    block = min(scene.params.simulation.block_pulses, n_p)
    out = stored_bytes(*((n_ch,) if n_ch > 1 else ()), n_p, n_rg)
    # The automatic window takes delays of every pulse, channel and target at once (plan_simulation).
    window_plan = 0.0 if acq.range_window is not None else n_p * n_tg * 8.0 * (n_ch + 7)
    mem = (
        complex_bytes(n_ch, block, n_rg + 2 * n_env, itemsize=16)
        + complex_bytes(block, n_env, itemsize=16) * 6
        + block * n_tg * 8 * 8.0
        + max(window_plan, complex_bytes(n_ch, block, n_rg))
    )
    # compiled echo accumulation: ~1.5 ns per echo sample (one complex multiply-add, 2 threads, shared
    # machine), ~0.1 us per (pulse, target) pair, ~10 ns per stored sample (zeroing, chirp, cast, write);
    # measured: nie2016 (1.1e10 echo samples) 17 s of CPU, xu_clutter 2.0 s, demo 0.9-1.2 s with the process
    seconds = n_ch * n_p * n_tg * (n_env * 1.5e-9 + 0.1e-6) + n_ch * n_p * n_rg * 10e-9
    from sarproc.simulation.effects.clutter import Clutter, clutter_cost

    for e in scene.effects:  # clutter scatterers: the same ~1.5 ns per echo sample (xu_clutter: 4.9e8, 2.0 s)
        if isinstance(e, Clutter):
            seconds += 1.5e-9 * clutter_cost(n_p, n_ch, e.params.n_scatterers, n_env)
    window = (
        "acquisition.range_window"
        if acq.range_window is not None
        else f"the targets' delays + radar.pulse_duration {r.pulse_duration:g} s"
    )
    detail = (
        f"{n_ch} x {n_p} pulses x {n_rg} samples, {n_tg} targets; samples = {window} "
        f"x radar.range_sampling_rate {fs:g} Hz"
    )
    return Plan("simulate", out, mem, seconds, detail)


def export_sicd_estimate(stage: str, header: Product, params: Any) -> Plan:
    """SICD holds complex64 pixels; the image, its reordered copy and the read-back are in memory."""
    n = math.prod(_shape(header))
    return Plan(stage, complex_bytes(n) + 1e5, 3 * complex_bytes(n), n * 50e-9, f"{n} pixels")


def export_cphd_estimate(stage: str, header: Product, params: Any) -> Plan:
    """CPHD holds the FX-domain signal (complex64) and 200 bytes of per-vector parameters per pulse."""
    n_az, n_rg = _shape(header)[-2:]
    n = n_az * n_rg
    return Plan(
        stage,
        complex_bytes(n) + 200.0 * n_az + 1e5,
        complex_bytes(n) + 3 * complex_bytes(n, itemsize=16),
        n * 80e-9,
        f"{n_az} vectors x {n_rg} samples",
    )


def import_cphd_estimate(stage: str, cphd: dict) -> Plan:
    n_v, n_s = cphd["vectors"], cphd["samples"]
    n = n_v * n_s
    return Plan(
        stage,
        stored_bytes(n_v, n_s),
        complex_bytes(n) + 3 * complex_bytes(n, itemsize=16),
        n * 80e-9,
        f"{n_v} vectors x {n_s} samples",
    )


def import_gotcha_estimate(stage: str, files: Sequence[Path]) -> Plan:
    """Gotcha files store complex64 samples: the product is about their size; read as complex128, twice."""
    size = float(sum(Path(f).stat().st_size for f in files))
    return Plan(stage, size, 5 * size, size * 10e-9, f"{len(files)} file(s), {size / 1e6:.3g} MB")
